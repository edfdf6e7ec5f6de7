"""``--inertia estimate``: the joint's inertia read off the record itself, for a log whose
M_jj nobody wrote down (a working robot's joint: motor, gear and link, reflected).

Eq. 5 needs M to turn the torque into friction; at sliding speeds the friction depends on the
velocity alone, so the torque's dependence on the acceleration there is M (the regression
``bench.effects.inertia_error`` makes for a declared M, made from nothing).  LuGre's bristles
lag the Stribeck map while the joint accelerates, which that regression reads as inertia
(the linear stage 3 % low on our generator), so it is refined the way an inertia error is
fitted: LuGre identified with it, and the inertia's correction fitted beside LuGre.  The
diagnosis then cannot name an inertia error (no inertia was declared); the report gives the
estimate, its standard error and how it was read.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from bench.errors import InputError
from bench.records import Record

ESTIMATE = "estimate"
# the regression's standard error (of M) above which the estimate is said to be poor (a motion
# with little acceleration at its sliding speeds); refused when it is not clearly positive
POOR = 0.1


def wanted(rec: Record, inertia) -> bool:
    """Is the inertia to be estimated (``--inertia estimate`` or ``# inertia: estimate``)?"""
    value = inertia if inertia is not None else rec.meta.get("inertia")
    return isinstance(value, str) and value.strip().lower() == ESTIMATE


def regression(rec: Record, name: str = "record", cutoff: float | None = None) -> tuple[float, float]:
    """M and its standard error from tau = M qdd + Fc sgn v + sigma2 v + c at the record's
    sliding speeds.  Not gravity: under a torque sine q ~ -qdd, and a sin q + b cos q took
    the inertia whole (j1 on our generator: 10 ± 88 for 250); the diagnosis names gravity
    on the estimated inertia instead, where the motion's harmonics tell them apart."""
    from bench.identify import prepare
    data, _ = prepare(rec, inertia=0.0, cutoff=cutoff, name=name)
    c, m = data.c, data.mask
    speed = np.abs(c.v)
    vmax = float(np.percentile(speed[m], 99.5)) if m.any() else 0.0
    hi = m & (speed > 0.5 * vmax)
    if vmax <= 0 or hi.sum() < 20:
        raise InputError(f"{name}: the joint does not slide long enough to estimate its inertia: give --inertia")
    X = np.column_stack([c.a, np.sign(c.v), c.v, np.ones_like(c.v)])[hi]
    coef, *_ = np.linalg.lstsq(X, c.tau[hi], rcond=None)
    r = c.tau[hi] - X @ coef
    # the residual's samples are correlated over the low-pass's span: its effective count
    # (cutoff vs grid rate) sets the standard error, not the grid's samples
    n_eff = max(hi.sum() * min(1.0, 2.0 * c.cutoff * c.dt_grid), len(coef) + 1.0)
    cov = np.linalg.pinv(X.T @ X) * float(np.sum(r ** 2)) / (n_eff - len(coef)) * hi.sum() / n_eff
    return float(coef[0]), float(math.sqrt(max(cov[0, 0], 0.0)))


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
        M0, se = regression(rec, name, cutoff)
    if not M0 > 3.0 * se:
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
    if info.get("poor"):
        text += (" - poorly: this motion hardly accelerates while it slides; declare the inertia "
                 "if it is known")
    return text
