"""Timestamps written coarser than the samples come.

A logger that writes its clock with too few digits (``%.2f`` seconds, a 10 ms tick) beside
samples taken every millisecond gives ten rows the same time.  Read as duplicates, nine of
ten samples were dropped; read as they are, the median step is 0 and the record was refused
("sample step 0 s is outside ...").  Where most rows repeat the time before them, the time
is a stamp of the samples' quantum, not of each sample: the rows of one stamp are spread
evenly over the quantum after it (as a truncating clock writes them; a rounding one is off by
half a quantum, one constant shift of the whole record, which identification does not see).
A stamp followed by a gap keeps the quantum's width.  A few repeated times (a logger writing
one twice) are duplicates still, dropped by ``bench.resample``.
"""
from __future__ import annotations

import copy

import numpy as np
from scipy.ndimage import uniform_filter1d

from bench.records import Record

# Spread only where the stamps are clearly coarser than the samples: at least half the rows
# repeat the time before them (the median step is then 0).  A 1 kHz PC logger stamping in
# whole milliseconds repeats a few % of its times (dropped as duplicates, as before).
REPEATED_SHARE = 0.5
# the spread times are evened over this many stamps' samples (``_evened``)
SMOOTH_STAMPS = 3.0


def _evened(spread: np.ndarray, starts: np.ndarray, stamps: np.ndarray, quantum: float,
            step: float, width: int) -> np.ndarray:
    """``spread`` with each run between gaps (stamp steps over 1.5 quanta) smoothed over
    ``width`` samples about its own straight line: a sample clock not locked to the stamps'
    puts 9 and 11 samples in neighbouring stamps (a clean 1 kHz j2 log rounded to 10 ms:
    steps 9 % uneven, so resampled, Fc -1.7 %), which the average evens out; a lost sample
    stays a step of the time spread over the window.  A steady clock's run is its straight
    line (that j2 log: its exact times' parameters)."""
    if width < 3:
        return spread
    cuts = starts[1:][np.diff(stamps) > 1.5 * quantum]
    out = spread.copy()
    for a, b in zip(np.concatenate(([0], cuts)), np.concatenate((cuts, [len(spread)]))):
        if b - a <= width:
            continue
        i = np.arange(b - a, dtype=float)
        line = np.polyval(np.polyfit(i, spread[a:b], 1), i)
        off = spread[a:b] - line
        # a steady clock (the run's samples within one sample step of one line) is taken
        # as such: evenly sampled, nothing to resample.  Lost samples walk away from a line
        # (j2 with 0.5 % lost and 30 % jitter, tuning seed 1580, a 10 ms stamp: Fc +1.6 % on
        # the line, +1.2 % evened, -0.5 % from the exact times)
        out[a:b] = line if np.max(np.abs(off)) <= step else line + uniform_filter1d(off, width, mode="nearest")
    return out


def spread_stamps(rec: Record) -> dict | None:
    """Spread ``rec.t`` in place where its stamps are coarser than its samples; returns what
    was done (the quantum, samples per stamp) or None."""
    t = np.asarray(rec.t, dtype=float)
    if len(t) < 3:
        return None
    d = np.diff(t)
    if np.count_nonzero(d == 0) < REPEATED_SHARE * len(d) or np.any(d < 0):
        return None     # time going back is an error bench.resample names
    starts = np.concatenate(([0], np.nonzero(d > 0)[0] + 1))
    if len(starts) < 3:
        return None     # every timestamp the same: bench.resample says so
    stamps = t[starts]
    quantum = float(np.median(np.diff(stamps)))
    counts = np.diff(np.concatenate((starts, [len(t)])))
    width = np.minimum(np.append(np.diff(stamps), quantum), quantum)
    step = width / counts
    typical = float(np.median(counts))
    within = (np.arange(len(t)) - np.repeat(starts, counts)).astype(float)
    # the log starts and ends mid-quantum: its first stamp holds the quantum's last samples,
    # its last stamp the first ones, at the typical step (a first stamp fuller than typical
    # keeps to its quantum, not running into the next stamp's times)
    step[0] = min(quantum / typical, step[0])
    step[-1] = quantum / typical
    lead = max(typical - counts[0], 0.0)
    within[:counts[0]] += lead
    spread = stamps.repeat(counts) + step.repeat(counts) * within
    # evened in time since the first stamp: a Unix time's 0.24 us rounding stays out of the fit
    rec.t = stamps[0] + _evened(spread - stamps[0], starts, stamps, quantum, quantum / typical,
                                int(round(SMOOTH_STAMPS * typical)))
    return {"quantum": quantum, "samples_per_stamp": typical, "stamps": int(len(starts))}


def spread(rec: Record) -> Record:
    """``rec``, or a copy with its times spread where its stamps are coarser than its samples
    (``spread_stamps``); the copy's ``reading`` says what was done (``stamps_spread``) and
    keeps the stamps as written (``stamps_t``: --residuals writes them)."""
    out = copy.copy(rec)
    done = spread_stamps(out)
    if not done:
        return rec
    out.reading = dict(rec.reading, stamps_spread=done, stamps_t=np.array(rec.t, dtype=float))
    return out
