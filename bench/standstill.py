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

A *held pose* is shorter (``held_poses``): a robot's dwell between point-to-point moves, the
position loop holding the joint with a torque that barely changes.  The loop's chatter and
the disturbance dither the bristles there below the encoder's resolution, and the stuck
friction creeps away from where the joint stopped, which a model driven by the measured
velocity cannot follow.  Its inside is left out of the fit and the scoring (not cut: the
filters and the bristle state run through it, so the stop and the breakaway either side stay
whole).
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
    band = max(STILL_TRAVEL * float(np.ptp(q)), 3.0 * smallest_step(q))
    w = max(3, int(round(0.5 * interval / h)))
    runs = []      # still runs [i, j) in raw indices, with their piece [a, b)
    for a, b in ranges:
        runs += [(a + i, a + j, a, b) for i, j in still_runs(q[a:b], w, band)]
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


def smallest_step(q: np.ndarray) -> float:
    """The position's smallest step between samples (1st percentile of the nonzero ones): an
    encoder's count on a raw record; 0 when it never moves."""
    d = np.abs(np.diff(np.asarray(q, dtype=float)))
    d = d[d > 0]
    return float(np.percentile(d, 1)) if len(d) else 0.0


def still_runs(q: np.ndarray, w: int, band: float) -> list[tuple[int, int]]:
    """Index ranges [i, j) where ``q`` stays within ``band`` over every window of ``w`` samples
    around each index."""
    if len(q) < w:
        return []
    spread = maximum_filter1d(q, w, mode="nearest") - minimum_filter1d(q, w, mode="nearest")
    still = np.concatenate(([False], spread <= band, [False]))
    edges = np.flatnonzero(np.diff(still.astype(np.int8)))
    return list(zip(edges[::2], edges[1::2]))


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


# A held pose: still (the band above, over HOLD_WINDOW) for HOLD_MIN reversal intervals or
# more, its torque's whole range within HOLD_TORQUE of the record's 90th percentile |tau|;
# HOLD_KEEP kept in at each side (the stop's settling, the torque's rise before breakaway).
# Measured 2026-11-29 on the independent simulator's point-to-point logs under PD (dwells of
# 0.15-0.75 intervals, ``tests/independent_joint.point_to_point``; tuning seeds 1800-1835 and
# 1900-1935, nine library kinds): named first 52 -> 58 of 72, gravity 5 -> 8 of 8; 84 clean
# logs: stories 5 -> 4, and 24 geared logs: parameters off by more than 5 % 8 -> 5.  Whole
# dwells' torque ranges there: 0.004-0.10 (p90) of that percentile; every run of 0.4 intervals
# or more in 222 records without dwells (every named condition, six joints, seeds 1320-1321;
# the independent simulator's sine, PD, two-tone, sticky and geared tests, 1330) spanned 0.17
# or more but one, our two-tone's j4 (0.045): 5 of those records have a held pose, 0.3-3.3 %
# of their samples.  Each torque window's own swing instead (not the whole run's) marked 18 of
# them, 17-19 % of our two-tone records; cutting the poses like standstills (the filters'
# edges then ate the stops and breakaways) named 1 fewer.
HOLD_WINDOW = 0.1
HOLD_MIN = 0.4
HOLD_TORQUE = 0.1
HOLD_KEEP = 0.05


def held_poses(t: np.ndarray, q: np.ndarray, tau: np.ndarray, count: float,
               ranges: list[tuple[int, int]]) -> tuple[np.ndarray, list]:
    """(the samples inside held poses, their spans [(t0, t1)]): ``t``, ``q``, ``tau`` low-passed
    on a grid, ``ranges`` its evenly sampled segments, ``count`` the encoder's step
    (``smallest_step`` of the record's own positions)."""
    out = np.zeros(len(t), dtype=bool)
    interval = reversal_interval(t, q)
    if interval is None:
        return out, []
    h = float(np.median(np.diff(t)))
    band = max(STILL_TRAVEL * float(np.ptp(q)), 3.0 * count)
    w = max(3, int(round(HOLD_WINDOW * interval / h)))
    steady = HOLD_TORQUE * float(np.percentile(np.abs(tau), 90))
    spans = []
    for a, b in ranges:
        ts = t[a:b]
        for i, j in still_runs(q[a:b], w, band):
            t0, t1 = ts[i] - 0.5 * w * h, ts[j - 1] + 0.5 * w * h
            if t1 - t0 < HOLD_MIN * interval or np.ptp(tau[a + i:a + j]) > steady:
                continue
            lo = int(np.searchsorted(ts, t0 + HOLD_KEEP * interval))
            hi = int(np.searchsorted(ts, t1 - HOLD_KEEP * interval, side="right"))
            if hi > lo:
                out[a + lo:a + hi] = True
                spans.append((float(ts[lo]), float(ts[hi - 1])))
    return out, spans
