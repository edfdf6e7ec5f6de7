"""Long standstills in a log: stretches where the joint stood still for longer than a period of
its own motion (a robot holding a pose before, between and after its moves).

They carry nothing about friction but its stuck level, and they harm the fit: the bristle
state integrates the velocity's noise there and relaxes (dither), so a fit bends LuGre until
the relaxation stops (a friction log of j2 with 15 s still before and after its 20 s of
motion: Fc 14x the truth, every parameter "not identifiable"; and the motion's frequency,
counted over the whole record, came out 2.5x low, taking the filters' band with it).  So
their insides are cut out like a logger's gaps (``bench.resample``): the motion either side
becomes a segment of its own, and half a reversal interval of the rest is kept at each side,
so a breakaway from rest stays in the record.  A segment that starts at rest is scored from
the joint's first sliding (``bench.identify.prepare``), and its bristle start leaves the
model's own offset, gravity and cogging out of the friction it is read from
(``bench.model_trace.rest_start_additive``).

A stretch is still where the position stays within a band (``STILL_TRAVEL`` of the travel,
or three encoder counts) over half a reversal interval; it is long from two median reversal
intervals (a full back-and-forth period).  The excitation's own sticking at reversals lasts
less than one interval (the joint moves between reversals), so it is never cut.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from bench.signals import motion_reversals

# Position band of a standstill, a share of the record's travel: a creep at 1 % of the top
# speed for two reversal intervals covers ~3 % of a sine's travel (kept); presliding at a
# stuck reversal of the Table II joints covers Fs/sigma0, 0.1-0.6 % of theirs, over less than
# an interval (kept by the length rule).  Measured 2026-11-27: 228 records of every named
# condition on the six joints (tuning seeds 1320-1324) and sticky sine tests at 1.02-1.1 Fs
# (1330): none cut; 10-12 s rests either side of the motion (1310-1350): every one cut.
STILL_TRAVEL = 0.005
LONGER_THAN = 2.0   # reversal intervals: a full back-and-forth period of the motion
MIN_STILL = 1.0     # s, whatever the motion's rate
KEEP = 0.5          # reversal intervals of rest kept at each side of a cut


def stretches(t: np.ndarray, q: np.ndarray, ranges: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Raw index ranges [a, b) to leave out: the insides of long standstills, none across
    ``ranges``' ends (the record's gap-free pieces)."""
    return standstills(t, q, ranges)[0]


def standstills(t: np.ndarray, q: np.ndarray, ranges: list[tuple[int, int]]):
    """(the raw index ranges to leave out, as ``stretches``; the long standstills' whole
    time spans [(t0, t1)], the kept rest at their ends included)."""
    interval = reversal_interval(t, q)
    if interval is None:
        return [], []
    h = float(np.median(np.diff(t)))
    d = np.abs(np.diff(q))
    d = d[d > 0]
    count = float(np.percentile(d, 1)) if len(d) else 0.0
    band = max(STILL_TRAVEL * float(np.ptp(q)), 3.0 * count)
    w = max(3, int(round(0.5 * interval / h)))
    runs = []      # still runs [i, j) in raw indices, with their piece [a, b)
    for a, b in ranges:
        qs = q[a:b]
        if len(qs) < w:
            continue
        spread = maximum_filter1d(qs, w, mode="nearest") - minimum_filter1d(qs, w, mode="nearest")
        still = np.concatenate(([False], spread <= band, [False]))
        edges = np.flatnonzero(np.diff(still.astype(np.int8)))
        runs += [(a + i, a + j, a, b) for i, j in zip(edges[::2], edges[1::2])]
    out, spans = [], []
    for group in _across_gaps(runs, q, band):
        # the window's half-width on each side of the run is still too
        t0 = t[group[0][0]] - 0.5 * w * h
        t1 = t[group[-1][1] - 1] + 0.5 * w * h
        if t1 - t0 < max(LONGER_THAN * interval, MIN_STILL):
            continue
        cut = False
        for i, j, a, b in group:     # each piece between the logger's gaps cut on its own
            lo = max(i, a + int(np.searchsorted(t[a:b], t0 + KEEP * interval)))
            hi = min(j, a + int(np.searchsorted(t[a:b], t1 - KEEP * interval, side="right")))
            if hi - lo > 1:
                out.append((lo, hi))
                cut = True
        if cut:
            spans.append((float(t0), float(t1)))
    return out, spans


def _across_gaps(runs: list, q: np.ndarray, band: float) -> list:
    """Still runs that a logger's gap splits are one standstill when the first is still up to
    its piece's end, the next from its piece's start, and the position across the gap stays
    in the band: a robot holding its pose does not move while its logger stalls.  Judged
    apart, each piece was shorter than the length rule, and a held pose stayed in the motion's
    segment (tuning seed 1407 on j1, 100-125 Hz: 2.3 s of rest before a stall at the end of
    the motion kept, Fs fitted 0 where the truth is 1.08 Fc)."""
    groups: list = []
    for run in runs:
        if groups:
            _, j, _, b = groups[-1][-1]
            k, _, c, _ = run
            if j == b and k == c and abs(q[k] - q[j - 1]) <= band:
                groups[-1].append(run)
                continue
        groups.append([run])
    return groups


def reversal_interval(t: np.ndarray, q: np.ndarray) -> float | None:
    """The median time between the motion's reversals (``bench.signals.motion_reversals``, on
    the record's own steps), or None with fewer than three."""
    h = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    w = max(1, int(round(0.02 / h))) if h > 0 else 1
    if len(q) < w + 3:     # too short to have reversals (extreme inputs: a few samples)
        return None
    k, w = motion_reversals(q, h, np.diff(t))
    if len(k) < 3:
        return None
    return float(np.median(np.diff(t[w // 2 + k])))
