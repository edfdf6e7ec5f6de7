"""Dynamic least-squares fit of the LuGre model (plus optional effect terms) to a record.

The model is simulated along the measured velocity with the shared kernel
(``bench.lugre.friction_trace``), passed through the record's zero-phase low-pass and
compared with the friction estimate of eq. 5.  Positive physical parameters are fitted on a
log scale; standard errors come from the Jacobian, inflated for the residual's
autocorrelation (filtered residuals are far from white).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from bench import terms
from bench.checkpoint import checkpoint
from bench.gear_model import gear_unit_term
from bench.load_side import gap_slip, spring_slip
from bench.lugre import LuGreParams
from bench.model_trace import filtered_columns, filtered_terms_lugre
from bench.signals import Conditioned
from bench.residual_stats import effective_sample_fraction

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
    load_encoder: bool = False    # the encoder reads the load beyond a gear (``encoder: load``)
    inertia: float = 1.0          # the joint's declared inertia (eq. 5's M)
    # the Coulomb level read off the map's high-speed line (eq. 8): the scale of "worth naming",
    # robust where a distorted dynamic fit is not
    coulomb: float = float("nan")
    # the held poses left out of ``mask`` [(t0, t1)] (``bench.standstill.held_poses``)
    held_poses: list = field(default_factory=list)
    # predict()'s memory of its last filtered LuGre traces (keyed by the values they depend on)
    cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def n(self) -> int:
        return int(self.mask.sum())


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
                   "backlash": 0.0, "flex_frequency": 0.0, "flex_damping": 0.0, "load_kappa": 0.0,
                   "contact_frequency": 0.0, "contact_damping": 0.0, "flex_slip": 0.0,
                   "motor_inertia": 0.0, "gap_slip": 0.0}
    for apply in appliers:
        apply(values, extra, ev)
    c = data.c
    out = motor = filtered_terms_lugre(data, lugre, ev)
    coef = ev[list(terms.ADDITIVE_SLOTS)]
    if coef[:3].any():
        out = out + coef[:3] @ filtered_columns(c, "base", lambda q: terms.additive_columns(q, 0.0)[:3])
    if coef[3:].any():
        pitch = float(ev[terms.COG_PITCH])
        out = out + coef[3:] @ filtered_columns(c, pitch, lambda q: terms.cogging_columns(q, pitch))
    if extra["inertia_error"]:
        out = out + extra["inertia_error"] * c.a
    if extra["torque_lag"]:
        # the joint felt tau(t - lag), the record says tau(t): the estimate tau - M qdd carries
        # the difference (the filters are linear and time-invariant, so delay the filtered tau)
        # (in time since the record's start: a Unix time's 0.24 us rounding quantises the lag)
        t = c.t_since_start
        out = out + c.tau - np.interp(t - extra["torque_lag"], t, c.tau)
    if data.load_encoder and extra["backlash"] > 0 and extra["motor_inertia"] > 0:
        # backlash seen from the load: the motor leads through the gap (bench.load_side.gap_slip);
        # its friction on v_l + de/dt and its inertia term M_motor e'' (the motor's inertia is in
        # the lead's dynamics, so it is fitted as such, not as a linear load); the whole term's
        # share is a screening column (0 at the effect's zero strength, 1 once refitted)
        _, unit, along = gap_slip(data, extra["backlash"], extra["motor_inertia"])
        return out + extra["gap_slip"] * (along + extra["motor_inertia"] * unit)
    if data.load_encoder and extra["flex_frequency"] > 0:
        # a gear spring seen from the load: the motor leads by e (bench.load_side.spring_slip);
        # its friction runs on v_l + de/dt, and eq. 5 leaves M_motor e'' (the load key holds
        # the inertia beyond the spring from the encoder, here the motor's).  The slip's share
        # is a screening column (0 at the effect's zero strength); the joint fit holds it at 1,
        # its physics (left free it traded against sigma0/sigma1: 0.18 on the rotary motor)
        slip, unit = spring_slip(c, extra["flex_frequency"], extra["flex_damping"])
        if extra["flex_slip"]:
            along = filtered_terms_lugre(data, lugre, ev, along=((extra["flex_frequency"], extra["flex_damping"]),
                                                                 c.v_mid + slip))
            out = out + extra["flex_slip"] * (along - motor)
        return out + extra["load_inertia"] * unit
    if extra["load_inertia"] and (extra["backlash"] > 0 or extra["flex_frequency"] > 0):
        # a load beyond the gear (encoder on the motor): eq. 5 leaves M_load (qdd_l - qdd_m),
        # the load driven through the gear by the motor's recorded trajectory
        spring = (extra["flex_frequency"], extra["flex_damping"])
        if spring[0] <= 0 and extra["contact_frequency"] > 0:     # the flanks' own contact
            spring = (extra["contact_frequency"], extra["contact_damping"])
        gear = (extra["backlash"], *spring, extra["load_kappa"])
        out = out + extra["load_inertia"] * gear_unit_term(data, lugre, *gear, motor=motor)
    return out


def cleaned(data: FitData, values: dict, appliers: list[Applier] = ()) -> FitData:
    """The friction estimate with the effects' contribution removed, to re-identify LuGre on.
    A gear spring or backlash seen from the load leaves the friction on the *motor's*
    velocity: the cleaned record is then the motor's (velocity v_l + de/dt, its inertia term
    M_m e'' removed), so LuGre is identified where it acts, not bent by the load's motion."""
    lugre_only = {k: values[k] for k in LUGRE_KEYS}
    f = values.get("flex_frequency", 0.0)
    gap = values.get("bl_width", 0.0) if values.get("bl_motor", 0.0) > 0 else 0.0
    if not (data.load_encoder and (f > 0 or gap > 0)):
        contribution = predict(data, values, appliers) - predict(data, lugre_only)
        return FitData(c=data.c, friction=data.friction - contribution, mask=data.mask, z0=data.z0,
                       revolute=data.revolute, load_encoder=data.load_encoder)
    c = data.c
    if gap > 0:
        slip, unit, _ = gap_slip(data, gap, values["bl_motor"])
        inertia, rest = values["bl_motor"], dict(values, bl_motor=0.0)
    else:
        (slip, unit), inertia = spring_slip(c, f, values["flex_damping"]), values["flex_load"]
        rest = dict(values, flex_load=0.0)     # the other effects' terms, on the load's motion
    plain = FitData(c=c, friction=data.friction, mask=data.mask, z0=data.z0, revolute=data.revolute)
    contribution = (predict(plain, rest, appliers) - predict(plain, lugre_only)
                    + inertia * unit)
    motor = replace(c, v_mid=c.v_mid + slip, v=c.v + c.lowpass(c.at_samples(slip)))
    return FitData(c=motor, friction=data.friction - contribution, mask=data.mask, z0=data.z0,
                   revolute=data.revolute)


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
        checkpoint()        # a caller may stop a long analysis here (bench.checkpoint)
        r = (y - predict(data, values_of(x), appliers))[mask]
        return r if np.all(np.isfinite(r)) else np.full_like(r, 1e6 * (np.abs(y).max() + 1))

    x0 = np.array([np.clip(p.to_x(p.value), p.lo, p.hi) for p in params])
    lo = np.array([p.lo for p in params])
    hi = np.array([p.hi for p in params])
    # a load carrying friction is simulated with the LuGre values (gear_friction_terms), ten
    # times the cost of the model without it: the Jacobian's LuGre columns then keep the load
    # on the path of the point they step from (gear_friction_terms; the residuals themselves
    # stay exact, and the standard errors get one exact Jacobian at the end).  j1 with all its
    # friction beyond 3 mrad of backlash (an independent simulator's record): the same fit
    # as with exact columns, 10.9 s against 20.3 s for the analysis
    load_friction = any(k.endswith("_kappa") and v > 0 for k, v in values_of(x0).items())
    jac = _jacobian(resid, params, hi, data.cache, frozen=True) if load_friction else "2-point"
    res = least_squares(resid, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac",
                        max_nfev=max_nfev, xtol=1e-10, ftol=1e-10, gtol=1e-10)
    if load_friction:
        res.jac = _jacobian(resid, params, hi, data.cache, frozen=False)(res.x)
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


def _jacobian(resid, params: list[Param], hi: np.ndarray, cache: dict, frozen: bool):
    """A forward-difference Jacobian with scipy's steps ("2-point"); with ``frozen``, the
    steps of LuGre values reuse the load's simulation of the point they step from."""
    lugre = set(LUGRE_KEYS) | {"delta"}

    def jac(x, *_):
        f0 = resid(x)
        J = np.empty((len(f0), len(x)))
        for i, p in enumerate(params):
            h = np.sqrt(np.finfo(float).eps) * max(1.0, abs(x[i]))
            if x[i] + h > hi[i]:
                h = -h
            xi = x.copy()
            xi[i] += h
            cache["freeze_load"] = frozen and p.name in lugre
            try:
                J[:, i] = (resid(xi) - f0) / h
            finally:
                cache["freeze_load"] = False
        return J
    return jac


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
