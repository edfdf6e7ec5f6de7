"""A record with a velocity and no position: a drive's scope logs the actual speed and the
actual current, the classic friction-velocity test.  Its position is the velocity integrated
(trapezoids on the record's own times, in SI, once the rows with lost cells are out): eq. 5's
acceleration is then the velocity's derivative, as it would be anyway, and the velocity column
stays the model's velocity.  What the integral cannot give is where the joint is: position-
locked effects (gravity, cogging, friction that varies along the travel) are read against a
position of unknown origin that drifts with any offset of the velocity, and the report says so."""
from __future__ import annotations

import numpy as np

from bench.records import Record, column_index

WARNING = ("the file has no position column: the position was integrated from the velocity column "
           "(its origin is unknown, and an offset in the velocity makes it drift), so effects locked "
           "to position (gravity, cogging, friction along the travel) are read against that")


def velocity_only(mapping: dict, names: list) -> bool:
    """Is a velocity column mapped and no position column there?"""
    return column_index(mapping.get("qd"), names) is not None and column_index(mapping.get("q"), names) is None


def integrate(rec: Record) -> None:
    """``rec.q`` from ``rec.qd`` (SI, rows with lost cells already out)."""
    t, v = np.asarray(rec.t, dtype=float), np.asarray(rec.qd, dtype=float)
    q = np.zeros_like(v)
    if len(v) > 1:
        q[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))
    rec.q = q
