"""Records as users have them: CSV with any delimiter, Parquet, MATLAB .mat (v5), any of them
compressed or zipped, text in UTF-8, UTF-16 or Windows-1252 (``bench.containers``).

``read_record`` takes a file (path or bytes) and an optional column mapping
(``t=NAME,tau=NAME,q=NAME[,qd=NAME]``; a name may also be a 1-based column number), takes
metadata from ``#`` lines (CSV), scalar variables (.mat), options or the header's own units,
and then, in this order (``_finish``): drops rows with lost cells (``bench.rows``), unwraps a
wrapping time counter (``bench.counters``), converts to SI (``bench.units``), unwraps a
position that wraps at whole turns (``bench.turns``), cuts the window,
mends position glitches (``bench.glitches``), puts uneven timestamps on a uniform grid
(``bench.resample``) and validates.  What was done is kept in ``Record.reading`` for the
report.  Every problem is an ``InputError`` of one line.
"""
from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from bench import column_names, friction_map, header_units, joint_columns, own_times, position_from_velocity, split_stamps
from bench.coarse_time import spread
from bench.containers import strip_suffix, unwrap
from bench.counters import unwrap_counter
from bench.errors import InputError
from bench.glitches import mend_glitches
from bench.joined_streams import VALUES, onto_kept_rows, sparse_columns
from bench.records import ENCODER_SIDES, REQUIRED, Record, _parse_meta_value, column_index, validate
from bench.resample import regularise
from bench.rows import cut, drop_empty_rows, parse_window
from bench.sample_rate import sample_rate_of
from bench.slow_stream import filled_forward
from bench.text_table import read_text
from bench.turns import unwrap_turns
from bench.units import to_si, velocity_factor, whole_number_position
from bench.validate import record_magnitudes

ROLES = ("t", "tau", "q", "qd")
_ITEMS = re.compile(r'(?:[^,"]|"[^"]*")+')
META_UNITS = ("joint_type", "time_unit", "position_unit", "torque_unit", "torque_hold")


def parse_columns(spec: str | None) -> dict | None:
    """``t=time,tau=torque,q=pos`` -> {'t': 'time', ...}; None for no mapping.  A name with a
    comma in it is quoted: ``t="time, s"`` (or the whole item, ``"t=time, s"``)."""
    if spec is None or not spec.strip():
        return None
    if spec.count('"') % 2:
        raise InputError(f"--columns: a quote is not closed in {spec.strip()!r}")
    out = {}
    for item in _ITEMS.findall(spec):    # a name quoted, "time, s", may hold a comma
        role, eq, col = item.partition("=")
        role, col = role.strip().strip('"'), col.strip().strip('"')
        if not eq or not col:
            raise InputError(f"--columns: {item.strip()!r} is not ROLE=NAME (roles: {', '.join(ROLES)})")
        if role not in ROLES:
            raise InputError(f"--columns: unknown role {role!r} (roles: {', '.join(ROLES)})")
        if role in out:
            raise InputError(f"--columns: {role} is mapped twice")
        out[role] = col
    # t may be left out: a scope's export without times, read at its sample rate
    missing = [r for r in REQUIRED if r not in out and r != "t" and not (r == "q" and "qd" in out)]
    if missing:
        raise InputError(f"--columns must map t, tau and q (missing: {', '.join(missing)}; t may be "
                         f"left out for a file without times given its --sample-rate, q for one "
                         f"with a velocity qd)")
    return out


def read_record(source, name: str | None = None, columns: str | dict | None = None,
                joint_type: str | None = None, position_unit: str | None = None,
                torque_unit: str | None = None, inertia: float | None = None,
                torque_hold: str | None = None, time_unit: str | None = None,
                window: str | None = None, sample_rate: float | None = None,
                joint: str | None = None, encoder: str | None = None) -> Record | friction_map.FrictionMap:
    """Read, map, convert, resample and validate a record (a table of speed and friction with
    no time and no position: a ``FrictionMap``, ``bench.friction_map``).  ``source``: a path, bytes or a
    text stream.  ``window``: "START:END", seconds from the first sample (either may be
    left out), the part of a long log to analyse.  ``sample_rate`` [Hz]: the rows' rate, for
    a file without a time column (``bench.sample_rate``).  ``joint``: the label of the joint
    to read from a log of several (``bench.joint_columns``)."""
    span = parse_window(window)
    raw, name = _load(source, name)
    raw, name, wrapped = unwrap(raw, name)      # gzip, xz, zstd, a zip of one (bench.containers)
    if encoder is not None and encoder not in ENCODER_SIDES:   # a Parquet or .mat log has no '#' line to say it
        raise InputError(f"--encoder must be motor or load (the side of a geared joint's gear it reads), got {encoder!r}")
    opts = dict(joint_type=joint_type, position_unit=position_unit, torque_unit=torque_unit,
                inertia=inertia, torque_hold=torque_hold, time_unit=time_unit, encoder=encoder)
    fmt = _format(raw, name)
    mapping = parse_columns(columns) if isinstance(columns, str) or columns is None else dict(columns)
    if joint is not None and mapping is not None:
        raise InputError("--joint picks a joint's columns by their names; with --columns give the "
                         "columns' full names instead, not both")
    units_row: dict | None = None
    if fmt == "parquet":
        table, meta = _parquet(raw, name)
        trace = _trace_record(table, mapping, name, joint)
        if trace is not None:
            return _finish(trace, name, fmt, opts, span, wrapped)
    elif fmt == "mat":
        table, meta = _mat(raw, name)
        table.update({k: table[v] for k, v in own_times.signal_names(table).items()})
    else:
        table, meta, fmt, units_row, encoding, skipped = read_text(raw, name)
        if encoding != "utf-8":
            wrapped["encoding"] = encoding
        wrapped.update(skipped)     # lines before the header and after the rows (bench.text_table)
    text_row = units_row == {}          # a row of descriptions under the header, skipped
    units_row = units_row or {}
    explicit = mapping is not None
    names = _names(table)
    if explicit:
        mapping = {r: column_names.by_bare_name(c, names) for r, c in mapping.items()}
    by_name, of_joint = {}, {}
    if mapping is None:         # roles by their own names or as loggers name them (bench.column_names)
        try:
            mapping, by_name, of_joint = column_names.default_mapping(names, ROLES, REQUIRED, joint)
        except InputError as bad_joint:      # a --joint no column names: said with the file's name
            raise InputError(f"{name}: {bad_joint}") from None
        by_name = {**of_joint, **by_name}      # a joint's columns were found by their names too
        joint_columns.refuse_unfound(mapping, names, joint, name)    # which joint, or what it lacks
    if not explicit and mapping.get("t") not in names and (stamp := split_stamps.stamp_column(names)):
        mapping["t"] = stamp     # a ROS stamp in sec + nanosec
    mapping, given = own_times.given_times(mapping, names)
    if explicit and not {"t", "q"} & set(mapping):    # a map's columns: a name not there is told as such
        for role in ("qd", "tau"):
            if role in mapping:
                _column_key(table, mapping[role], role, name, explicit=True)
    # a mapping that left out the time of a file that has one is refused below as before
    if friction_map.is_map(mapping, names, meta, sample_rate is not None, bool(given)) and not (
            explicit and column_index(column_names.default_mapping(names, ROLES, REQUIRED)[0].get("t"), names) is not None):
        return _map(table, mapping, meta, dict(opts, window=window), units_row, name, fmt, explicit, wrapped)
    if not explicit:
        friction_map.refuse_torqueless(mapping, names, meta, sample_rate is not None, bool(given), name)
    rate = sample_rate_of(sample_rate, meta, mapping, names, name, plain=fmt != "mat" and not given)
    if rate is not None:
        mapping.pop("t", None)
    elif "t" not in mapping:
        raise InputError(f"{name}: no time column mapped; map one (--columns t=NAME) or give the rows' "
                         f"sample rate (--sample-rate HZ, or a '# sample_rate: HZ' line)")
    from_qd = fmt != "mat" and not given and position_from_velocity.velocity_only(mapping, names)
    if from_qd:                  # a speed and no position (bench.position_from_velocity)
        mapping.pop("q", None)
    own = {}
    if fmt == "mat" or given:   # signals with times of their own (bench.own_times)
        table, mapping, own = own_times.join(table, names, mapping, name, explicit, given)
    else:
        own_times.unnamed_time(table, names, mapping, name)
    data, stated = {}, {}
    clock, ticks, velocity_unit = False, None, None
    for role, col in mapping.items():
        key = _column_key(table, col, role, name, explicit=explicit)
        unit = units_row.get(key) or header_units.unit_in_name(str(key)) or column_names.suffix_unit(key, role)
        if unit and role in header_units.KEYS:
            stated[role] = unit
        elif role == "qd" and (speed := velocity_factor(unit)):
            velocity_unit = speed          # converted by its own unit (bench.units.to_si)
        values = _column(table, key)
        data[role] = _numeric(values, key, name, time=role == "t")
        fraction = split_stamps.fraction_of(key, names) if role == "t" and fmt != "mat" else None
        stamped = fraction and split_stamps.joined(data[role], _numeric(_column(table, fraction), fraction, name))
        if stamped is not None:     # seconds and their nanoseconds in two columns (bench.split_stamps)
            clock, data[role], mapping = True, stamped, dict(mapping, t=f"{key} + {fraction}")
        elif role == "t" and isinstance(data[role], _ClockSeconds):
            clock, data[role] = True, np.asarray(data[role])
        elif role == "t":   # integer ticks (ns since the epoch) lose digits as floats: keep them
            ints = values.to_numpy() if hasattr(values, "to_numpy") else np.asarray(values)
            ticks = ints.astype(np.int64) if ints.dtype.kind in "iu" else None
    if rate is not None:       # seconds, whatever a time unit says
        clock, data["t"] = True, np.arange(len(data["tau"])) / rate
    if from_qd:                # integrated once the rows with lost cells are out (_finish)
        data["q"] = np.array(data["qd"], dtype=float)
    rec = Record(t=data["t"], tau=data["tau"], q=data["q"], qd=data.get("qd"), meta=meta)
    rec.reading = {"format": fmt, "columns": {r: str(c) for r, c in mapping.items()}}
    if from_qd:
        rec.reading["columns"]["q"] = f"integral of {mapping['qd']}"
        rec.reading["position_from"] = "qd"
    if rate is not None:
        rec.reading["columns"]["t"] = f"row number / {rate:g} Hz"
        rec.reading["sample_rate"] = rate
    if ticks is not None:
        rec.reading["raw_ticks"] = ticks
    if clock:
        rec.reading["clock_time"] = True
    if stated:
        rec.reading["stated_units"] = stated
    if text_row:
        rec.reading["text_row_skipped"] = True
    if velocity_unit:
        rec.reading["velocity_unit"] = velocity_unit
    if by_name := {r: c for r, c in by_name.items() if mapping.get(r) == c}:
        rec.reading["columns_by_name"] = by_name
    if joint is not None:
        rec.reading["joint"] = {"label": str(joint).strip(), "columns": of_joint}
    if own:
        rec.reading["own_times"] = own
    return _finish(rec, name, fmt, opts, span, wrapped)


def _map(table, mapping, meta, opts, units_row, name, fmt, explicit, wrapped) -> "friction_map.FrictionMap":
    """A velocity and a torque and nothing else: a friction-velocity map (bench.friction_map)."""
    keys = {r: _column_key(table, mapping[r], r, name, explicit=explicit) for r in ("qd", "tau")}
    values = {r: _numeric(_column(table, k), k, name) for r, k in keys.items()}
    units = {r: units_row.get(k) or header_units.unit_in_name(str(k)) or column_names.suffix_unit(k, r)
             for r, k in keys.items()}
    meta_units = {k: meta[k] for k in ("joint_type", "torque_unit") if k in meta}
    return friction_map.build(values["qd"], values["tau"], units, keys, meta,
                              {**meta_units, **{k: v for k, v in opts.items() if v is not None}},
                              name, fmt, wrapped)


def _finish(rec: Record, name, fmt, opts: dict, span=None, wrapped: dict | None = None) -> Record:
    for key, value in opts.items():
        if value is not None:
            rec.meta[key] = value
    rec.reading.update(wrapped or {})
    rec.reading.setdefault("format", fmt)
    header_units.apply(rec, name)
    joined = sparse_columns(rec)       # streams on rows of their own (bench.joined_streams)
    if joined:
        rec.reading["joined_streams"] = joined
    drop_empty_rows(rec, name, spare=VALUES if joined else ())
    counter = unwrap_counter(rec)       # in the file's own unit, before it is converted
    if counter:
        rec.reading["time_counter"] = {"bits": counter[0], "wraps": counter[1]}
    if counts := whole_number_position(rec):    # encoder counts with no unit given
        rec.reading["whole_number_position"] = counts
    to_si(rec, name)
    if rec.reading.get("position_from") == "qd":
        position_from_velocity.integrate(rec)
    wraps = unwrap_turns(rec)          # in file order, before anything differentiates q
    if wraps:
        rec.reading["turns_unwrapped"] = wraps
    if span is not None:
        cut(rec, span, name)
    rec = spread(rec)                  # a clock coarser than the samples (bench.coarse_time)
    rec, instants = onto_kept_rows(rec, name)    # each reading at its own time
    # the columns' magnitudes before any interpolation (1e300 overflows one); the inertia is
    # validate()'s, below
    record_magnitudes(rec, None, name, with_inertia=False)
    rec = filled_forward(rec, instants=instants)   # a slower stream filled forward (bench.slow_stream)
    rec.reading["glitches"] = mend_glitches(rec)   # an encoder's bad samples, once whole turns are out
    # for --residuals at the record's own times (converted back to the file's unit there)
    rec.reading["raw_t"] = np.array(rec.t, dtype=float)
    rec = regularise(rec, name)
    validate(rec, name)
    return rec


# --- loading ---------------------------------------------------------------------------------
def _load(source, name):
    if isinstance(source, (str, Path)):
        name = name or str(source)
        try:
            return Path(source).read_bytes(), name
        except FileNotFoundError:
            raise InputError(f"{name}: no such file") from None
        except (IsADirectoryError, PermissionError) as e:
            raise InputError(f"{name}: cannot read ({e.__class__.__name__})") from None
    if isinstance(source, (bytes, bytearray)):
        return bytes(source), name or "record"
    text = source.read()
    return (text.encode() if isinstance(text, str) else text), name or "record"


def _format(raw: bytes, name: str) -> str:
    if raw[:4] == b"PAR1":
        return "parquet"
    if raw[:10] == b"MATLAB 5.0" or raw[:19] == b"MATLAB 7.3 MAT-file":
        return "mat"
    base = strip_suffix(name).lower()     # a compressed file's name tells its content's format
    if base.endswith((".parquet", ".pq")):
        raise InputError(f"{name}: not a Parquet file (no PAR1 magic)")
    if base.endswith(".mat"):
        return "mat"   # v4 files have no magic; scipy says what it can read
    return "csv"


def _parquet(raw: bytes, name: str):
    import pyarrow as pa
    import pyarrow.parquet as pq
    try:
        table = pq.read_table(io.BytesIO(raw))
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{name}: unreadable Parquet ({str(e).splitlines()[0][:120]})") from None
    meta = {}
    for k, v in (table.schema.metadata or {}).items():   # key/value metadata, if any was written
        key = k.decode(errors="replace")
        if key == "inertia" or key in META_UNITS:
            meta[key] = _parse_meta_value(v.decode(errors="replace"))
    return table, meta


def _trace_record(table, mapping: dict | None, name: str, joint: str | None = None) -> Record | None:
    """The project's own run traces (bench.traces): columns t, tau_<id>, g_<id>, q_<id>,
    v_<id>, segment.  Without a mapping (one joint) or with tau=tau_<id>, q=q_<id>, read
    as the trace exporter does: the host's gravity model g_<id> is taken off the torque."""
    from bench.traces import trace_to_record
    names = table.column_names
    if "segment" not in names or "t" not in names:
        return None
    joints = [n[2:] for n in names if n.startswith("q_")]
    if mapping is None and joint is not None:
        if str(joint).strip() not in joints:
            raise InputError(f"{name}: --joint {joint}: the run trace holds joints {', '.join(joints)}")
        jid = str(joint).strip()
    elif mapping is None:
        if len(joints) != 1:
            raise InputError(f"{name}: a run trace of joints {', '.join(joints)}: choose one with "
                             f"--joint <joint>")
        jid = joints[0]
    else:
        jid = mapping["q"][2:] if mapping["q"].startswith("q_") else None
        if jid not in joints or mapping["tau"] != f"tau_{jid}" or mapping["t"] != "t":
            return None   # an ordinary mapping: the columns as they are
    rec = trace_to_record(table, jid, meta={})
    if mapping and "qd" not in mapping:
        rec.qd = None
    rec.reading = {"format": "parquet (run trace)", "columns": {
        "t": "t", "tau": f"tau_{jid}" + (f" - g_{jid}" if f"g_{jid}" in names else ""),
        "q": f"q_{jid}", **({"qd": f"v_{jid}"} if rec.qd is not None else {})}}
    return rec


def _mat(raw: bytes, name: str):
    from scipy.io import loadmat
    if raw[:19] == b"MATLAB 7.3 MAT-file":
        raise InputError(f"{name}: MATLAB v7.3 (HDF5) file; save it with -v7 (or as CSV)")
    try:
        mat = loadmat(io.BytesIO(raw), squeeze_me=True, struct_as_record=False)
    except Exception as e:  # noqa: BLE001 - scipy's reader fails many ways on a broken file
        detail = (str(e).splitlines() or [e.__class__.__name__])[0][:120]
        raise InputError(f"{name}: unreadable MATLAB file ({detail})") from None
    table: dict = {}
    meta: dict = {}

    def add(prefix, value):
        if hasattr(value, "_fieldnames"):            # a struct: its fields, as prefix.field
            for f in value._fieldnames:
                add(f"{prefix}.{f}" if prefix else f, getattr(value, f))
            return
        arr = np.asarray(value)
        key = prefix.rsplit(".", 1)[-1]
        if arr.dtype.kind in "US" and key in META_UNITS:
            meta[key] = str(arr)
        elif arr.ndim == 0 and arr.dtype.kind in "fiu" and key == "inertia":
            meta[key] = float(arr)
        elif arr.ndim == 1 and arr.dtype.kind in "fiu":
            table[prefix] = arr
        elif arr.ndim == 2 and arr.dtype.kind in "fiu":   # a matrix: its columns, name(1), name(2) ...
            for j in range(arr.shape[1]):
                table[f"{prefix}({j + 1})"] = arr[:, j]

    for k, v in mat.items():
        if not k.startswith("__"):
            add(k, v)
    structs = [k for k, v in mat.items() if hasattr(v, "_fieldnames")]
    if len(structs) == 1:   # one struct: its fields also under their own names
        for k in list(table):
            short = k.split(".", 1)[1] if k.startswith(structs[0] + ".") else None
            if short and short not in table:
                table[short] = table[k]
    return table, meta


# --- columns ---------------------------------------------------------------------------------
def _names(table) -> list[str]:
    return list(table.column_names) if hasattr(table, "column_names") else list(table)


def _column_key(table, col: str, role: str, name: str, explicit: bool):
    names = _names(table)
    at = column_index(col, names)
    if at is not None:
        return names[at]
    shown = ", ".join(names[:40]) + (" ..." if len(names) > 40 else "")
    if explicit:
        raise InputError(f"{name}: no column {col!r} (for {role}); the file's columns: {shown}")
    rate = " (a file without times: --sample-rate HZ)" if role == "t" else ""
    if all(str(n).isdigit() for n in names):       # numbered by the reader: no header line
        raise InputError(f"{name}: the file has no header line ({len(names)} columns); map its columns "
                         f"by number, --columns t=1,tau=2,q=3[,qd=4]{rate}")
    raise InputError(f"{name}: missing column '{role}' (header is: {shown}); map yours with "
                     f"--columns t=NAME,tau=NAME,q=NAME{rate}")


def _column(table, key):
    return table.column(key) if hasattr(table, "column_names") else table[key]


def _numeric(values, col: str, name: str, time: bool = False) -> np.ndarray:
    if time:   # numbers, or clock times as many loggers write them: seconds from the first
        try:
            arr = own_times.clock_or_numbers(values)
        except (TypeError, ValueError):
            arr = None
        if arr is not None and arr.dtype.kind == "M":
            ts = arr.astype(np.int64)
            return _ClockSeconds((ts - ts[0]) * 1e-9)
        if arr is not None:
            return arr
    if hasattr(values, "to_numpy"):   # a pyarrow column
        import pyarrow as pa
        try:
            values = values.to_numpy(zero_copy_only=False)
        except pa.ArrowException:
            raise InputError(f"{name}: column '{col}' is not numeric") from None
    arr = np.asarray(values)
    if arr.dtype.kind in "fiu":
        return arr.astype(float)
    try:
        return np.array(arr, dtype=float)
    except (ValueError, TypeError):
        pass
    for r, cell in enumerate(arr, start=1):
        try:
            float(cell)
        except (ValueError, TypeError):
            raise InputError(f"{name}: column '{col}' is not numeric at data row {r}: {cell!r}") from None
    raise InputError(f"{name}: column '{col}' is not numeric")


class _ClockSeconds(np.ndarray):
    """Seconds read from clock times: a time unit does not apply to them."""

    def __new__(cls, a):
        return np.asarray(a, dtype=float).view(cls)
