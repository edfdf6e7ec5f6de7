"""Identification of the six LuGre parameters from one sinusoidal-torque record.

Section III of the paper, step by step, gives the starting point:
  friction-velocity map from eq. 5;  Fc and sigma2 from the high-velocity line (eq. 8);
  Fs from the friction on the sliding-to-presliding approach (eq. 9);  alpha from the slope
  near the origin (eq. 16), then tuned by matching the steady-state map;  sigma0 from the
  presliding force-displacement slope;  sigma1 from the presliding transient of the
  linearised model (eq. 10).
A dynamic fit of all six over the whole record then refines them (``bench.fitting``) and
gives each a standard error and an identifiability flag.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from bench.errors import InputError, NotIdentifiable
from bench.fitting import LUGRE_KEYS, FitData, FitResult, Param, fit, predict
from bench.lugre import LuGreParams
from bench.records import Record
from bench.signals import Conditioned, condition
from bench.grid_math import zero_crossings
from bench.standstill import held_poses, smallest_step

# A parameter is reported identifiable when its 2-sigma band is within +-30 % of its value.
IDENTIFIABLE_REL_SE = 0.15


def is_identifiable(value: float, se: float | None) -> bool:
    """The report's "identifiable": a standard error within ``IDENTIFIABLE_REL_SE`` of the value."""
    return bool(se is not None and se <= IDENTIFIABLE_REL_SE * abs(value))


@dataclass
class Identification:
    params: LuGreParams
    uncertainty: dict
    identifiable: dict
    fit: dict
    initial: dict                       # the Section III estimates, before refinement
    inertia: float
    data: FitData
    result: FitResult
    warnings: list = field(default_factory=list)

    def report(self) -> dict:
        """The stable JSON contract (see README)."""
        return {
            "parameters": self.params.as_dict(),
            "uncertainty": {k: self.uncertainty.get(k) for k in LUGRE_KEYS},
            "identifiable": {k: bool(self.identifiable.get(k, False)) for k in LUGRE_KEYS},
            "fit": dict(self.fit),
            "diagnosis": [],
            "inertia": self.inertia,
            "section3_estimates": self.initial,
            "warnings": list(self.warnings),
        }


def prepare(rec: Record, inertia: float | None = None, cutoff: float | None = None,
            name: str = "record", hold: str | None = None) -> tuple[FitData, float]:
    """Condition a record and form the friction estimate with the declared inertia."""
    M = inertia if inertia is not None else rec.inertia
    if M is None:
        raise InputError(f"{name}: no inertia: give --inertia or an 'inertia' metadata line")
    # 0 declares a friction-torque record (tau is the friction): no acceleration term
    if not (M >= 0 and math.isfinite(M)):
        raise InputError(f"{name}: inertia must be a positive number (or 0 for a friction-torque record), got {M}")
    c = condition(rec, cutoff=cutoff, name=name, hold=hold)
    F = c.friction(M)
    mask = np.zeros(len(c.t), dtype=bool)
    edge = math.ceil(3.0 / (c.cutoff * c.dt_grid))      # the filter's edge transient
    settle = int(0.25 / (c.frequency * c.dt_grid))      # the bristle start-up
    if len(c.segments) == 1 and not c.rest_starts:
        n = len(c.t)
        edge = int(min(n // 10, edge))
        mask[max(edge, settle):n - edge] = True
    else:  # split at gaps: each segment has its own filter edges and bristle start
        for k, (a, b) in enumerate(c.grid_segments):
            start = max(edge, settle) if k == 0 else edge
            if k in c.rest_starts:
                # a segment that starts at rest beside a long standstill (bench.standstill)
                # waits for the joint to slide: its bristle start is read from a friction that
                # may carry an offset or gravity, and only sliding makes the state forget it
                moved = np.flatnonzero(np.abs(c.v[a:b]) >= c.sliding_speed)
                start = max(start, int(moved[0]) if len(moved) else b - a)
            mask[a + start:max(b - edge, a)] = True
    # the insides of held poses (a robot's dwells): the friction there creeps below the
    # encoder's resolution (bench.standstill)
    held, held_spans = held_poses(c.t, c.q, c.tau, smallest_step(rec.q), c.grid_segments)
    mask &= ~held
    if not mask.any() and len(c.segments) > 1:
        longest = max(b - a for a, b in c.segments) * c.dt
        raise InputError(f"{name}: segments too short to analyse after splitting at {len(c.segments) - 1} gaps "
                         f"(the longest is {longest:.3g} s; each needs more than {2 * edge * c.dt_grid:.3g} s "
                         "of filter edges): record without long gaps")
    return FitData(c=c, friction=F, mask=mask, z0=0.0, revolute=rec.joint_type == "revolute",
                   load_encoder=rec.load_encoder, inertia=M, held_poses=held_spans), M


# The median inertial torque |M q''| at the top speeds, as a share of the friction read there,
# above which a refusal blames the motion's inertia, not a lack of sliding.  Measured
# 2026-12-06: the rotary motor under PD with a 6.2 ms torque lag (tuning seeds 1894, 1896),
# refused, 0.95 (4 ms, 1895: identified, 0.47); records that never broke away (j1-j4, linear,
# rotary at 0.5-0.9 Fs; j2 below Fc from the independent simulator) 0.0008-0.04.
INERTIA_SWAMPS = 0.25
# A top-speed map whose friction follows sgn(v) (sign agreement >= 0.9) but scatters about the
# line down to this R^2 is still read (a gear ringing on its contact).  Measured 2026-12-07:
# the linear stage's gap under a PID Fourier log 0.69 (soak seed 30243); the refusals it must
# keep -- the rotary motor under PD with a 6 ms lag (1894, 1896, 10225) -- 0.15-0.30, and
# there the sign agrees on only 60-69 % anyway.
SCATTERED_R2 = 0.5


def _check_sliding(c: Conditioned, F: np.ndarray, name: str, revolute: bool = True,
                   M: float = 0.0) -> tuple[float, float, float, np.ndarray]:
    """Eq. 8 on the high-velocity part of the map; raise if the joint never slid.

    Sliding means that at its highest speeds the friction follows sgn(v) (plus viscous
    friction) in both directions.  A constant offset, gravity left in the torque (a sin q +
    b cos q) or a direction asymmetry are not reasons to refuse: they are regressed out here
    (and named later by the diagnosis).  Returns (Fc, sigma2, v_max, the regressed-out
    torque on every sample)."""
    speed = np.abs(c.v)
    vmax = float(np.percentile(speed, 99.5))
    if vmax <= 0:
        raise NotIdentifiable(f"{name}: the joint never moved")
    hi = speed > 0.6 * vmax
    up, down = int(np.sum(hi & (c.v > 0))), int(np.sum(hi & (c.v < 0)))
    if min(up, down) < 3 and np.any(c.v > 0) and np.any(c.v < 0):
        # one direction's moves are slower than the other's (a log whose fast move goes one
        # way, a homing step at its start): each direction's own top speeds, which the sign
        # and line checks below still judge (a p2p log of j3, tuning seed 1876: refused)
        top_up, top_down = (float(np.percentile(np.abs(c.v[s]), 99.5)) for s in (c.v > 0, c.v < 0))
        hi = ((c.v > 0.6 * top_up) & (c.v > 0)) | ((c.v < -0.6 * top_down) & (c.v < 0))
        up, down = int(np.sum(hi & (c.v > 0))), int(np.sum(hi & (c.v < 0)))
    if min(up, down) < 3:
        raise NotIdentifiable(
            f"{name}: the joint never reaches sliding in both directions ({up} fast samples moving up, "
            f"{down} down); record a motion that slides both ways (a torque sine or a back-and-forth "
            f"move of larger amplitude)")
    # the paper's line first; only where it fails, the same with an offset and gravity (a
    # clean record keeps the paper's estimates, and the fits that start from them)
    options = [np.zeros((len(F), 0)), np.ones((len(F), 1))]
    if revolute and np.ptp(c.q) > 0.05:  # gravity is only separable from an offset with travel
        options.append(np.column_stack([np.ones_like(F), np.sin(c.q), np.cos(c.q)]))

    def line(N, hi):
        X = np.column_stack([np.sign(c.v[hi]), c.v[hi], N[hi]])
        coef, *_ = np.linalg.lstsq(X, F[hi], rcond=None)
        ss = np.sum((F[hi] - F[hi].mean()) ** 2)
        r2 = 1.0 - np.sum((F[hi] - X @ coef) ** 2) / max(ss, 1e-300)
        other = N @ coef[2:]
        return coef, r2, float(np.mean(np.sign(F[hi] - other[hi]) == np.sign(c.v[hi]))), other

    for N in options:
        coef, r2, agree, other = line(N, hi)
        if coef[0] > 0 and r2 >= 0.8 and agree >= 0.9:
            break
    if (r2 < 0.8 or agree < 0.9) and M > 0:
        # the same reading only where the joint slides steadily: a violent transient among the
        # top speeds (a step of the reference at a log's start, a PID's overshoot) reads
        # friction as tau - M a with tau and M a many times the friction, so a small inertia
        # error or lag there swamps the map (PID-tracked logs, tuning seeds 1612, 1656: refused)
        level = np.median(np.abs(F[hi]))
        steady = hi & (np.abs(M * c.a) <= 2.0 * level) & (np.abs(c.tau) <= 3.0 * level)
        if (np.sum(steady) >= 0.5 * np.sum(hi)
                and min(np.sum(steady & (c.v > 0)), np.sum(steady & (c.v < 0))) >= 3):
            hi = steady
            coef, r2, agree, other = line(options[-1], hi)
    if coef[0] <= 0 and r2 >= SCATTERED_R2 and agree >= 0.9:
        # it slides (friction follows the motion's sign) but the map at top speed is steeper
        # than Coulomb plus viscous friction allows, its intercept <= 0: physics outside the
        # model (a torque constant falling at high current, tuning seeds 1005-1017 on j3) or a
        # map far into the Stribeck decay.  Start from the mean friction there and no viscous
        # term; the fit and the diagnosis say what is left, which a refusal would hide.
        return float(np.mean(np.abs(F[hi] - other[hi]))), 0.0, vmax, other
    # a map that slides but scatters about the line (a gear's gap ringing on its contact under
    # a PID's fast moves: SCATTERED_R2 <= R^2 < 0.8) is read too: the line is a start, and the
    # fit and the diagnosis say what is left
    if coef[0] <= 0 or r2 < SCATTERED_R2 or agree < 0.9:
        why = (f"at its highest speeds friction does not follow sgn(v), even allowing for an offset "
               f"and gravity: R^2 {r2:.2f}, sign agreement {agree:.0%}")
        inertial = float(np.median(np.abs(M * c.a[hi]))) / max(float(np.median(np.abs(F[hi]))), 1e-300)
        if inertial >= INERTIA_SWAMPS:
            raise NotIdentifiable(
                f"{name}: friction cannot be read off this motion ({why}); there the inertial "
                f"torque M q'' is {inertial:.2g}x the friction read, so a lag between the torque "
                f"and the motion, an inertia error or a gear's play or spring between motor and "
                f"load swamps it: check that torque and position share one clock and the declared "
                f"inertia, or record a slower motion in which friction dominates")
        raise NotIdentifiable(
            f"{name}: the joint never reaches sliding ({why}); record with a larger torque "
            f"amplitude or faster motion, so that the joint slides clearly in both directions")
    return float(coef[0]), float(max(coef[1], 0.0)), vmax, other


def section3_estimates(data: FitData, M: float, name: str = "record", revolute: bool = True) -> dict:
    c = data.c
    v, q = c.v, c.q
    Fc, s2, vmax, other = _check_sliding(c, data.friction, name, revolute, M)
    data.coulomb = Fc
    # the steps below read the map: without the offset/gravity found above (the dynamic fit
    # still sees them, and the diagnosis names them)
    F = data.friction - other
    skipped = {}
    speed = np.abs(v)
    decel = v * c.a < 0
    # below ~5 % of the top speed the map is dominated by presliding and stick-slip
    # transitions (Fig. 3); the steady-state relations are read above that
    v_lo = 0.05 * vmax
    # eq. 9: friction reached on the sliding-to-presliding approach
    band = decel & (speed > v_lo) & (speed < 0.1 * vmax) & data.mask
    Fs = float(np.median(np.abs(F[band]) - s2 * speed[band])) if band.sum() > 5 else 1.1 * Fc
    if band.sum() <= 5:
        skipped["Fs"] = ("eq. 9 needs the joint to slow from sliding to a stop; the record has "
                         "too few samples there, so Fs starts at 1.1 Fc")
    Fs = max(Fs, Fc * 1.01)
    # eq. 16: slope near the origin on the approach branch
    near = decel & (speed > v_lo) & (speed < 0.2 * vmax) & data.mask
    alpha = float("nan")
    if near.sum() > 5:
        kappa1 = np.polyfit(speed[near], np.abs(F[near]), 1)[0]
        alpha = -(kappa1 - s2) / (Fs - Fc)
    alpha_eq16 = alpha
    if not (np.isfinite(alpha) and alpha > 0):
        alpha = 2.0 / vmax
        skipped["alpha_eq16"] = ("eq. 16 needs a clear slope of the map near the origin on the "
                                 "approach branch; not found, alpha starts from the top speed")
    # fine-tune the steady-state map (6c), as the paper tunes alpha by matching maps, on the
    # approach branch and on the high-velocity part where breakaway overshoot has died out
    slide = ((decel & (speed > v_lo)) | (speed > 0.15 * vmax)) & data.mask
    vv, FF = v[slide], F[slide]

    def ss_resid(x):
        fc, dfs, al, sg = np.exp(x)
        return np.sign(vv) * (fc + dfs * np.exp(-al * np.abs(vv))) + sg * vv - FF

    x0 = np.log([Fc, Fs - Fc, alpha, max(s2, 1e-6 * Fc / vmax)])
    noise = max(1.4826 * np.median(np.abs(np.diff(FF))) / math.sqrt(2), 1e-12)
    r = least_squares(ss_resid, x0, bounds=(x0 - 8, x0 + 8), method="trf", x_scale="jac",
                      loss="soft_l1", f_scale=3 * noise, max_nfev=300)
    Fc, dFs, alpha, s2 = (float(x) for x in np.exp(r.x))
    Fs = Fc + dFs
    # sigma0 and sigma1: presliding windows around friction reversals at low speed
    sig0, sig1 = [], []
    for i in zero_crossings(F):
        if speed[i] > 0.1 * vmax or not data.mask[i]:
            continue
        lo, hi = i, i + 1
        lim = 0.5 * Fs
        while lo > 0 and abs(F[lo - 1]) < lim and speed[lo - 1] < 0.1 * vmax:
            lo -= 1
        while hi < len(F) - 1 and abs(F[hi + 1]) < lim and speed[hi + 1] < 0.1 * vmax:
            hi += 1
        if hi - lo < 6:
            continue
        X = np.column_stack([q[lo:hi + 1] - q[i], v[lo:hi + 1], np.ones(hi - lo + 1)])
        coef, *_ = np.linalg.lstsq(X, F[lo:hi + 1], rcond=None)
        if coef[0] > 0:
            sig0.append(coef[0])
            sig1.append(coef[1] - s2)
    sigma0 = float(np.median(sig0)) if sig0 else float("nan")
    sigma1 = float(np.median(sig1)) if sig1 else float("nan")
    if not sig0:
        skipped["sigma0"] = skipped["sigma1"] = (
            "no presliding window: the friction never reverses slowly enough to read the "
            "force-displacement slope; sigma0 and sigma1 come from the dynamic fit alone")
    return {"Fc": Fc, "Fs": Fs, "alpha": alpha, "alpha_eq16": alpha_eq16, "sigma0": sigma0,
            "sigma1": sigma1, "sigma2": s2, "v_max": vmax, "presliding_windows": len(sig0),
            "offset_and_gravity_rms": float(np.sqrt(np.mean(other ** 2))), "skipped": skipped}


def _starting_point(data: FitData, est: dict, M: float, sigma0: float | None = None) -> dict:
    """Starting values for the dynamic fit.  The Section III estimates can be far off (the
    approach branch is not quite steady, presliding windows are short), and the dynamic
    cost has local minima in alpha and in sigma0/sigma1; a coarse search on the dynamic cost
    itself, one coordinate group at a time, puts the fit in the right basin."""
    def cost(vals):
        r = (data.friction - predict(data, vals))[data.mask]
        return float(r @ r)

    vmax = est["v_max"]
    span = max(np.ptp(data.c.q), 1e-12)
    s0 = est["sigma0"] if np.isfinite(est["sigma0"]) and est["sigma0"] > 0 else 100 * est["Fs"] / span
    cur = {"Fc": est["Fc"], "Fs": est["Fs"], "alpha": est["alpha"], "sigma2": est["sigma2"],
           "sigma0": s0, "sigma1": _damping_scale(s0, M)}
    # stiffness and damping first (they shape every reversal), then the Stribeck curve
    if sigma0 is None:
        cur["sigma0"] = min(_sigma0_grid(s0), key=lambda g: cost(dict(cur, sigma0=g, sigma1=_damping_scale(g, M))))
    else:
        cur["sigma0"] = sigma0
    crit = _damping_scale(cur["sigma0"], M)
    cur["sigma1"] = min(crit * np.logspace(-3, 1, 9), key=lambda g: cost(dict(cur, sigma1=g)))
    alphas = [est["alpha"]] + ([est["alpha_eq16"]] if np.isfinite(est["alpha_eq16"]) and est["alpha_eq16"] > 0 else [])
    alphas += list(np.logspace(-0.5, 1.5, 7) / vmax)
    dfs = est["Fs"] - est["Fc"]
    best = None
    for a in alphas:
        for ds in (0.5 * dfs, dfs, 2.0 * dfs):
            vals = dict(cur, alpha=a, Fs=cur["Fc"] + ds)
            c = cost(vals)
            if best is None or c < best[0]:
                best = (c, a, cur["Fc"] + ds)
    cur["alpha"], cur["Fs"] = best[1], best[2]
    return cur


def _sigma0_grid(s0: float) -> np.ndarray:
    return s0 * np.logspace(-2, 2, 9)


# With no presliding window measured (a record sampled too coarsely to see one) the start
# search's stiffness is a guess on a coordinate grid, and the fit from that one basin can stay
# in it: the linear stage's friction log at 333 Hz (tuning seed 1322) ended at rms 17 % of
# Fc (Fs 2x, sigma0 16x the truth) while 7 of 9 starts across the grid reached 0.9 % of Fc
# with Fc within 2 %.  So the fit also starts a decade and two below and a decade above.
# Another basin replaces the search's own only when it fits clearly better: where the record
# cannot resolve the dip at all, biased minima lie a few % apart (rotary motor at 250 Hz,
# tuning seeds 1322, 1404-1406: cost 0.972-0.975x at Fs 2.2x the truth), while the linear
# stage's right basin cost 0.71-0.83x the wrong one's at 100 Hz and 0.002x at 250-333 Hz.
OTHER_STIFFNESS_STARTS = (0.01, 0.1, 10.0)
OTHER_BASIN_GAIN = 0.9


def _damping_scale(sigma0: float, M: float) -> float:
    """Scale of sigma1 for the start search: critical damping of the bristles with the joint's
    inertia; a friction-torque record (M = 0) has none, so a 10 ms bristle time constant
    sigma1/sigma0 (Table II's joints: 8-9 ms), searched over 1e-3..10x like the other."""
    return 2.0 * math.sqrt(sigma0 * M) if M > 0 else 0.01 * sigma0


def section3_complete(est: dict) -> bool:
    """Did Section III estimate every LuGre value (finite and positive)?"""
    return all(isinstance(est.get(k), (int, float)) and math.isfinite(est[k]) and est[k] > 0
               for k in LUGRE_KEYS)


def lugre_starts(data: FitData, est: dict, M: float) -> list[dict]:
    """The dynamic cost has local minima: fit from the Section III estimates and from a
    coarse search on the dynamic cost, and keep the better."""
    starts = [_starting_point(data, est, M)]
    if section3_complete(est):
        starts.append({k: est[k] for k in LUGRE_KEYS})
    first = starts[0]
    v_max = est.get("v_max")
    if (first["Fs"] < 1.02 * first["Fc"] or not est["alpha"] > 0) and v_max and np.isfinite(v_max) and v_max > 0:
        # With no Stribeck dip in the estimates (a coarse logger smears it: Section III sees
        # Fs = Fc and alpha = 0), the fit stays where Fc does nothing (alpha -> 0, s(v) = Fs).
        # Start it off that manifold too, the dip's speed on a grid of the record's top speed
        # (tuning seeds 1209, 1240, 1271: the rotary motor on a 4 ms logger).
        starts += [dict(first, Fs=1.25 * first["Fc"], alpha=k / v_max) for k in (1.0, 3.0)]
    return starts


def _fit_lugre(data: FitData, est: dict, M: float, other_basins: bool = False) -> FitResult:
    """The best fit from ``lugre_starts``; with ``other_basins`` (a record's identification)
    and no presliding measured, also from the other stiffness starts."""
    res = None
    starts = lugre_starts(data, est, M)
    others = []
    if other_basins and not (np.isfinite(est["sigma0"]) and est["sigma0"] > 0):
        others = [_starting_point(data, est, M, sigma0=k * starts[0]["sigma0"]) for k in OTHER_STIFFNESS_STARTS]
    for i, start in enumerate(starts + others):
        data.z0 = _initial_bristle(data, est, start["sigma0"])
        params = [Param(k, start[k], lo=math.log(start[k]) - 9, hi=math.log(start[k]) + 9)
                  for k in LUGRE_KEYS]
        r = fit(data, params)
        better = OTHER_BASIN_GAIN if i >= len(starts) else 1.0
        if res is None or r.cost < better * res.cost:
            res, z0 = r, data.z0
    data.z0 = z0
    return res


def _prefers_sampled_torque(rec: Record, data: FitData, res: FitResult) -> bool:
    """Was tau sampled at t rather than held until the next sample?  The two conventions
    differ by half a sample of torque timing.  With zoh applied to sampled data the
    friction estimate is off by -(tau_sampled - tau_held), filtered: regress the residual on
    that difference, together with the model's sensitivities to its own parameters (the fit
    has partly absorbed the error), and look for a coefficient near -1."""
    from bench.screening import Model, model_columns
    c = data.c
    m = data.mask
    d = (c.lowpass(rec.tau) - c.tau)[m]
    model = Model(values=res.values, params=res.params)
    base = predict(data, res.values)
    J = model_columns(data, model, base, np.nonzero(m)[0])
    X = np.column_stack([J, d])
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    r = res.residual[m]
    coef, *_ = np.linalg.lstsq(X / scale, r, rcond=1e-12)
    beta = coef[-1] / scale[-1]
    fitted = (X / scale) @ coef
    return bool(beta < -0.5 and float(fitted @ fitted) > 0.05 * float(r @ r))


def identify(rec: Record, inertia: float | None = None, cutoff: float | None = None,
             name: str = "record") -> Identification:
    from bench.signals import torque_hold
    hold = torque_hold(rec, name)
    if (inertia if inertia is not None else rec.inertia) == 0:
        hold = "sample"   # a friction column is a measurement at t, not a held command
    data, M = prepare(rec, inertia, cutoff, name, hold)
    revolute = data.revolute
    est = section3_estimates(data, M, name, revolute)
    res = _fit_lugre(data, est, M, other_basins=True)
    if hold == "auto":
        hold = "zoh"
        # a logged qd driving the model is no reason to skip this: its derivative sees a held
        # torque as the position's second difference does (bench.signals.condition)
        if _prefers_sampled_torque(rec, data, res):
            hold = "sample"
            data, M = prepare(rec, inertia, cutoff, name, hold)
            est = section3_estimates(data, M, name, revolute)
            res = _fit_lugre(data, est, M, other_basins=True)
    p = res.lugre()
    identifiable, warnings = judged(res, est["v_max"])
    # the verdict's Coulomb scale (an effect's size, what is left) is eq. 8's line; where the
    # top speeds are steeper than a line it is the mean friction there, viscous part and all:
    # 1.9-2.4x Fc on the linear stage's 100-125 Hz robot logs (tuning seeds 1600-1607,
    # 1620-1627), every bar that much more lenient.  A determined fit's Fc is the scale where
    # the line reads over 1.5x it -- never upward: a fit bent by physics outside the model
    # reads Fc several times too large (friction beyond a gear: 4.6x), and a bar that lenient
    # called such a log "nothing left" (tried 2026-11-30, reverted)
    if identifiable.get("Fc") and data.coulomb > 1.5 * p.Fc > 0:
        data.coulomb = float(p.Fc)
    fitq = {"rms_error": res.rms, "nrmse": res.nrmse, "fit_percent": 100.0 * (1.0 - res.nrmse),
            "samples": data.n, "effective_sample_fraction": res.n_eff_fraction,
            "cutoff_hz": data.c.cutoff, "velocity_band_hz": data.c.velocity_band,
            "excitation_hz": data.c.frequency, "torque_hold": hold}
    return Identification(params=p, uncertainty=res.stderr, identifiable=identifiable, fit=fitq,
                          initial={k: (v if k == "skipped" else _finite_or_none(v)) for k, v in est.items()},
                          inertia=M,
                          data=data, result=res, warnings=warnings)


# alpha |v| the record must reach for the Stribeck decay to be traversed (e^-1.5 = 22 % of
# Fs - Fc left): below it alpha and Fc trade off
MIN_REACH = 1.5


def value_warnings(p: LuGreParams, v_max: float) -> list[str]:
    """What a LuGre model's values say of the record (the Stribeck decay barely traversed up to
    the record's top speed ``v_max``) and of the model itself (not passive)."""
    out = []
    if v_max * p.alpha < MIN_REACH:
        out.append(f"the record reaches alpha*|v| = {v_max * p.alpha:.2f} only: the Stribeck "
                   "decay is barely traversed, so alpha and Fc trade off; excite faster")
    pw = p.passivity_warning()
    if pw:
        out.append(pw)
    return out


def judged(res: FitResult, v_max: float) -> tuple[dict, list[str]]:
    """A fit's LuGre values judged: which the record determines (the report's identifiable;
    alpha only where the record traverses the Stribeck decay) and the warnings that go with
    them (``value_warnings``, then each value not determined).  The baseline's in
    ``identify``, the final model's in ``bench.analysis``."""
    identifiable = {k: is_identifiable(res.values[k], res.stderr.get(k)) for k in LUGRE_KEYS}
    p = res.lugre()
    if v_max * p.alpha < MIN_REACH:
        identifiable["alpha"] = False
    warnings = value_warnings(p, v_max)
    for k in LUGRE_KEYS:
        if not identifiable[k]:
            se = res.stderr.get(k)
            warnings.append(f"{k} is not identifiable from this record"
                            + (f" (standard error {se:.3g})" if se is not None else ""))
    return identifiable, warnings


def _initial_bristle(data: FitData, est: dict, sigma0: float) -> float:
    """Bristle deflection at the first sample: steady state if sliding, else the friction
    estimate over the stiffness, clipped to the stiction deflection."""
    F0 = float(data.friction[0])
    lim = est["Fs"] / sigma0
    return float(np.clip(F0 / sigma0, -lim, lim))


def _finite_or_none(x):
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None
