"""Dynamic least-squares fit of the LuGre model (plus optional effect terms) to a record.

The model is simulated along the measured velocity with the shared kernel
(``bench.lugre.friction_trace``), passed through the record's zero-phase low-pass and
compared with the friction estimate of eq. 5.  Positive physical parameters are fitted on a
log scale; standard errors come from the Jacobian, inflated for the residual's
autocorrelation (filtered residuals are far from white).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from bench import terms
from bench.lugre import LuGreParams, friction_trace, interval_to_samples
from bench.signals import Conditioned, effective_sample_fraction, second_difference

LUGRE_KEYS = ("Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2")


@dataclass
class Param:
    name: str
    value: float
    log: bool = True          # fit log(value): the parameter is positive
    lo: float = -np.inf       # bounds in fitted coordinates
    hi: float = np.inf

    def to_x(self, value: float) -> float:
        return math.log(value) if self.log else value

    def from_x(self, x: float) -> float:
        return math.exp(x) if self.log else x


@dataclass
class FitData:
    """What every fit of one record shares."""
    c: Conditioned
    friction: np.ndarray      # eq. 5 estimate with the declared inertia
    mask: np.ndarray          # samples scored (filter edges and start-up excluded)
    z0: float
    revolute: bool = True     # gravity (sin q, cos q) is a candidate nuisance term
    # the Coulomb level read off the map's high-speed line (eq. 8): the scale of "worth naming",
    # robust where a distorted dynamic fit is not
    coulomb: float = float("nan")
    # predict()'s memory of its last filtered LuGre traces (keyed by the values they depend on)
    cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def n(self) -> int:
        return int(self.mask.sum())


_ONES: dict[int, np.ndarray] = {}


def _ones(n: int) -> np.ndarray:
    if n not in _ONES:
        _ONES.clear()
        _ONES[n] = np.ones(n)
    return _ONES[n]


# An "applier" writes a set of fitted values into the model: LuGre parameters, the terms
# vector, an inertia correction.  Effects (bench.effects) provide their own.
Applier = Callable[[dict, dict, np.ndarray], None]


def predict(data: FitData, values: dict, appliers: list[Applier] = ()) -> np.ndarray:
    """Model friction, filtered like the measurement, at every sample.

    The filters are linear, so the model is filtered term by term: the LuGre trace (which
    depends on the LuGre values and the level / viscous multipliers only) is remembered for
    the last few values, and the additive torque is a weighted sum of filtered columns.  A
    least-squares Jacobian that steps an additive coefficient or a load inertia then costs no
    simulation at all, and one that steps a LuGre value no re-evaluation of the terms."""
    lugre = {k: values[k] for k in LUGRE_KEYS}
    lugre["delta"] = values.get("delta", 1.0)
    ev = terms.empty()
    extra: dict = {"inertia_error": 0.0, "torque_lag": 0.0, "load_inertia": 0.0,
                   "backlash": 0.0, "flex_frequency": 0.0, "flex_damping": 0.0}
    for apply in appliers:
        apply(values, extra, ev)
    c = data.c
    out = _filtered_lugre(data, lugre, ev)
    coef = ev[list(terms.ADDITIVE_SLOTS)]
    if coef[:3].any():
        out = out + coef[:3] @ _filtered_columns(c, "base", lambda q: terms.additive_columns(q, 0.0)[:3])
    if coef[3:].any():
        pitch = float(ev[terms.COG_PITCH])
        out = out + coef[3:] @ _filtered_columns(c, pitch, lambda q: terms.cogging_columns(q, pitch))
    if extra["inertia_error"]:
        out = out + extra["inertia_error"] * c.a
    if extra["torque_lag"]:
        # the joint felt tau(t - lag), the record says tau(t): the estimate tau - M qdd carries
        # the difference (the filters are linear and time-invariant, so delay the filtered tau)
        out = out + c.tau - np.interp(c.t - extra["torque_lag"], c.t, c.tau)
    if extra["load_inertia"] and (extra["backlash"] > 0 or extra["flex_frequency"] > 0):
        # a load beyond the gear (encoder on the motor): eq. 5 leaves M_load (qdd_l - qdd_m),
        # the load driven through the gear by the motor's recorded trajectory
        out = out + extra["load_inertia"] * gear_term(c, extra["backlash"],
                                                      extra["flex_frequency"], extra["flex_damping"])
    return out


def _remember(cache: dict, key, make, size: int):
    """``cache[key]``, made by ``make()`` when missing; the oldest entries go beyond ``size``."""
    hit = cache.get(key)
    if hit is None:
        hit = cache[key] = make()
        while len(cache) > size:
            cache.pop(next(iter(cache)))
    return hit


def _filtered_lugre(data: FitData, lugre: dict, ev: np.ndarray) -> np.ndarray:
    """The LuGre friction with the terms' level and viscous multipliers, filtered.  Remembered
    for the last few values: a finite-difference Jacobian steps one value at a time, and every
    step of a non-LuGre value reuses the trace of the point it steps from."""
    c = data.c
    level_key = tuple(float(ev[i]) for i in terms.LEVEL_SLOTS)
    # the bristle start z0 is set on the data by identification, so it is part of the key
    key = (tuple(float(lugre[k]) for k in (*LUGRE_KEYS, "delta")), level_key, float(data.z0))

    def make():
        if any(level_key):
            level, visc = _remember(data.cache.setdefault("level", {}), level_key,
                                    lambda: _multipliers(c, ev), 4)
        else:
            level = visc = _ones(len(c.v_mid))
        return c.lowpass(_lugre_samples(data, lugre, level, visc))
    return _remember(data.cache.setdefault("lugre", {}), key, make, 4)


def _multipliers(c: Conditioned, ev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    _, level, visc = terms.effect_terms(c.q_mid, c.v_mid, c.t_mid, ev)
    return np.ascontiguousarray(np.maximum(level, 1e-6)), np.ascontiguousarray(visc)


def _filtered_columns(c: Conditioned, key, columns) -> np.ndarray:
    """``columns(q)`` at the samples, each filtered: the offset and gravity columns, and those
    of the last few cogging pitches."""
    cache = c.__dict__.setdefault("_additive_columns", {})
    return _remember(cache, key, lambda: np.array([c.lowpass(col) for col in columns(c.q_full)]), 4)


def _lugre_samples(data: FitData, p: dict, level: np.ndarray, visc: np.ndarray) -> np.ndarray:
    """LuGre friction at the full-rate samples, simulated segment by segment: the bristle
    state restarts at each segment (a gap hides what it did), from the friction estimate at
    the segment's start as for the first (``data.z0``)."""
    c = data.c
    args = (p["Fc"], p["Fs"], p["alpha"], p["delta"], p["sigma0"], p["sigma1"], p["sigma2"])
    if len(c.segments) == 1:
        F, _ = friction_trace(c.v_mid, c.dt, data.z0, *args, level, visc)
        return interval_to_samples(F)
    parts = []
    for k, ((a, b), (g, _)) in enumerate(zip(c.interval_segments, c.grid_segments)):
        z0 = data.z0
        if k:
            lim = p["Fs"] / p["sigma0"]
            z0 = float(np.clip(data.friction[min(g, len(data.friction) - 1)] / p["sigma0"], -lim, lim))
        F, _ = friction_trace(c.v_mid[a:b], c.dt, z0, *args, level[a:b], visc[a:b])
        parts.append(interval_to_samples(F) if b > a else np.zeros(1))
    return np.concatenate(parts)


_GEAR_CACHE: dict = {}


def gear_term(c: Conditioned, width: float, frequency: float, damping: float) -> np.ndarray:
    """(qdd_load - qdd_motor) on the grid, per unit load inertia.  Cached: a fit varies
    LuGre far more often than the gear."""
    key = (id(c), width, frequency, damping)
    hit = _GEAR_CACHE.get(key)
    if hit is not None and hit[0] is c:
        return hit[1]
    ev = terms.empty()
    ev[terms.BACKLASH], ev[terms.FLEX_FREQ], ev[terms.FLEX_DAMP] = width, frequency, damping
    gap, w2, c2 = terms.coupling(ev)
    # the load's step resolves the locked-rotor mode (h w <= 0.25), as the joint's does
    n_sub = int(min(64, max(1, math.ceil(c.dt * math.sqrt(w2) / 0.25))))
    # the gear is driven by the motor as the friction model sees it (the lightly smoothed
    # velocity, integrated): fed the raw encoder, the stiff contact turns quantisation steps
    # into load jitter that parts the flanks and biases the width (+10 % on j3 and the rotary
    # motor, tuning seeds); the motor's own qdd stays the measured one, as in eq. 5
    rel = np.empty_like(c.q_full)      # qdd_load - qdd_motor, segment by segment (a gap
    for (a, b), (ia, ib) in zip(c.segments, c.interval_segments):   # restarts the gear)
        q = c.q_full[a:b]
        qm = np.empty_like(q)
        qm[0] = q[0]
        qm[1:] = q[0] + np.cumsum(c.v_mid[ia:ib]) * c.dt
        ql = terms.load_trajectory(qm, c.dt, n_sub, gap, w2, c2)
        rel[a:b] = second_difference(ql - qm, c.dt) + second_difference(qm - q, c.dt)
    term = c.lowpass(rel)
    if len(_GEAR_CACHE) > 8:
        _GEAR_CACHE.clear()
    _GEAR_CACHE[key] = (c, term)
    return term


@dataclass
class FitResult:
    values: dict
    stderr: dict              # natural units; None where the Jacobian is singular
    residual: np.ndarray      # on all samples: measured - model
    rms: float                # on the scored samples
    nrmse: float
    cost: float
    n_eff_fraction: float
    success: bool
    params: list[Param] = field(default_factory=list)

    def lugre(self) -> LuGreParams:
        return LuGreParams(**{k: self.values[k] for k in LUGRE_KEYS}, delta=self.values.get("delta", 1.0))


def fit(data: FitData, params: list[Param], fixed: dict | None = None,
        appliers: list[Applier] = (), max_nfev: int = 200) -> FitResult:
    """Least-squares fit of ``params`` (others held at ``fixed``)."""
    fixed = dict(fixed or {})
    # the grid holds ~10 samples per cutoff period of a low-passed residual: every third is
    # still above Nyquist, and the solver's linear algebra shrinks threefold
    mask = np.zeros_like(data.mask)
    mask[np.nonzero(data.mask)[0][::3]] = True
    y = data.friction

    def values_of(x):
        vals = dict(fixed)
        for p, xi in zip(params, x):
            vals[p.name] = p.from_x(xi)
        return vals

    def resid(x):
        r = (y - predict(data, values_of(x), appliers))[mask]
        return r if np.all(np.isfinite(r)) else np.full_like(r, 1e6 * (np.abs(y).max() + 1))

    x0 = np.array([np.clip(p.to_x(p.value), p.lo, p.hi) for p in params])
    lo = np.array([p.lo for p in params])
    hi = np.array([p.hi for p in params])
    res = least_squares(resid, x0, bounds=(lo, hi), method="trf", x_scale="jac",
                        max_nfev=max_nfev, xtol=1e-10, ftol=1e-10, gtol=1e-10)
    vals = values_of(res.x)
    full_r = y - predict(data, vals, appliers)
    r = full_r[mask]
    rms = float(np.sqrt(np.mean(r ** 2)))
    ym = y[mask]
    nrmse = float(np.linalg.norm(r) / max(np.linalg.norm(ym - ym.mean()), 1e-300))
    frac = effective_sample_fraction(r)
    stderr = _stderr(res.jac, res.fun, params, res.x, frac)
    return FitResult(values=vals, stderr=stderr, residual=full_r, rms=rms, nrmse=nrmse,
                     cost=float(res.cost), n_eff_fraction=frac, success=bool(res.success),
                     params=params)


def _stderr(jac, fun, params, x, n_eff_fraction):
    n, k = jac.shape
    dof = max(n - k, 1)
    s2 = float(fun @ fun) / dof
    out = {}
    try:
        jtj = jac.T @ jac
        scale = np.sqrt(np.diag(jtj))
        scale[scale == 0] = 1.0
        cov = np.linalg.pinv(jtj / np.outer(scale, scale), rcond=1e-12) / np.outer(scale, scale)
        cov = cov * s2 / n_eff_fraction
        diag = np.diag(cov)
    except np.linalg.LinAlgError:
        diag = np.full(k, np.nan)
    for p, xi, d in zip(params, x, diag):
        if not np.isfinite(d) or d < 0:
            out[p.name] = None
            continue
        se_x = math.sqrt(d)
        out[p.name] = float(p.from_x(xi) * se_x) if p.log else float(se_x)
    return out
