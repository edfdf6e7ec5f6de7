"""Which rows of a file are analysed (``bench.readers``): a logger's lost samples — rows with
an empty, NaN or infinite cell — are taken out and counted, and ``--window START:END`` keeps
the part of a long log that holds the excitation."""
from __future__ import annotations

import math

import numpy as np

from bench.errors import InputError
from bench.records import Record


def _columns(rec: Record) -> tuple[str, ...]:
    return ("t", "tau", "q") + (("qd",) if rec.qd is not None else ())


def keep_rows(rec: Record, mask: np.ndarray) -> None:
    """Keep the rows of ``mask`` in every column, the file's integer times and a coarse
    clock's stamps as written (``bench.coarse_time``) among them."""
    for col in _columns(rec):
        setattr(rec, col, getattr(rec, col)[mask])
    for key in ("raw_ticks", "stamps_t"):
        if rec.reading.get(key) is not None:
            rec.reading[key] = rec.reading[key][mask]


def drop_empty_rows(rec: Record, name: str, spare: tuple[str, ...] = ()) -> np.ndarray | None:
    """Rows with an empty, NaN or infinite cell in a mapped column are a logger's dropped
    samples: taken out (counted in the report) and handled as uneven time and gaps are; the
    rows kept (None: all).  ``spare``: columns whose empty cells stay (``bench.joined_streams``
    fills them)."""
    cols = _columns(rec)
    ok = np.ones(len(rec.t), dtype=bool)
    for col in cols:
        if col in spare:
            continue
        ok &= np.isfinite(getattr(rec, col))
    if ok.all():
        return None
    if not ok.any():
        alone = [c for c in cols if c != "t" and np.isfinite(getattr(rec, c)).any()]
        hint = ""
        if len(alone) > 1:    # each stream on its own rows, too few readings (bench.joined_streams)
            hint = (f" ({', '.join(alone)} each hold numbers, on different rows: streams joined on their "
                    f"own times, one with too few readings to read as a stream; record longer, or put "
                    f"the slower one on the faster one's rows, filled forward (pandas merge_asof))")
        raise InputError(f"{name}: no row holds a number in every one of {', '.join(cols)}{hint}")
    keep_rows(rec, ok)
    rec.reading["empty_rows"] = rec.reading.get("empty_rows", 0) + int((~ok).sum())
    return ok


def parse_window(spec: str | None) -> tuple[float, float] | None:
    """"START:END" (seconds from the first sample; either side may be empty) -> (start, end)."""
    if spec is None or not str(spec).strip():
        return None
    a, colon, b = str(spec).partition(":")
    try:
        lo = float(a) if a.strip() else 0.0
        hi = float(b) if b.strip() else math.inf
    except ValueError:
        lo = hi = math.nan
    if not colon or not (0 <= lo < hi) or math.isnan(hi):
        raise InputError(f"window {spec!r} is not START:END in seconds from the first sample "
                         f"(0 <= START < END, e.g. 120:300 or 600:)")
    return lo, hi


def cut(rec: Record, span: tuple[float, float], name: str) -> None:
    """Keep the samples of ``span`` (seconds from the first sample)."""
    rel = rec.t - rec.t[0]
    keep = (rel >= span[0]) & (rel <= span[1])
    if keep.sum() < 2:
        raise InputError(f"{name}: the window {span[0]:g}:{span[1]:g} s holds {int(keep.sum())} samples "
                         f"(the record lasts {rel[-1]:.6g} s)")
    keep_rows(rec, keep)
    rec.reading["window"] = {"start": span[0], "end": min(span[1], float(rel[-1])), "samples": int(keep.sum())}
