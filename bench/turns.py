"""A revolute position that wraps at a whole turn (a single-turn absolute encoder, an angle
logged in [-180°, 180°) or [0, 2π)) is unwrapped before anything else reads it.

Left wrapped, each wrap is a step of almost 2π inside one sample: the derivative filter makes
a velocity spike of thousands of rad/s out of it, and the record was refused as "never reaches
sliding … record with a larger torque amplitude" — advice that sends a technician to the wrong
fix.  A step is taken for a wrap only when it lies within a quarter turn of a whole number of
turns and the position's every other step stays under a quarter turn (so the motion is
resolved and a whole turn cannot be a real step); anything else is left for the checks that
follow to judge.
"""
from __future__ import annotations

import math

import numpy as np

from bench.records import Record

TURN = 2.0 * math.pi
# A real step of the joint between two samples stays far below a quarter turn: the fastest
# preset (the rotary motor, ~30 rad/s at 1 kHz) moves 0.03 rad a sample, and a 13 ms logger
# step 0.4 rad.  A wrap then lies within that much of a whole turn.
QUARTER = TURN / 4.0


def unwrap_turns(rec: Record) -> int:
    """Unwrap ``rec.q`` in place where it wraps at whole turns; the number of wraps taken out
    (0 for a prismatic joint or a position that never jumps by half a turn)."""
    if str(rec.meta.get("joint_type", "revolute")) != "revolute" or len(rec.q) < 3:
        return 0
    q = np.array(rec.q, dtype=float)
    seen = np.isfinite(q)      # a position on rows of its own: empty elsewhere (bench.joined_streams)
    dq = np.diff(q[seen])
    jump = np.abs(dq) > TURN / 2.0
    if not jump.any() or jump.all():
        return 0
    turns = np.round(dq[jump] / TURN)
    left = dq[jump] - turns * TURN
    if np.abs(dq[~jump]).max() >= QUARTER or np.abs(left).max() >= QUARTER:
        return 0
    shift = np.zeros(np.count_nonzero(seen))
    shift[1:][jump] = -turns * TURN
    q[seen] += np.cumsum(shift)
    rec.q = q
    return int(np.abs(turns).sum())
