"""Random hidden effects at realistic magnitudes, for tests, demos and technician training.

Magnitudes are relative to the joint's own friction and travel, so a scenario is as hard on
a 0.1 N·m direct drive as on a 1500 N·m geared joint.  Seeds decide everything: tuning and
testing use disjoint seed ranges (see tests/).
"""
from __future__ import annotations

import math

import numpy as np

from virtual_drives.joint import JointSpec, simulate_record

# effect -> a function (spec, travel, duration, rng) -> injection text for --effect
def _sym(rng, lo, hi):
    return float(rng.uniform(lo, hi) * rng.choice((-1.0, 1.0)))


def _inertia(spec, travel, T, rng):
    f = rng.uniform(0.6, 0.85) if rng.random() < 0.5 else rng.uniform(1.2, 1.6)
    return f"inertia_error:factor={f:.4f}"


def _asym(spec, travel, T, rng):
    return f"direction_asymmetry:ratio={_sym(rng, 0.04, 0.15):.4f}"


def _cogging(spec, travel, T, rng):
    amp = rng.uniform(0.03, 0.10) * spec.friction.Fc
    pitch = travel / rng.uniform(4.0, 20.0)
    return f"cogging:amplitude={amp:.6g},pitch={pitch:.6g},phase={rng.uniform(0, 2 * math.pi):.4f}"


def _posfric(spec, travel, T, rng):
    pitch = travel / rng.uniform(2.0, 8.0)
    return (f"position_dependent_friction:amplitude={rng.uniform(0.05, 0.15):.4f},pitch={pitch:.6g},"
            f"phase={rng.uniform(0, 2 * math.pi):.4f}")


def _gravity(spec, travel, T, rng):
    amp = rng.uniform(0.03, 0.10) * spec.friction.Fc
    return f"gravity:amplitude={amp:.6g},phase={rng.uniform(0, 2 * math.pi):.4f}"


def _offset(spec, travel, T, rng):
    return f"torque_offset:value={_sym(rng, 0.02, 0.08) * spec.friction.Fc:.6g}"


def _thermal(spec, travel, T, rng):
    return f"thermal_drift:gain={-rng.uniform(0.08, 0.2):.4f},tau={rng.uniform(0.2, 1.0) * T:.4g}"


def _stribeck(spec, travel, T, rng):
    d = rng.uniform(1.8, 2.5) if rng.random() < 0.5 else rng.uniform(0.5, 0.7)
    return f"stribeck_shape:delta={d:.4f}"


def _lag(spec, travel, T, rng):
    # a current loop or a command held to the next SYNC: a few ms; in tenths of a period of
    # the excitation that is what a direct drive shows, a slow macro joint hardly at all
    return f"torque_lag:delay={rng.uniform(0.002, 0.008):.5f}"


def _backlash(spec, travel, T, rng):
    # geared joints: spur/planetary trains of a heavy arm wear to 3-15 arcmin (1-4 mrad) at
    # the output, the paper's "considerable mismatches"; direct drives: the play of a
    # coupling to the payload, tens of micrometres on a stage, a few mrad on a rotary joint
    if spec.joint_type == "prismatic":
        width = rng.uniform(40e-6, 120e-6)
    else:
        width = rng.uniform(1.0e-3, 4.0e-3)
    return f"backlash:width={width:.6g}"


def _flexibility(spec, travel, T, rng):
    # locked-rotor resonances: 3-8 Hz for a heavy geared arm (long links, large reduction),
    # 10-30 Hz for a direct drive with a compliant coupling or tool; lightly damped
    f = rng.uniform(3.0, 8.0) if spec.gear_ratio > 1 else rng.uniform(10.0, 30.0)
    return f"joint_flexibility:frequency={f:.4g},damping={rng.uniform(0.03, 0.12):.4f}"


def _damping(spec, travel, T, rng):
    # LuGre simulators that fade sigma1 set v_d near the Stribeck velocity 1/alpha or below
    # it; the fade matters from about a third of it down (bench.effects.damping_fade)
    return f"damping_fade:vd={rng.uniform(0.15, 0.35) / spec.friction.alpha:.5g}"


GENERATORS = {
    "inertia_error": _inertia, "direction_asymmetry": _asym, "cogging": _cogging,
    "position_dependent_friction": _posfric, "gravity": _gravity, "torque_offset": _offset,
    "thermal_drift": _thermal, "stribeck_shape": _stribeck, "torque_lag": _lag,
    "backlash": _backlash, "joint_flexibility": _flexibility, "damping_fade": _damping,
}


def travel_of(spec: JointSpec, duration: float = 20.0) -> float:
    """Travel of the joint's default excitation (what a position pitch is relative to)."""
    sim = simulate_record(spec, *spec.excitation, duration=min(duration, 3.0 / spec.excitation[1]),
                          seed=0, torque_noise=0.0)
    return float(np.ptp(sim.true_q))


def random_effects(spec: JointSpec, effects: list[str], seed: int, duration: float = 20.0) -> list[str]:
    rng = np.random.default_rng(seed)
    travel = travel_of(spec, duration)
    return [GENERATORS[e](spec, travel, duration, rng) for e in effects]


def simulate_scenario(spec: JointSpec, effects: list[str], seed: int, duration: float = 20.0):
    """A record of ``spec`` with hidden ``effects`` drawn from ``seed``.
    Returns (Simulation, injection texts)."""
    from bench.effects.inject import parse_injections
    texts = random_effects(spec, effects, seed, duration)
    ev, factor, delta, lag = parse_injections(texts, spec)
    if delta is not None:
        spec = spec.with_(friction=spec.friction.with_(delta=delta))
    sim = simulate_record(spec, *spec.excitation, duration=duration, seed=seed, extra=ev,
                          declared_inertia=spec.inertia * factor, torque_lag=lag)
    sim.record.meta["injected"] = "; ".join(texts)
    return sim, texts
