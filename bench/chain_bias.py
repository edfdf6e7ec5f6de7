"""How far the measurement chain alone moves the LuGre values, counted in their uncertainty.

A standard error covers noise.  A logger's coarse or jittered sampling, the interpolation
onto the grid and the comparison band leave a bias of their own that no amount of data
averages out: on the independent simulator at 4 ms (jittered, 2 % lost) the rotary motor's
Fs came out 6-11 % low with standard errors of 4-6 %, and the linear stage's Fc 0.3-0.8 % low
with 0.2-0.4 % (README known limits).

The perfect-model replay (``bench.perfect_model.replay``) already puts the fitted model
through this record's chain: its twin has no noise and known values, so a LuGre fit of the
twin, started at those values, moves only by what the chain does to them.  That move is
joined to each standard error.  Measured on the independent simulator (tuning seeds
1986-1987, 1991-1995, 2-4 ms jittered loggers), value error against the twin's move:
the linear stage Fc -0.6/-0.3/-0.5/-0.8 % against -0.4/-0.5/-1.1/-1.0 %; the rotary motor at
2 ms Fs -1.3/+1.0 % against -1.3/-1.3 %, at 4 ms Fs -6.8/-8.8/-6.0/-11.4 % against
-6.4/-4.4/-0.4/-2.0 % (the drive's torque staircase, which the twin does not replay, is the
rest); j3, whose chain is benign, moved under 0.5 %.  Fresh seeds 10252-10255 (the linear
stage, ``tests/diagnosis/test_chain_bias.py``): Fs 3.7-5.1 noise-only errors off, 0.6-0.9 of
the joined ones.  The move is not subtracted: where it is
large the fit lies in a valley (Fc against alpha) and the twin's refit walks it further than
the record's bias goes (Fc -48 % against -22 %), so it is an uncertainty, not a correction.
"""
from __future__ import annotations

import math

from bench.fitting import LUGRE_KEYS, FitData, Param, fit
from bench.identify import is_identifiable
from bench.perfect_model import replay
from bench.records import Record

# A local polish: the twin starts at its own truth
POLISH_NFEV = 30


def shift(rec: Record, data: FitData, values: dict, inertia: float) -> dict[str, float]:
    """{LuGre key: the twin's refitted value minus ``values``'s} (signed), the twin being
    ``rec`` replayed through ``values``."""
    v = {k: float(values[k]) for k in LUGRE_KEYS}
    if not all(x > 0 and math.isfinite(x) for x in v.values()):
        return {}
    twin, _ = replay(rec, data, values, inertia, data.c.cutoff)
    params = [Param(k, v[k], lo=math.log(v[k]) - 4, hi=math.log(v[k]) + 4) for k in LUGRE_KEYS]
    res = fit(twin, params, fixed=dict(values), max_nfev=POLISH_NFEV)
    return {k: float(res.values[k]) - v[k] for k in LUGRE_KEYS}


def widened(doc: dict, moved: dict[str, float]) -> None:
    """The report ``doc`` with the chain's move joined to each standard error, identifiable
    re-judged, and a warning where the move is larger than the noise's error."""
    if not moved:
        return
    doc["chain_shift"] = dict(moved)
    newly, said = [], []
    for k in LUGRE_KEYS:
        se, value, d = doc["uncertainty"].get(k), doc["parameters"][k], abs(moved.get(k, 0.0))
        if se is None or not d:
            continue
        if d > se and value:
            said.append(f"{k} {100 * moved[k] / abs(value):+.2g} %")
        doc["uncertainty"][k] = math.hypot(se, d)
        if doc["identifiable"].get(k) and not is_identifiable(value, doc["uncertainty"][k]):
            doc["identifiable"][k] = False
            newly.append(k)
    if said:
        doc.setdefault("warnings", []).append(
            "the measurement chain alone (the record's sampling, its resampling onto a grid and the "
            f"comparison band) moves a perfect model's values by {', '.join(said)} (the record replayed "
            "through the fitted model and refitted); counted in the uncertainty"
            + (f", so {', '.join(newly)} {'is' if len(newly) == 1 else 'are'} not determined by this "
               "record" if newly else ""))
