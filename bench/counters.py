"""A time column that is a logger's or a drive's free-running counter wraps: a 16-bit
millisecond counter every 65.5 s, a 32-bit microsecond one every 71.6 minutes (CiA 402
drives' and embedded loggers' timestamps often are).  A record that crosses the wrap read as
time going backwards and was refused.  Such a column is unwrapped in its own unit, before
anything else reads it; the file's values are kept for ``--residuals``.

A backwards step is taken for a wrap only when the column holds whole non-negative counts
below 2^bits and every backwards step, plus 2^bits, is an ordinary step forward (at most
``MAX_STEPS`` median steps): any other decrease is still refused as time going backwards.
"""
from __future__ import annotations

import numpy as np

from bench.records import Record

BITS = (8, 16, 24, 31, 32, 48)   # counter widths loggers and drives use (31: a signed int's positive half)
# a wrap's forward step may include a lost sample or two, like any other step; a larger one
# would be a gap straddling the wrap, which nothing can place
MAX_STEPS = 10


def unwrap_counter(rec: Record) -> tuple[int, int] | None:
    """Unwrap ``rec.t`` (the file's unit) in place if it is a wrapping counter: (its width in
    bits, the number of wraps), or None when the time never goes back or does not wrap like a
    counter."""
    if rec.reading.get("clock_time"):
        return None
    t = np.asarray(rec.t, dtype=float)
    d = np.diff(t)
    back = d < 0
    if not back.any() or t.min() < 0 or not np.all(t == np.round(t)):
        return None
    forward = d[d > 0]
    if len(forward) == 0:
        return None
    step = float(np.median(forward))
    for bits in BITS:
        size = 2.0 ** bits
        if t.max() >= size:
            continue
        wrapped = d[back] + size
        if np.all((wrapped > 0) & (wrapped <= MAX_STEPS * step)):
            rec.t = t + size * np.concatenate(([0.0], np.cumsum(back)))
            return bits, int(back.sum())
        return None      # the narrowest width that holds the counts does not explain the steps
    return None
