"""``bench analyze --residuals OUT.csv``: the comparison at the record's own timestamps.

Columns ``t, measured, baseline, final, held_out``: the measured friction (tau - M q'', or the
friction column; low-passed exactly as the tool compares it), the LuGre-only model, the final
model with its effects, and 1 where the sample lies in held-out scoring (every scored cycle
is held out in one fold; 0 for filter edges, start-up and segments too short to score).  The
comparison grid is interpolated linearly onto the raw timestamps, segment by segment; a raw
sample outside every segment's grid (a dropped segment, a filter edge beyond the first grid
point) gets NaN, so another tool can be set beside this one on exactly the same samples.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.fitting import predict

COLUMNS = ("t", "measured", "baseline", "final", "held_out")


def held_out_mask(analysis) -> np.ndarray:
    """Grid samples scored on held-out folds: around the cross-validation's scored indices
    (it scores a subsample of the low-passed residual), within the fit mask."""
    data = analysis.ident.data
    cv = analysis.diagnosis.cv if analysis.diagnosis is not None else None
    idx = getattr(cv, "idx", None)
    if idx is None or len(idx) < 2:
        return np.zeros(len(data.c.t), dtype=bool)
    half = max(1, int(np.median(np.diff(idx)))) // 2
    near = np.zeros(len(data.c.t) + 1, dtype=int)
    np.add.at(near, np.clip(idx - half, 0, len(data.c.t)), 1)
    np.add.at(near, np.clip(idx + half + 1, 0, len(data.c.t)), -1)
    return (np.cumsum(near)[:-1] > 0) & data.mask


def residual_table(analysis, raw_t: np.ndarray) -> dict:
    data = analysis.ident.data
    c = data.c
    if analysis.diagnosis is not None:
        baseline, final = analysis.diagnosis.contexts[0].model, analysis.diagnosis.contexts[-1].model
    else:
        baseline = final = predict(data, analysis.ident.result.values)
    grid = {"measured": data.friction, "baseline": baseline, "final": final,
            "held_out": held_out_mask(analysis).astype(float)}
    out = {k: np.full(len(raw_t), np.nan) for k in grid}
    for a, b in c.grid_segments:
        if b - a < 2:
            continue
        tg = c.t[a:b]
        inside = (raw_t >= tg[0]) & (raw_t <= tg[-1])
        for k, y in grid.items():
            out[k][inside] = np.interp(raw_t[inside], tg, y[a:b])
    held = out.pop("held_out")
    out["held_out"] = np.where(np.isnan(held), 0, held == 1.0).astype(int)
    return {"t": np.asarray(raw_t, dtype=float), **out}


def write_residuals(analysis, path: str | Path) -> Path:
    rec = analysis.record
    raw_t = rec.reading.get("raw_t", rec.t)
    table = residual_table(analysis, np.asarray(raw_t, dtype=float))
    # t as the file wrote it (its own unit, ``time_unit``), so the rows join on the file's values
    ticks = rec.reading.get("raw_ticks")
    if ticks is not None and len(ticks) == len(table["t"]):
        t_col, t_fmt = ticks, "%d"
    else:   # a clock coarser than the samples: its stamps, the values at the spread times
        stamped = rec.reading.get("stamps_t")
        t_si = stamped if stamped is not None and len(stamped) == len(table["t"]) else table["t"]
        t_col = t_si / rec.reading.get("units", {}).get("time", {}).get("factor", 1.0)
        t_fmt = "%.16g"      # 16 digits: epoch seconds with microseconds survive
    path = Path(path)
    with open(path, "w") as fh:
        fh.write(",".join(COLUMNS) + "\n")
        rows = zip(t_col, table["measured"], table["baseline"], table["final"], table["held_out"])
        fh.writelines(f"{t_fmt % t},{m:.9g},{b:.9g},{f:.9g},{h:d}\n" for t, m, b, f, h in rows)
    return path
