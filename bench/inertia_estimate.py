"""``--inertia estimate``: the joint's inertia read off the record itself, for a log whose
M_jj nobody wrote down (a working robot's joint: motor, gear and link, reflected).

Eq. 5 needs M to turn the torque into friction; at sliding speeds the friction depends on the
velocity alone, so the torque's dependence on the acceleration there is M (the regression
``bench.effects.inertia_error`` makes for a declared M, made from nothing).  LuGre's bristles
lag the Stribeck map while the joint accelerates, which that regression reads as inertia
(the linear stage 3 % low on our generator), and effects left in the residual widen it, so
the analysis that runs on it is followed by the way an inertia error is fitted: M refitted
beside LuGre and the effects named, and the analysis repeated.  The diagnosis cannot name an
inertia error then (none was declared); the report gives the estimate, its standard error
and how it was read.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from bench.errors import InputError
from bench.records import Record, asks_estimate

# the standard error (of M) above which the estimate is said to be poor (a motion with little
# acceleration at its sliding speeds)
POOR = 0.1
# Inertia and gravity are said to be one measurement on this record when gravity beside the
# regression widens its standard error more than CONFOUNDED times and the acceleration follows
# the position over the whole record (FOLLOWS, 1 / sqrt(1 - R^2)).  Tuning seeds 1620-1642:
# our generator's torque sine 4.1x (the rotary motor) to 20x (j3; 30x on j1 with gravity in
# the torque) and 1.61-2.54; the independent simulator's two tones 1.4-2.0x and 1.25-1.61,
# its PD-tracked sine 2.0-2.65 there; PID-tracked point-to-point logs 1.0-3.1x (above 3.5 on
# 2 of 6 fresh seeds) but 1.02-1.09, their dwells hold gravity at many poses
CONFOUNDED, FOLLOWS = 3.5, 1.3


def wanted(rec: Record, inertia) -> bool:
    """Is the inertia to be estimated (``--inertia estimate`` or ``# inertia: estimate``)?"""
    return asks_estimate(inertia if inertia is not None else rec.meta.get("inertia"))


def regression(rec: Record, name: str = "record",
               cutoff: float | None = None) -> tuple[float, float, tuple[float, float]]:
    """M and its standard error from tau = M qdd + Fc sgn v + sigma2 v + c at the record's
    sliding speeds, and (how much a sin q + b cos q beside it would widen that error, how
    closely the acceleration follows sin q and cos q over the whole record; 1: not at all).
    Gravity is not fitted here: the analysis names it on the estimate and M is then refitted
    beside it.  But under a torque sine q ~ -qdd and the two are one column (the
    widening 35x on j1 on our generator, where gravity took the whole inertia: 10 ± 88 for
    250), and gravity left in the torque then went into M unseen (0.1 Fc on j1: M 17 % low,
    nothing named)."""
    from bench.identify import prepare
    data, _ = prepare(rec, inertia=0.0, cutoff=cutoff, name=name)
    c, m = data.c, data.mask
    speed = np.abs(c.v)
    vmax = float(np.percentile(speed[m], 99.5)) if m.any() else 0.0
    hi = m & (speed > 0.5 * vmax)
    if vmax <= 0 or hi.sum() < 20:
        raise InputError(f"{name}: the joint does not slide long enough to estimate its inertia: give --inertia")
    # the residual's samples are correlated over the low-pass's span: its effective count
    # (cutoff vs grid rate) sets the standard error, not the grid's samples
    n_eff = hi.sum() * min(1.0, 2.0 * c.cutoff * c.dt_grid)

    def line(cols):
        X = np.column_stack(cols)[hi]
        coef, *_ = np.linalg.lstsq(X, c.tau[hi], rcond=None)
        r = c.tau[hi] - X @ coef
        dof = max(n_eff - len(coef), 1.0)
        cov = np.linalg.pinv(X.T @ X) * float(np.sum(r ** 2)) / dof * hi.sum() / max(n_eff, 1.0)
        return float(coef[0]), float(math.sqrt(max(cov[0, 0], 0.0)))

    base = [c.a, np.sign(c.v), c.v, np.ones_like(c.v)]
    M, se = line(base)
    widening, follows = 1.0, 1.0
    if rec.joint_type == "revolute" and np.ptp(c.q[m]) > 0.05:
        widening = line(base + [np.sin(c.q), np.cos(c.q)])[1] / max(se, 1e-300)
        # ... and over the whole record, dwells and slow parts too, where the analysis reads
        # gravity held at a pose: 1 / sqrt(1 - R^2) of qdd on (1, sin q, cos q)
        G = np.column_stack([np.ones_like(c.q), np.sin(c.q), np.cos(c.q)])
        coef, *_ = np.linalg.lstsq(G, c.a, rcond=None)
        unexplained = np.sum((c.a - G @ coef) ** 2) / max(np.sum((c.a - c.a.mean()) ** 2), 1e-300)
        follows = 1.0 / math.sqrt(max(unexplained, 1e-12))
    return M, se, (widening, follows)


def analyze(rec: Record, add, diagnose_effects: bool, cutoff, name: str):
    """``bench.analysis.analyze_record`` with the inertia read off the record: the regression;
    the analysis on it; the inertia refitted beside LuGre and the effects that names; the
    analysis repeated on that.  (Refitted beside LuGre alone first, cogging left in the
    residual took it 6-22 % astray on PID logs of the independent simulator, tuning seeds
    1620-1627; beside the named cogging 0.03-8 %.)"""
    from bench.analysis import _analyze, _ready, fit_errors
    if add and "inertia_error" in add:
        raise InputError("effect inertia_error does not apply to a record whose inertia is estimated "
                         "from itself (declare it to test it)")
    rec = _ready(replace(rec, meta={k: v for k, v in rec.meta.items() if k != "inertia"}), None, name, cutoff)
    with fit_errors():
        M0, se, widening = regression(rec, name, cutoff)
    # a wide first value is refitted below (cogging took the regression to 290 ± 120 for 250 on
    # a PID log of j1, fresh seed 5830); only one that is not a mass at all stops here
    if not (M0 > 0 and math.isfinite(M0)):
        raise InputError(f"{name}: this record does not determine the joint's inertia (estimate {M0:.3g} "
                         f"± {se:.2g}): give --inertia")
    result = _analyze(_with(rec, M0, True), M0, add, diagnose_effects, cutoff, name)
    named = list(add) if add else (result.diagnosis.model.names() if result.diagnosis is not None else [])
    M, se_fit = _refined(rec, M0, named, cutoff, name)
    info = {"inertia": M, "standard_error": se if se_fit is None else se_fit, "regression": M0,
            "regression_standard_error": se, "beside": named}
    result = _analyze(_with(rec, M, True), M, add, diagnose_effects, cutoff, name)
    if info["standard_error"] > POOR * M:
        info["poor"] = True
    if widening[0] > CONFOUNDED and widening[1] > FOLLOWS:
        info["gravity_confounded"] = {"widening": round(widening[0], 3), "position_follows": round(widening[1], 3)}
    result.ident.warnings.insert(0, warning(info))
    result.ident.fit["inertia_estimate"] = info
    return result


def _with(rec: Record, M: float, estimated: bool) -> Record:
    meta = dict(rec.meta, inertia=M)
    if estimated:   # the diagnosis then has no declared inertia to call wrong
        meta["inertia_estimated"] = True
    return replace(rec, meta=meta)


def _refined(rec: Record, M: float, effects: list[str], cutoff, name: str) -> tuple[float, float | None]:
    """M corrected by an inertia error fitted beside LuGre and ``effects``, and that fit's
    standard error of it (None where its Jacobian was singular)."""
    from bench.analysis import _analyze
    a = _analyze(_with(rec, M, False), M, list(effects) + ["inertia_error"], True, cutoff, name)
    fit = a.diagnosis.model
    M2 = M + float(fit.values.get("inertia_error", 0.0))
    se = (fit.result.stderr or {}).get("inertia_error") if fit.result is not None else None
    return (M2, se) if M2 > 0 else (M, None)


def warning(info: dict) -> str:
    beside = f", refitted beside LuGre{''.join(', ' + e for e in info['beside'])}"
    text = (f"no inertia was declared: M = {info['inertia']:.4g} ± {info['standard_error']:.2g} "
            f"(standard error) was estimated from the record{beside}; an inertia error cannot "
            f"be named")
    if info.get("gravity_confounded"):
        text += (" - and under this motion the joint's position follows its acceleration, so "
                 "the inertia and gravity left in the torque are one measurement: the estimate "
                 "holds only if the torque has gravity compensated (a log of moves with dwells, or "
                 "two tones, separates them); declare the inertia if it is known")
    elif info.get("poor"):
        text += (" - poorly: this motion hardly accelerates while it slides; declare the inertia "
                 "if it is known")
    return text
