"""What the final model still does not explain, and where to look outside the effect library.

The diagnosis can only name effects it has.  When the residual of the final model is still
structured, no effect in the library accounts for it, and the technician needs to know that
rather than a forced answer: how strongly structured it is, where it concentrates (regime,
direction) and which signal it follows, each with the physics that typically leaves that
signature.  "Structured" means either of two things: the residual stays correlated far
longer than filtered noise, or it is still well above the record's own measurement-noise
floor (``noise_floor``).  Set on tuning seeds (1000-1999, never the tests'), 20 s and 40 s
records of six joints: the 98 without an effect or with one the library found ended at a
correlation-time ratio of 0.56-1.05 and at 0.70-1.39x the floor (a perfect model leaves the
floor, 0.87-1.07x).  Physics outside the library was flagged in 7 of 7 records with a
saturating torque constant and, before ``torque_lag`` joined the library, in all 12
direct-drive records with a torque lag of 2-20 ms (3 of 18 on the macro joints, where
gravity, inertia or position terms absorbed most of it: a sine excitation repeats every
cycle, so a cycle-locked mismatch can pass for them).  A linear correlation of the final
residual is rare (the fit projects out what its sensitivities span): the regime and
direction in which it concentrates point further.
"""
from __future__ import annotations

import numpy as np

from bench.signals import Conditioned, held_torque, second_difference

STRUCTURED_RATIO = 2.0    # residual correlation time / that of filtered white noise
ABOVE_FLOOR = 1.6         # final held-out rms / measurement noise floor
CONCENTRATED = 2.0        # a regime holding this many times its share of time in residual energy
FOLLOWS = 0.3             # |correlation| that counts as following a signal

# signal -> (what the residual follows, physics outside the library that leaves it)
SIGNALS = {
    "torque_rate": ("the rate of change of the recorded torque",
                    "a lag or delay between the commanded and the applied torque (current loop, "
                    "communication), or a compliant transmission"),
    "velocity": ("the velocity", "viscous friction that is not linear in velocity (sigma2 |v|^beta)"),
    "acceleration": ("the acceleration", "an inertia that changes with position, or a compliant "
                     "(two-mass) transmission"),
    "sign_velocity": ("the direction of motion", "a direction-dependent effect the library's "
                      "asymmetry does not capture (e.g. different Stribeck shapes per direction)"),
    "position": ("the position", "a position-dependent effect that is not periodic (a local defect, "
                 "a load that grows along the travel)"),
    "time": ("time", "a drift that is not a single exponential, or a change during the record"),
}
REGIME_PHYSICS = {
    "presliding": "presliding behaviour beyond a single bristle state: backlash in the gears, or "
                  "hysteresis with nonlocal memory (a Maxwell-slip / GMS model)",
    "breakaway": "a breakaway that the Stribeck curve does not describe: frictional lag, or "
                 "rising static friction with dwell time",
    "stribeck": "a Stribeck decay with another shape, or frictional lag on slowing down",
    "viscous": "high-speed friction that is not linear in velocity, or a velocity-dependent drive effect",
}


def noise_floor(c: Conditioned, tau: np.ndarray, q: np.ndarray, inertia: float,
                mask: np.ndarray) -> float:
    """RMS of the measurement noise in the compared friction estimate (tau - M q''), through
    the same operators (held torque, second difference, decimation, low-pass).  Each noise
    level comes from the record's own fourth differences: a smooth excitation has next to
    none at the sample rate, white noise sigma has 70 sigma^2 (encoder quantisation is
    treated as white, which slightly overstates it where the joint creeps)."""
    k4 = np.sqrt(70.0)
    s_tau = float(np.std(np.diff(tau, 4))) / k4
    s_q = float(np.std(np.diff(q, 4))) / k4
    rng = np.random.default_rng(0)
    n_tau = c.lowpass(held_torque(s_tau * rng.standard_normal(len(tau))))
    n_acc = c.lowpass(second_difference(s_q * rng.standard_normal(len(q)), c.dt))
    n = (n_tau - inertia * n_acc)[mask]
    return float(np.sqrt(np.mean(n * n)))


def assess(final: dict, rms: float | None = None, floor: float | None = None) -> dict:
    """The verdict on a final residual breakdown (``bench.residuals.breakdown``), with the
    final held-out ``rms`` and the record's measurement ``floor`` when known."""
    ratio = float(final["whiteness"]["correlation_time_ratio"])
    above = rms / floor if rms is not None and floor else None
    out: dict = {"structured": ratio > STRUCTURED_RATIO or (above is not None and above > ABOVE_FLOOR),
                 "correlation_time_ratio": ratio, "noise_floor": floor, "rms_vs_noise_floor": above,
                 "concentrated_in": None, "direction": None, "follows": None, "look_for": [],
                 "evidence": ""}
    size = "" if above is None else f", {above:.1f}x the measurement noise floor"
    if not out["structured"]:
        out["evidence"] = (f"the residual is as uncorrelated as measurement noise through the same "
                           f"filters (correlation time ratio {ratio:.2f}{size}): nothing left to explain")
        return out
    total = sum((r["rms"] or 0.0) ** 2 * r["fraction"] for r in final["by_regime"].values()) or 1.0
    shares = {name: ((r["rms"] or 0.0) ** 2 * r["fraction"] / total, r["fraction"])
              for name, r in final["by_regime"].items() if r["fraction"] > 0}
    name, (energy, time_share) = max(shares.items(), key=lambda kv: kv[1][0] / kv[1][1])
    parts = [f"the final model leaves a structured residual (correlation time {ratio:.1f}x that of "
             f"noise through the same filters{size}) that no effect in the library explains"]
    out["concentrated_in"] = {"regime": name, "energy_share": energy, "time_share": time_share,
                              "clearly": energy / time_share >= CONCENTRATED}
    out["look_for"].append(REGIME_PHYSICS[name])
    parts.append(f"it {'concentrates' if energy / time_share >= CONCENTRATED else 'is largest'} in "
                 f"the {name} regime ({100 * energy:.0f} % of its energy in {100 * time_share:.0f} % "
                 f"of the time)")
    pos, neg = (final["by_direction"][k]["rms"] or 0.0 for k in ("positive", "negative"))
    if min(pos, neg) > 0 and max(pos, neg) >= 1.5 * min(pos, neg):
        side = "positive" if pos > neg else "negative"
        out["direction"] = {"larger": side, "rms_ratio": max(pos, neg) / min(pos, neg)}
        parts.append(f"it is {max(pos, neg) / min(pos, neg):.1f}x larger moving in the {side} direction")
        out["look_for"].append("an effect that differs between the directions of motion")
    corr = {k: final["cross_correlation"][k] for k in SIGNALS if k in final["cross_correlation"]}
    key = max(corr, key=lambda k: abs(corr[k])) if corr else None
    if key is not None and abs(corr[key]) >= FOLLOWS:
        out["follows"] = {"signal": key, "correlation": corr[key]}
        out["look_for"].append(SIGNALS[key][1])
        parts.append(f"it follows {SIGNALS[key][0]} (r = {corr[key]:+.2f})")
    parts.append("look for " + "; or ".join(out["look_for"]))
    out["evidence"] = "; ".join(parts)
    return out
