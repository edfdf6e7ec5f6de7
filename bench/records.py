"""The record format: a CSV of one joint's excitation.

    # inertia: 2.5
    # joint_type: revolute
    # position_unit: rad
    # torque_unit: N*m
    t,tau,q[,qd]
    0.000,0.01,0.0
    ...

``t`` [s]; ``tau`` the applied torque [N·m or N], gravity already compensated; ``q`` [rad or m];
optional ``qd``.  Comment lines carry ``key: value`` metadata.  Reading validates everything
the identification relies on and raises ``InputError`` with one line naming the problem.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.errors import InputError

REQUIRED = ("t", "tau", "q")
JOINT_TYPES = ("prismatic", "revolute")
ENCODER_SIDES = ("motor", "load")    # which side of a geared joint's gear the encoder reads


@dataclass
class Record:
    t: np.ndarray
    tau: np.ndarray
    q: np.ndarray
    qd: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    # set by resampling (bench.resample): the record is the concatenation of evenly sampled
    # segments cut at gaps, ``segments`` their start indices, ``step`` their common period
    segments: list[int] | None = None
    step: float | None = None
    reading: dict = field(default_factory=dict)   # what reading did: format, units, resampling

    @property
    def dt(self) -> float:
        if self.step is not None:
            return float(self.step)
        return float((self.t[-1] - self.t[0]) / (len(self.t) - 1))

    def segment_bounds(self) -> list[tuple[int, int]]:
        """[(start, stop)] of the evenly sampled segments (one, unless split at gaps)."""
        starts = list(self.segments or [0])
        return list(zip(starts, starts[1:] + [len(self.t)]))

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def inertia(self) -> float | None:
        m = self.meta.get("inertia")
        # 'estimate': none declared (bench.inertia_estimate reads it off the record)
        return None if m is None or asks_estimate(m) else float(m)

    @property
    def load_encoder(self) -> bool:
        """The encoder reads the load beyond a gear (``encoder: load``), not the motor."""
        return str(self.meta.get("encoder", "motor")).strip().lower() == "load"

    @property
    def joint_type(self) -> str:
        return str(self.meta.get("joint_type", "revolute"))

    def to_csv(self, path: str | Path | None = None) -> str:
        buf = io.StringIO()
        for k, v in self.meta.items():
            buf.write(f"# {k}: {v}\n")
        cols = ["t", "tau", "q"] + (["qd"] if self.qd is not None else [])
        buf.write(",".join(cols) + "\n")
        data = np.column_stack([self.t, self.tau, self.q] + ([self.qd] if self.qd is not None else []))
        np.savetxt(buf, data, delimiter=",", fmt=["%.6f", "%.9g", "%.10g"] + (["%.9g"] if self.qd is not None else []))
        text = buf.getvalue()
        if path is not None:
            Path(path).write_text(text)
        return text


def column_index(col, names: list) -> int | None:
    """Where a mapped column is among the file's ``names``: by its name, or by its 1-based
    number (``t=1``); None when it is not there."""
    if col is None:
        return None
    if col in names:
        return names.index(col)
    col = str(col)
    return int(col) - 1 if col.isdigit() and 1 <= int(col) <= len(names) else None


def asks_estimate(inertia) -> bool:
    """Is this inertia setting the word asking for it to be read off the record (``estimate``)?"""
    return isinstance(inertia, str) and inertia.strip().lower() == "estimate"


def inertia_setting(text: str | None) -> float | str | None:
    """A user's inertia option (CLI ``--inertia``, REST ``?inertia=``): a number >= 0 (0: the torque
    column is the friction), 'estimate', or None (the record's metadata)."""
    if text is None or asks_estimate(text):
        return None if text is None else "estimate"
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"inertia must be a number >= 0 (0: the torque column is the friction) or 'estimate', got {text!r}") from None
    if not (value >= 0 and math.isfinite(value)):
        raise InputError(f"inertia must be >= 0 (0: the torque column is the friction), got {value:g}")
    return value


def _parse_meta_value(v: str):
    try:
        x = float(v)
    except ValueError:
        return v
    return x if math.isfinite(x) else v


def split_metadata(text: str) -> tuple[dict, list[str]]:
    """``# key: value`` lines -> metadata; the other non-empty lines, stripped."""
    meta: dict = {}
    rows: list[str] = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            body = s[1:].strip()
            if ":" in body:
                k, v = body.split(":", 1)
                meta[k.strip()] = _parse_meta_value(v.strip())
            continue
        rows.append(s)
    return meta, rows


def read_csv(source: str | Path | io.TextIOBase, name: str | None = None) -> Record:
    """Read and validate a record.  ``source`` is a path or an open text stream."""
    if isinstance(source, (str, Path)):
        name = name or str(source)
        try:
            text = Path(source).read_text()
        except FileNotFoundError:
            raise InputError(f"{name}: no such file") from None
        except (IsADirectoryError, PermissionError, UnicodeDecodeError) as e:
            raise InputError(f"{name}: cannot read ({e.__class__.__name__})") from None
    else:
        text = source.read()
        name = name or "record"
    meta, rows = split_metadata(text)
    if not rows:
        raise InputError(f"{name}: no header row and no data")
    header = [h.strip() for h in rows[0].split(",")]
    for col in REQUIRED:
        if col not in header:
            raise InputError(f"{name}: missing column '{col}' (header is: {','.join(header)})")
    if len(set(header)) != len(header):
        raise InputError(f"{name}: duplicate column names in header")
    idx = {h: i for i, h in enumerate(header)}
    wanted = [c for c in ("t", "tau", "q", "qd") if c in idx]
    data = {c: np.empty(len(rows) - 1) for c in wanted}
    for r, line in enumerate(rows[1:], start=2):
        cells = line.split(",")
        if len(cells) != len(header):
            raise InputError(f"{name}: data row {r - 1} has {len(cells)} fields, header has {len(header)}")
        for c in wanted:
            cell = cells[idx[c]].strip()
            try:
                x = float(cell)
            except ValueError:
                raise InputError(f"{name}: column '{c}' is not numeric at data row {r - 1}: {cell!r}") from None
            if not math.isfinite(x):
                raise InputError(f"{name}: column '{c}' has a non-finite value ({cell}) at data row {r - 1}")
            data[c][r - 2] = x
    rec = Record(t=data["t"], tau=data["tau"], q=data["q"], qd=data.get("qd"), meta=meta)
    validate(rec, name)
    return rec


def validate(rec: Record, name: str = "record") -> None:
    n = len(rec.t)
    if n < 10:
        raise InputError(f"{name}: only {n} samples; a record needs at least two excitation cycles")
    for col in ("t", "tau", "q") + (("qd",) if rec.qd is not None else ()):
        arr = getattr(rec, col)
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name}: column '{col}' contains NaN or infinite values")
    d = np.diff(rec.t)
    if rec.segments:  # steps across a gap between segments are not samples
        d = np.delete(d, np.asarray(rec.segments[1:], dtype=int) - 1)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise InputError(f"{name}: time is not increasing at data row {i + 2} (t={rec.t[i + 1]:g})")
    dt = float(np.median(d))
    if np.max(np.abs(d - dt)) > 0.01 * dt + 1e-9:
        i = int(np.argmax(np.abs(d - dt)))
        raise InputError(f"{name}: unevenly sampled: step {d[i]:.6g} s at data row {i + 2}, "
                         f"median step {dt:.6g} s (resample to a fixed rate first)")
    jt = rec.meta.get("joint_type")
    if jt is not None and jt not in JOINT_TYPES:
        raise InputError(f"{name}: joint_type must be prismatic or revolute, not {jt!r}")
    enc = rec.meta.get("encoder")
    if enc is not None and str(enc).strip().lower() not in ENCODER_SIDES:
        raise InputError(f"{name}: encoder must be motor or load (the side of a geared joint's gear it reads), not {enc!r}")
    m = rec.meta.get("inertia")
    if m is not None and not asks_estimate(m):
        try:
            mv = float(m)
        except (TypeError, ValueError):
            raise InputError(f"{name}: metadata inertia is not a number (nor 'estimate'): {m!r}") from None
        # 0 declares a friction-torque record: tau already is the friction (torque-sensing arms)
        if not (mv >= 0 and math.isfinite(mv)):
            raise InputError(f"{name}: metadata inertia must be positive (or 0 for a friction-torque record), got {m}")
    if np.ptp(rec.q) == 0:
        raise InputError(f"{name}: position is constant: the joint never moved")
