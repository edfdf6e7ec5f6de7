"""Does the friction grow with the torque the joint carries (a loaded gear mesh, a bearing)?

LuGre's levels depend on the velocity only.  In a gear the tooth and bearing forces grow with
the torque transmitted, and so does their friction (Coulomb's law on the mesh: about
mu |tau| on top of the unloaded level).  Fitted without it, Fc lands on the average load's
level, 6-32 % high on the other simulator's loaded meshes, and the residual left looks like
noise to the state learner (``bench.predictability``), which is not given the torque on
purpose (a disturbance torque would pass for physics).  So it is tested apart, like a level
drift (``bench.level_drift``), on physics: within each motion segment, the friction level error
(the residual times the direction) is regressed on the torque, with the speed beside it so a
velocity dependence is not taken for a load dependence.

Which torque?  The recorded one carries the loop's answer to a disturbance it felt
(closed loop), and the one the motion needs, tau - residual = M q'' + the model's friction,
carries a disturbance that moved the joint (open loop, process noise); each alone leaks noise
into a slope.  A torque the friction truly follows shows up in both, so the smaller of the two
decides.  A friction-torque record (inertia 0) carries no torque the analysis sees: not tested.

What it cannot tell apart: an inertia other than the declared one.  Within a motion segment the
torque does not change sign (the friction brakes the joint, not the drive: no sliding sample of
30 tuning records, clean, meshes and inertia errors, 1710-1715, 1800-1817, 1983-1994, had the
torque against the motion), so M q'' = tau - F is linear in |tau| just as mu |tau| is.  The
inertia_error effect fits it unless a felt disturbance hides it (its regressor q'' carries the
disturbance; tuning 1990 and 1993, j2 and j4 15 % heavier under a felt 2-3 % of Fc: nothing
named, both readings 3.7-6.7 % of Fc; the only two flagged of 26 inertia errors 0.8-1.5 x under
a felt 1-3 %, 1970-1995), so the hint names both."""
from __future__ import annotations

import math

import numpy as np

from bench.level_drift import sliding_segments

# Both torques' effects (slope x the torque's spread within segments) must reach SIZE of the
# Coulomb level at a jackknife t of T_CRIT.  Tuning seeds, 2026-12-02 (the smaller of the two):
# 96 clean records (our eleven recording conditions on six joints, 1716-1781; the other
# simulator's sine, two tones and PID under a felt disturbance or reading noise, 1710-1739) at
# most 0.63 % of Fc, none at both bars; 42 library effects of the other simulator once credited
# (1920-1961) at most 1.77 % (t 2.6: j4's gravity) and 1.27 % (t 13: a rotary lag left
# uncredited); loaded meshes at mu 0.05-0.15 (1800-1808) 2.6-12 %, 7 of 9 at both bars.
SIZE = 0.02
T_CRIT = 3.0
LEAST = 20          # sliding samples a segment needs for its own slope
MIN_SEGMENTS = 6
TORQUES = {"recorded": "the recorded torque", "needed": "the torque the motion needs"}


def carried(c, residual: np.ndarray, mask: np.ndarray) -> dict:
    """Per torque ("recorded" |tau|, "needed" |tau - residual|): the pooled within-segment slope
    of residual x direction on it (speed beside), times its within-segment spread ("effect",
    in the torque's unit), and its t against the jackknife over segments (each segment left
    out in turn: one badly conditioned segment cannot carry it, as it did a t of the
    per-segment slopes)."""
    segs = sliding_segments(c, mask, LEAST)
    out = {"segments": len(segs)}
    if len(segs) < MIN_SEGMENTS:
        return out | {name: {"effect": 0.0, "t": 0.0} for name in TORQUES}
    # what both torques share, per segment: the level error and the speed, centred
    shared = [(_centred(residual[sel] * np.sign(c.v[sel])), _centred(np.abs(c.v[sel]))) for sel in segs]
    for name, x in (("recorded", np.abs(c.tau)), ("needed", np.abs(c.tau - residual))):
        # per segment, the centred normal equations: pooled and leave-one-out fits are sums
        parts = []
        for sel, (y, speed) in zip(segs, shared):
            A = np.c_[_centred(x[sel]), speed]
            parts.append((A.T @ A, A.T @ y, float(np.sum(A[:, 0] ** 2)), len(sel)))
        G = sum(p[0] for p in parts)
        g = sum(p[1] for p in parts)
        spread = math.sqrt(sum(p[2] for p in parts) / sum(p[3] for p in parts))
        slope = _slope(G, g)
        loo = np.array([_slope(G - p[0], g - p[1]) for p in parts])
        n = len(parts)
        se = math.sqrt((n - 1) / n * float(np.sum((loo - loo.mean()) ** 2)))
        out[name] = {"effect": slope * spread, "t": slope / se if se > 0 else 0.0}
    return out


def _centred(u: np.ndarray) -> np.ndarray:
    return u - u.mean()


def _slope(G: np.ndarray, g: np.ndarray) -> float:
    """The torque's coefficient of the normal equations G b = g (0 when singular)."""
    try:
        return float(np.linalg.solve(G, g)[0])
    except np.linalg.LinAlgError:
        return 0.0


def grows(p: dict | None, friction_level: float) -> bool:
    """Does the friction clearly grow with the carried torque, by both torques' measures?"""
    if not p or "recorded" not in p:
        return False
    return all(p[k]["effect"] >= SIZE * friction_level and p[k]["t"] >= T_CRIT for k in TORQUES)
