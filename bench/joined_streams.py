"""Streams on rows of their own: loggers' tables joined on their times, other cells empty.

A table that holds each stream's readings on the rows of their own instants and leaves the
other columns' cells empty there -- an outer join of two loggers' tables on their time
columns, a ROS bag exported with one row per message and the other topics' cells empty, a
torque written on every tenth row of the encoder's logger -- says exactly when each reading
was taken.  Read as lost samples, such rows were dropped: a torque
on rows of its own left no row holding every column (refused), and a sparser torque or
position had the record analysed at its rate (the rotary motor's 100 Hz torque on 1 kHz rows:
every value but sigma2 undetermined, Fc -67 %, tuning seed 1651).  Here the record keeps the
torque's rows (or a stream's 2.5x as dense), and each other column takes the last reading
before each row together with that reading's instant, so that
``bench.slow_stream.filled_forward`` reads it between its readings at their own times (or, a
command held, as written).
"""
from __future__ import annotations

import copy

import numpy as np

from bench.records import Record
from bench.resample import increasing
from bench.rows import drop_empty_rows, keep_rows
from bench.slow_stream import GAP_INTERVALS, MIN_READINGS, MIN_ROWS_PER_READING

VALUES = ("tau", "q", "qd")
# A column is a stream of its own where it is empty on at least half the kept rows and its
# readings are spread among the rows (at least half as many runs of empty cells as
# readings): a logger's lost samples (1 % of the rows) and a sensor dead for a stretch (one
# run) stay lost samples, dropped rows, as before.
# (Fewer than ``MIN_READINGS`` and a column is not read as a stream; across a pause in it of
# over ``GAP_INTERVALS`` of its intervals the rows are a gap, dropped, not filled.)
EMPTY_SHARE = 0.5
SPREAD_SHARE = 0.5


def sparse_columns(rec: Record) -> dict | None:
    """{"rows_of": the torque or a denser column, "placed": the sparser streams} where ``rec``
    holds streams on rows of their own (module docstring); else None.  Counts only: the time
    column may still be in the file's unit."""
    cols = [c for c in VALUES if getattr(rec, c) is not None]
    seen = {c: np.isfinite(np.asarray(getattr(rec, c), dtype=float)) for c in cols}
    rows = np.isfinite(np.asarray(rec.t, dtype=float)) & np.logical_or.reduce([seen[c] for c in cols])
    if np.count_nonzero(rows) < 2 * MIN_READINGS:
        return None
    count = {c: np.count_nonzero(seen[c] & rows) for c in cols}
    # The torque's rows are kept unless a stream holds 2.5x its readings: the friction is
    # measured where the torque was read, and a torque placed on rows about as dense as its
    # own is beyond the held-command test (calibrated every 3-10 rows): a PID's torque read
    # on rows of its own between a 1 kHz encoder's was taken for a command held and the
    # rotary motor's Fc read -63 % (tuning seed 1710).  Denser streams win: dropping rows
    # between a torque's readings read Fc 14-44 % low (``bench.slow_stream``).
    densest = max(cols, key=count.get)
    base = "tau" if count["tau"] * MIN_ROWS_PER_READING > count[densest] else densest
    placed = []
    for c in cols:
        if c == base:
            continue
        s = seen[c][rows]
        n = count[c]
        empty_runs = np.count_nonzero(np.diff(s.astype(np.int8)) == -1) + int(not s[0])
        empty = 1.0 - np.count_nonzero(seen[c] & seen[base] & rows) / count[base]
        if n >= MIN_READINGS and empty >= EMPTY_SHARE and empty_runs >= SPREAD_SHARE * n:
            placed.append(c)
    return {"rows_of": base, "placed": placed} if placed else None


def onto_kept_rows(rec: Record, name: str) -> tuple[Record, dict]:
    """``rec`` (``reading["joined_streams"]`` set by ``sparse_columns``) on the rows its
    torque (or a denser stream) was read on, each other column holding the last reading at or
    before each row, and {column: per row, the instant of the reading it holds}; rows before a stream's first
    reading or across a pause in it are dropped as lost samples (counted).  Otherwise the rows
    with an empty cell are dropped as they always were."""
    joined = rec.reading.get("joined_streams")
    if not joined:
        drop_empty_rows(rec, name)
        return rec, {}
    t = np.asarray(rec.t, dtype=float)
    increasing(t, name)        # the readings are looked up by time
    out = copy.copy(rec)
    out.reading = dict(rec.reading)
    keep_rows(out, np.isfinite(np.asarray(getattr(rec, joined["rows_of"]), dtype=float)) & np.isfinite(t))
    instants = {}
    for c in joined["placed"]:
        x = np.asarray(getattr(rec, c), dtype=float)
        seen = np.isfinite(x) & np.isfinite(t)
        tr, xr = t[seen], x[seen]
        gaps = np.diff(tr)
        interval = float(np.median(gaps[gaps > 0])) if np.any(gaps > 0) else 0.0
        k = np.searchsorted(tr, out.t, side="right") - 1
        at = np.maximum(k, 0)
        fresh = (k >= 0) & (out.t - tr[at] <= GAP_INTERVALS * interval)
        setattr(out, c, np.where(fresh, xr[at], np.nan))
        instants[c] = np.where(fresh, tr[at], np.nan)
    kept = drop_empty_rows(out, name)
    return out, {c: v if kept is None else v[kept] for c, v in instants.items()}
