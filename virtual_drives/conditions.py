"""Named recording conditions at realistic magnitudes, for tests, demos and training.

``CONDITIONS`` holds the conditions issue 11 lists, each a clean joint recorded a new way;
``EXTRA_CONDITIONS`` a few more (1/f noise, 500 Hz, whole robot logs).  Magnitudes are drawn
from the seed, relative to the joint's own friction (noise) and travel (encoder), so a
condition is as hard on a 0.1 N·m direct drive as on a 1500 N·m geared joint.  Tuning and
testing use disjoint seed ranges (tests/).  What a condition does not set stays the joint's
own (its torque-reading noise, encoder, sine test at 1 kHz).  Effects from the library are
injected on top with ``effects=["cogging:amplitude=...", ...]`` (see
``virtual_drives.scenarios``).

    record, truth = make_record(PRESETS["j1"], "coloured process noise", seed=5001)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from bench.errors import InputError
from virtual_drives.joint import JointSpec
from virtual_drives.recording import Logger, Recording, make


@dataclass(frozen=True)
class Condition:
    name: str
    summary: str
    build: Callable[[JointSpec, np.random.Generator], Recording]


def _fc(spec: JointSpec) -> float:
    return spec.friction.Fc


def _white(spec, rng):
    # drive current ripple and load shocks: 2-8 % of the Coulomb level, per control period
    return Recording(process_noise=rng.uniform(0.02, 0.08) * _fc(spec), process_noise_colour="white")


def _coloured(spec, rng):
    # a slowly wandering load or a current loop's low-frequency error: 1-4 % of Fc with a
    # correlation time of 5-50 ms, inside the band the identification keeps
    return Recording(process_noise=rng.uniform(0.01, 0.04) * _fc(spec), process_noise_colour="lowpass",
                     process_noise_tau=rng.uniform(0.005, 0.05))


def _pink(spec, rng):
    return Recording(process_noise=rng.uniform(0.01, 0.04) * _fc(spec), process_noise_colour="pink",
                     process_noise_tau=rng.uniform(0.2, 2.0))


def _reading(spec, rng):
    return Recording(torque_noise=rng.uniform(0.005, 0.03) * _fc(spec))


def _coarse(spec, rng):
    # 12-14 bits over the travel of the joint's sine test: 5k-20k counts per turn on the rotary
    # motor, 10-40 um on the linear stage, 2^16-2^18 per output turn on j1 (a motor encoder
    # behind its gear gives 2^22)
    from virtual_drives.scenarios import travel_of
    res = travel_of(spec) / 2.0 ** rng.uniform(12.0, 14.0)
    return Recording(encoder_resolution=max(res, spec.encoder_resolution))


def _rate(hz):
    return lambda spec, rng: Recording(rate=hz)


def _logger(rng) -> Logger:
    # a PC logger polling a 1 kHz drive: mean step 3-6 ms (steps 1-13 ms), 0.5-3 % of the
    # samples lost, 1-3 stalls of 30-300 ms a minute
    return Logger(step=rng.uniform(0.003, 0.006), drop=rng.uniform(0.005, 0.03),
                  gaps_per_minute=rng.uniform(1.0, 3.0))


def _jitter(spec, rng):
    return Recording(logger=_logger(rng))


def _friction(spec, rng):
    # the joint-torque sensor's noise after the rigid-body model: 0.5-2 % of Fc
    return Recording(output="friction", velocity_column=True,
                     torque_noise=rng.uniform(0.005, 0.02) * _fc(spec))


def _pd(spec, rng):
    return Recording(excitation="pd")


def _two_tone(spec, rng):
    return Recording(excitation="two-tone")


def _robot_log(spec, rng):
    """What a torque-sensing arm's log looks like: friction column, velocity, a PC logger,
    sensor noise and a little process noise, the joint tracking a PD reference."""
    return Recording(excitation="pd", output="friction", velocity_column=True, logger=_logger(rng),
                     torque_noise=rng.uniform(0.005, 0.02) * _fc(spec),
                     process_noise=rng.uniform(0.01, 0.03) * _fc(spec), process_noise_colour="white")


def _robot_log_slow(spec, rng):
    # the same arm published at 100-125 Hz (ROS joint_states, a UR's 125 Hz RTDE stream)
    step = rng.uniform(0.008, 0.010)
    logger = Logger(step=step, min_step=0.75 * step, max_step=1.6 * step, drop=rng.uniform(0.005, 0.03),
                    gaps_per_minute=rng.uniform(1.0, 3.0))
    return _robot_log(spec, rng).with_(logger=logger)


def _robot_log_offset(spec, rng):
    # the arm: the published friction carries a constant offset near Fc / 4
    rec = _robot_log(spec, rng)
    return rec.with_(torque_offset=float(rng.uniform(0.2, 0.3) * rng.choice((-1.0, 1.0)) * _fc(spec)))


def _per_mille(spec, rng):
    # a CiA 402 drive's torque actual value (0x6077) logged as it is: per-mille of the rated
    # torque, with the friction 1-10 % of rated (a direct drive, a ball screw) -> steps of 1-10 %
    # of Fc; a harmonic drive's (friction 5-20 % of rated) are finer still
    return Recording(torque_resolution=float(np.exp(rng.uniform(np.log(0.01), np.log(0.1)))) * _fc(spec),
                     torque_noise=rng.uniform(0.002, 0.01) * _fc(spec))


def _c(name, summary, build):
    return name, Condition(name, summary, build)


CONDITIONS: dict[str, Condition] = dict((
    _c("white process noise", "a white disturbance torque the record does not contain", _white),
    _c("coloured process noise", "a low-pass (AR(1)) disturbance torque the record does not contain", _coloured),
    _c("torque-reading noise only", "white noise on the torque reading, none felt by the joint", _reading),
    _c("coarse encoder", "2^12-2^14 encoder counts over the travel", _coarse),
    _c("2 kHz", "control and record at 2 kHz", _rate(2000.0)),
    _c("jittered timestamps with dropped samples", "a PC logger: 1-13 ms steps, lost samples, stalls", _jitter),
    _c("friction-torque record", "the friction torque a torque-sensing arm publishes, inertia 0", _friction),
    _c("PD closed-loop tracking", "the recorded torque is a PD controller's output", _pd),
    _c("two-tone torque", "two torque sines at incommensurate frequencies", _two_tone),
))

EXTRA_CONDITIONS: dict[str, Condition] = dict((
    _c("1/f process noise", "a disturbance torque with a 1/f spectrum up to 0.2-2 s", _pink),
    _c("500 Hz", "control and record at 500 Hz", _rate(500.0)),
    _c("robot joint log", "PD tracking, friction column, PC logger, sensor and process noise", _robot_log),
    _c("robot joint log at 100-125 Hz", "the robot joint log published at 100-125 Hz", _robot_log_slow),
    _c("robot joint log with offset", "the same with a constant offset of 20-30 % of Fc in the friction",
       _robot_log_offset),
    _c("drive torque in per-mille", "the torque a CiA 402 drive reports: steps of 1-10 % of Fc", _per_mille),
))


def condition(name: str) -> Condition:
    try:
        return CONDITIONS[name] if name in CONDITIONS else EXTRA_CONDITIONS[name]
    except KeyError:
        known = ", ".join(repr(k) for k in (*CONDITIONS, *EXTRA_CONDITIONS))
        raise InputError(f"unknown condition {name!r}; known: {known}") from None


def recording_for(spec: JointSpec, name: str, seed: int) -> Recording:
    """The condition's recording settings for ``spec``, magnitudes drawn from ``seed`` (a stream
    separate from the noise's, so the same seed's noise does not depend on the condition)."""
    return condition(name).build(spec, np.random.default_rng([seed, 11]))


def make_record(spec: JointSpec, condition: str | Recording = "clean", seed: int = 0,
                duration: float = 20.0, effects=(), extra: np.ndarray | None = None,
                torque_lag: float = 0.0, declared_inertia: float | None = None, **overrides):
    """A record of ``spec`` under a named condition (or an explicit ``Recording``; "clean" is
    today's virtual record), with hidden ``effects`` (``--effect`` texts) or an ``extra``
    vector / ``torque_lag`` / ``declared_inertia``; ``overrides`` replace Recording fields.
    Returns (Record, Truth)."""
    from bench.effects.inject import parse_injections
    if isinstance(condition, Recording):
        rec, label = condition, "custom"
    elif condition == "clean":
        rec, label = Recording(), "clean"
    else:
        rec, label = recording_for(spec, condition, seed), condition
    rec = rec.with_(**overrides) if overrides else rec
    lag = torque_lag
    if effects:
        ev, factor, delta, lag_fx = parse_injections(list(effects), spec)
        if extra is not None:
            ev = ev + np.asarray(extra, float)
        extra, lag = ev, lag + lag_fx
        if delta is not None:
            spec = spec.with_(friction=spec.friction.with_(delta=delta))
        if declared_inertia is None and factor != 1.0:
            declared_inertia = spec.inertia * factor
    record, truth = make(spec, rec, duration, seed=seed, extra=extra, torque_lag=lag,
                         declared_inertia=declared_inertia)
    record.meta["condition"] = label
    if effects:
        record.meta["injected"] = "; ".join(effects)
    return record, truth
