"""Trace files: the sampled signals of one run, written while the run is going.

Why Parquet: columnar and typed (float64 signals stay exact, no CSV parsing cost), compressed,
readable from pandas/polars/DuckDB/Arrow in any language, and written in row groups so a
writer can flush incrementally.  Its weakness is the footer: a file whose writer was killed
has no footer and cannot be read.  So a live trace is a *directory of chunks*: every flush
(at least once a second) writes one small, complete Parquet file with ``ParquetWriter`` under
a temporary name and renames it into place (atomic on POSIX).  A SIGKILL loses at most the
rows buffered since the last flush; every chunk on disk is whole and readable.  ``close``
compacts the chunks into one ``trace.parquet`` (one row group per chunk) and removes them.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from bench.errors import InputError
from bench.records import Record

TRACE_FILE = "trace.parquet"
CHUNK_GLOB = "chunk-*.parquet"


class TraceWriter:
    """Append rows of float columns (plus one string column ``segment``) to a run directory.

    ``append`` is cheap (a row into a preallocated buffer); the buffer is flushed to a chunk
    file when it is full or ``flush_every`` seconds of wall time have passed."""

    def __init__(self, directory: str | Path, columns: list[str], flush_every: float = 1.0,
                 buffer_rows: int = 4096, meta: dict | None = None):
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.columns = list(columns)
        self.flush_every = float(flush_every)
        self.buf = np.empty((buffer_rows, len(self.columns)))
        self.segments: list[str] = []
        self.n = 0
        self.meta = {k: str(v) for k, v in (meta or {}).items()}
        existing = sorted(self.dir.glob(CHUNK_GLOB))
        self.seq = int(existing[-1].stem.split("-")[1]) + 1 if existing else 0  # resume appends
        self.last_flush = time.monotonic()
        self.schema = pa.schema([(c, pa.float64()) for c in self.columns] + [("segment", pa.string())],
                                metadata={k.encode(): v.encode() for k, v in self.meta.items()})
        self.closed = False

    def append(self, row, segment: str = "") -> None:
        self.buf[self.n] = row
        self.segments.append(segment)
        self.n += 1
        if self.n == len(self.buf) or time.monotonic() - self.last_flush >= self.flush_every:
            self.flush()

    def flush(self) -> None:
        self.last_flush = time.monotonic()
        if self.n == 0:
            return
        arrays = [pa.array(self.buf[:self.n, i]) for i in range(len(self.columns))]
        arrays.append(pa.array(self.segments, type=pa.string()))
        table = pa.Table.from_arrays(arrays, schema=self.schema)
        final = self.dir / f"chunk-{self.seq:06d}.parquet"
        tmp = final.with_suffix(".tmp")
        with pq.ParquetWriter(tmp, self.schema) as w:
            w.write_table(table)
        os.replace(tmp, final)
        self.seq += 1
        self.n = 0
        self.segments = []

    def close(self) -> Path:
        """Flush, then compact the chunks into one trace file."""
        if not self.closed:
            self.flush()
            compact(self.dir)
            self.closed = True
        return self.dir / TRACE_FILE


def compact(directory: str | Path) -> Path | None:
    d = Path(directory)
    chunks = sorted(d.glob(CHUNK_GLOB))
    target = d / TRACE_FILE
    if not chunks:
        return target if target.exists() else None
    tables = ([pq.read_table(target)] if target.exists() else []) + [pq.read_table(c) for c in chunks]
    tmp = d / "trace.tmp"
    with pq.ParquetWriter(tmp, tables[0].schema) as w:
        for t in tables:
            w.write_table(t.cast(tables[0].schema))
    os.replace(tmp, target)
    for c in chunks:
        c.unlink()
    return target


def read_trace(directory: str | Path) -> pa.Table:
    """The whole trace of a run, finished or not (compacted file first, then chunks)."""
    d = Path(directory)
    parts = []
    if (d / TRACE_FILE).exists():
        parts.append(pq.read_table(d / TRACE_FILE))
    parts += [pq.read_table(c) for c in sorted(d.glob(CHUNK_GLOB))]
    if not parts:
        raise InputError(f"{d}: no trace recorded")
    return pa.concat_tables([p.cast(parts[0].schema) for p in parts])


def trace_to_record(table: pa.Table, joint_id: str, meta: dict | None = None,
                    segment: str | None = None) -> Record:
    """One joint's columns as a core ``Record`` (t, tau without host gravity, q, qd).

    The trace stores ``tau_<id>`` as the drive-reported torque and ``g_<id>`` as the host's
    gravity model at that sample, so tau = tau - g, as the record format requires."""
    names = table.column_names
    for c in (f"q_{joint_id}", f"tau_{joint_id}"):
        if c not in names:
            raise InputError(f"trace has no column {c!r} (joints: "
                             f"{', '.join(n[2:] for n in names if n.startswith('q_'))})")
    if segment is not None:
        mask = np.array(table.column("segment").to_pylist()) == segment
        if not mask.any():
            raise InputError(f"trace has no segment {segment!r}")
        table = table.filter(pa.array(mask))
    col = lambda c: table.column(c).to_numpy()  # noqa: E731
    g = col(f"g_{joint_id}") if f"g_{joint_id}" in names else 0.0
    qd = col(f"v_{joint_id}") if f"v_{joint_id}" in names else None
    return Record(t=col("t"), tau=col(f"tau_{joint_id}") - g, q=col(f"q_{joint_id}"), qd=qd,
                  meta=dict(meta or {}))


def export_csv(directory: str | Path, joint_id: str, out: str | Path | None = None,
               meta: dict | None = None, segment: str | None = None) -> str:
    """A run's trace for one joint in the core record format, re-readable by ``bench analyze``."""
    return trace_to_record(read_trace(directory), joint_id, meta, segment).to_csv(out)
