"""Where the final model leaves structure, its LuGre values are those a model without that
structure settles on, and their standard errors (noise only) say nothing of it.  How far the
values move when the model is fitted on parts of the record that the structure treats
differently -- the first half against the second in time, the lower half of the travel
against the upper, sliding up against sliding down -- joins their standard errors.

Each half's fit is a local polish from the final values (as a nested control's): one
linear step on a half's samples went far along a valley the values trade off in (Fc
against alpha on j1 under two tones: 3.7x), where the fit itself stays in it.  Half the difference between two halves is, on noise
alone, about the whole record's standard error (each half has half the samples), so the
spread on a record with nothing left is no wider than the standard errors already are.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from bench.fitting import LUGRE_KEYS, FitData, Param, fit
from bench.identify import is_identifiable
from bench.screening import Model

# A part determines a value when its standard error is within this factor of the whole
# record's (sqrt 2 on noise alone); beyond it the part cannot tell the value from another
# parameter (Fc from a direction asymmetry within one direction) and its difference is not
# a spread.
DETERMINED_RATIO = 4.0
# a part needs this share of the scored samples (a joint that barely slides one way)
MIN_PART = 0.2


def parts(data: FitData) -> dict[str, np.ndarray]:
    """Per way of halving the scored samples, a boolean over them: the first half."""
    idx = np.nonzero(data.mask)[0]
    c = data.c
    t, q, v = c.t[idx], c.q[idx], c.v[idx]
    return {"time": t < np.median(t), "travel": q < np.median(q), "direction": v > 0}


def spread(data: FitData, model: Model, se: dict[str, float | None]) -> dict[str, float]:
    """Per LuGre value, half the largest difference between the two halves' fits over the
    ways of halving in which both determine it (0 where none does)."""
    out = {k: 0.0 for k in LUGRE_KEYS}
    idx = np.nonzero(data.mask)[0]
    params = [Param(p.name, model.values[p.name], p.log,
                    (math.log(model.values[p.name]) - 4 if p.log else p.lo),
                    (math.log(model.values[p.name]) + 4 if p.log else p.hi)) for p in model.params]
    for first in parts(data).values():
        if min(first.mean(), 1.0 - first.mean()) < MIN_PART:
            continue
        fits = []
        for part in (first, ~first):
            mask = np.zeros_like(data.mask)
            mask[idx[part]] = True
            # a local polish from the final values, as ``refit_without``
            fits.append(fit(replace(data, mask=mask), params, fixed=model.values,
                            appliers=model.appliers, max_nfev=20))
        for k in LUGRE_KEYS:
            whole = se.get(k)
            ses = [f.stderr.get(k) for f in fits]
            if k not in model.values or whole is None or None in ses:
                continue
            # each half's standard error is about sqrt 2 of the whole's on noise alone
            if max(ses) <= DETERMINED_RATIO * math.sqrt(2.0) * whole:
                out[k] = max(out[k], abs(fits[0].values[k] - fits[1].values[k]) / 2.0)
    return out


def widened(doc: dict, spread_of: dict[str, float]) -> None:
    """The report ``doc`` with each LuGre value's spread joined to its standard error, its
    identifiable re-judged and a warning naming what moved."""
    newly, moved = [], []
    for k in LUGRE_KEYS:
        se, d = doc["uncertainty"].get(k), spread_of.get(k, 0.0)
        if se is None or not d:
            continue
        doc["uncertainty"][k] = wide = math.hypot(se, d)
        value = doc["parameters"][k]
        if value and d > se:
            moved.append(f"{k} ± {100 * d / abs(value):.2g} %")
        if doc["identifiable"].get(k) and not is_identifiable(value, wide):
            doc["identifiable"][k] = False
            newly.append(k)
    doc["structure_spread"] = {k: spread_of.get(k, 0.0) for k in LUGRE_KEYS}
    if moved:
        doc["warnings"].append(
            "the model leaves structure (see unexplained), so its values are those a model without it "
            "settles on: fitted on halves of the record (early and late, low and high on the travel, "
            f"each direction) they lie {', '.join(moved)} about their middle, counted in the uncertainty"
            + (f", so {', '.join(newly)} {'is' if len(newly) == 1 else 'are'} not determined by this "
               "record" if newly else ""))
