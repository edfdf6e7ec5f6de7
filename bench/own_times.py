"""Signals with time vectors of their own, as MATLAB files hold them, joined on their times.

Simulink's To Workspace "Structure With Time" (``q.time``, ``q.signals.values``), a
timeseries saved as a struct (``q.Time``, ``q.Data``) and the per-topic tables of a ROS bag
read into MATLAB give each signal its own instants: a 200 Hz encoder beside a 1 kHz torque, or
two loggers' clocks.  Mapped as columns of one table they were of different lengths (a
traceback), or of one length on different instants (read as if taken together).  Here each
mapped signal that has a time vector of its own, other than the time column's, is put on the
rows of its own instants with the other cells empty -- the table an outer join of the
loggers' tables on their times would be -- and ``bench.joined_streams`` reads it as it reads
such a CSV.  In any format a mapped column may name its time column itself
(``--columns q=q@t_q``), as a scope's or a spreadsheet's side-by-side export has them.
"""
from __future__ import annotations

import re

import numpy as np

from bench.errors import InputError

# a struct's fields that hold its signal's instants, and those that hold its values
TIME_FIELDS = ("time", "Time", "t", "timestamp", "timestamps")
VALUE_FIELDS = ("signals.values", "Data", "data", "values")


def time_of(table: dict, key: str) -> str | None:
    """The key of ``key``'s own time vector: a time field of the struct holding it (or of a
    struct above, or of ``key`` itself as ``signal_names`` names a struct), of its length;
    None when it has none."""
    n = len(table[key])
    parts = re.sub(r"\(\d+\)$", "", key).split(".")
    while parts:
        for f in TIME_FIELDS:
            k = ".".join(parts + [f])
            if k != key and k in table and len(table[k]) == n:
                return k
        parts.pop()
    return None


def signal_names(table: dict) -> dict:
    """{struct name: its values' key} for structs holding one signal and its time (``q`` for
    ``q.signals.values``), so that ``--columns q=q`` or no mapping at all reaches them."""
    out = {}
    for key in table:
        for f in VALUE_FIELDS:
            if key.endswith("." + f):
                struct = key[: -len(f) - 1]
                if struct not in table and time_of(table, key):
                    out[struct] = key
    return out


def _floats(table, key, name: str) -> np.ndarray:
    col = table[key] if isinstance(table, dict) else table.column(key).to_numpy(zero_copy_only=False)
    try:
        return np.asarray(col, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: column {key!r} is not numeric") from None


def clock_or_numbers(col) -> np.ndarray:
    """A column (Arrow or array) as floats, or as datetime64[ns] where it holds clock times
    (Arrow's timestamps, ISO strings; empty cells NaT) -- the kinds the reader takes for a
    time.  Neither: ValueError or TypeError."""
    if hasattr(col, "type"):       # an Arrow column
        import pyarrow as pa
        if pa.types.is_timestamp(col.type):
            return col.cast(pa.timestamp("ns")).to_numpy(zero_copy_only=False).astype("datetime64[ns]")
        try:
            col = col.to_numpy(zero_copy_only=False)
        except pa.ArrowException as e:
            raise ValueError(str(e)) from None
    arr = np.asarray(col)
    if arr.dtype.kind == "M":
        return arr.astype("datetime64[ns]")
    try:
        return np.asarray(arr, dtype=float)
    except (TypeError, ValueError):
        return np.array(arr, dtype="datetime64[ns]")


def _instants(table, key, name: str) -> np.ndarray:
    """A time column of ``table`` read by ``clock_or_numbers``; neither kind: one line."""
    try:
        return clock_or_numbers(table[key] if isinstance(table, dict) else table.column(key))
    except (TypeError, ValueError):
        raise InputError(f"{name}: column {key!r} is not numeric (nor clock times)") from None


def _seconds(stamps: dict, keys: dict, name: str) -> tuple[dict, np.datetime64 | None]:
    """Clock times as seconds from one epoch, the earliest instant of them all (float
    seconds since 1970 keep only a quarter of a microsecond); numbers as they are.  The two
    kinds together have no common origin: one line."""
    clock = {role: ts.dtype.kind == "M" for role, ts in stamps.items()}
    if not any(clock.values()):
        return stamps, None
    if not all(clock.values()):
        a = next(keys[r] for r, c in clock.items() if c)
        b = next(keys[r] for r, c in clock.items() if not c)
        raise InputError(f"{name}: time {a!r} holds clock times and {b!r} numbers; give the "
                         "times in one kind, so that they share an origin")
    valid = [ts[~np.isnat(ts)] for ts in stamps.values()]
    epoch = min(v.min() for v in valid if len(v))
    out = {}
    for role, ts in stamps.items():
        sec = (ts - epoch).astype(np.int64) * 1e-9
        sec[np.isnat(ts)] = np.nan
        out[role] = sec
    return out, epoch


def given_times(mapping: dict, names: list) -> tuple[dict, dict]:
    """``--columns q=NAME@TIME`` -> ({'q': NAME}, {'q': TIME}): a column with a time column of
    its own, as a spreadsheet's or a scope's side-by-side export has (``t_q, q``).  A name
    that holds '@' itself stays a name."""
    out, given = dict(mapping), {}
    for role, col in mapping.items():
        if role != "t" and col not in names and "@" in col:
            name, _, tk = col.rpartition("@")
            out[role], given[role] = name.strip(), tk.strip()
    return out, given


def join(table, names: list, mapping: dict, name: str, explicit: bool, given: dict) -> tuple:
    """(table, mapping, {role: its time's key}) with each mapped signal that has time of its
    own (``given``: named in the mapping; in a MATLAB file's dict, also a struct's) on rows of
    its own instants (module docstring); the table unchanged when none has.  ``names``: the
    table's column names."""
    for role, tk in given.items():
        if tk not in names:
            shown = ", ".join(names[:40])
            raise InputError(f"{name}: no column {tk!r} (the time of {role}); the file's columns: {shown}")
    if any(col not in names for role, col in mapping.items() if explicit or role != "t"):
        return table, mapping, {}     # the reader names the missing column among the file's
    structs = isinstance(table, dict)   # a CSV's or Parquet's columns share their rows
    cols = {role: col for role, col in mapping.items() if col in names}
    t_col = cols.get("t")
    own = dict(given)
    for role, col in cols.items():
        if role == "t" or role in own or not structs:
            continue
        tk = time_of(table, col)
        same = t_col is not None and tk is not None and (
            tk == t_col or np.array_equal(np.asarray(table[tk]), np.asarray(table[t_col])))
        if tk is not None and not same:
            own[role] = tk
    # with no time column mapped, signals that all bring their own instants take their union
    every = all(r in own for r in cols if r != "t")
    if not own or (t_col is None and (explicit or not every)):
        _same_lengths(table, cols, name)
        return table, mapping, {}
    keys = dict(own)
    if t_col is not None:
        for role in cols:
            if role not in own and role != "t":
                keys[role] = t_col
    stamps, epoch = _seconds({role: _instants(table, tk, name) for role, tk in keys.items()}, keys, name)
    values = {}
    for role, ts in stamps.items():
        v = _floats(table, cols[role], name)
        if len(ts) != len(v):
            raise InputError(f"{name}: {cols[role]!r} has {len(v)} values but its "
                             f"time {keys[role]!r} has {len(ts)}; give it a time of its own (a struct "
                             "with a 'time' field, as Simulink's To Workspace writes)")
        # a side-by-side export's shorter columns end in empty cells: not readings
        keep = np.isfinite(ts) & (np.isfinite(v) if role in own else True)
        ts, v = ts[keep], v[keep]
        bad = np.flatnonzero(np.diff(ts) < 0)
        if len(bad):
            raise InputError(f"{name}: time {keys[role]!r} decreases at sample {bad[0] + 2}")
        stamps[role], values[role] = ts, v
    union = np.unique(np.concatenate(list(stamps.values())))
    # the time column says where its rows came from: "tau.time + q.time"
    t_name = " + ".join(dict.fromkeys(([t_col] if t_col else []) + list(own.values())))
    # clock times stay clock times: the reader takes them as seconds, with no time unit
    joined = {t_name: union if epoch is None else epoch + np.round(union * 1e9).astype("timedelta64[ns]")}
    for role, ts in stamps.items():
        col = np.full(len(union), np.nan)
        # a repeated instant keeps its first reading (np.unique's first index)
        ts_u, first = np.unique(ts, return_index=True)
        col[np.searchsorted(union, ts_u)] = values[role][first]
        joined[cols[role]] = col
    return joined, {**mapping, "t": t_name}, own


def _same_lengths(table: dict, cols: dict, name: str) -> None:
    lengths = {col: len(table[col]) for col in cols.values()}
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"{c!r} {n}" for c, n in lengths.items())
        raise InputError(f"{name}: the mapped variables differ in length ({shown}); give each "
                         "signal its own time (a struct with a 'time' field, as Simulink's To "
                         "Workspace writes) or map variables of one length")


def unnamed_time(table, names: list, mapping: dict, name: str) -> None:
    """A side-by-side export mapped without ``@TIME``: a value column filled on a leading run
    of rows other than the time column's, beside an unmapped column filled on exactly those
    rows that increases, is that signal's own time.  Read on the time column's rows it was
    placed at the wrong instants and the record refused as never reaching sliding, with advice
    to excite harder: say what the file holds instead."""
    cols = {role: col for role, col in mapping.items() if col in names}
    if "t" not in cols:
        return
    floats = {}

    def get(col):
        if col not in floats:
            try:
                v = _instants(table, col, name)
            except InputError:      # labels: not a time
                v = None
            if v is not None and v.dtype.kind == "M":   # clock times: seconds from one origin
                sec = (v - _ORIGIN).astype(np.int64) * 1e-9
                sec[np.isnat(v)] = np.nan
                v = sec
            floats[col] = v
        return floats[col]

    base = get(cols["t"])
    if base is None:
        return
    run_t = _leading_run(base)
    for role, col in cols.items():
        v = get(col) if role != "t" else None
        n = _leading_run(v) if v is not None else None
        if n is None or n < 3 or n == run_t:
            continue
        for other in names:
            c = get(other) if other not in cols.values() else None
            if c is None or _leading_run(c) != n or not np.all(np.diff(c[:n]) > 0):
                continue
            step = np.median(np.diff(base[:run_t or len(base)]))
            if run_t is not None and run_t >= n and np.all(np.abs(c[:n] - base[:n]) <= 0.01 * step):
                continue        # the time column's own instants: nothing to say
            rows = f"{run_t} rows" if run_t is not None else "other rows"
            raise InputError(
                f"{name}: {col!r} fills its first {n} rows and the time {cols['t']!r} {rows}; "
                f"{other!r} rises on exactly those {n} rows, as a side-by-side export gives "
                f"{col!r} a time of its own: map it as {role}={col}@{other}")


_ORIGIN = np.datetime64("2000-01-01", "ns")    # a fixed origin for comparing clock times


def _leading_run(values: np.ndarray) -> int | None:
    """How many leading cells hold numbers when every later one is empty; None otherwise."""
    ok = np.isfinite(values)
    k = int(ok.sum())
    return k if ok[:k].all() else None
