"""A torque, position or velocity column filled forward from a slower stream.

A logger that puts a torque read at 100 Hz on the rows of a 1 kHz encoder (pandas'
``merge_asof``, a ROS bag exported on the encoder's topic, a spreadsheet's fill-down) repeats
each reading for ten rows.  Read as it is, every torque sits up to 9 ms late against the
positions, and the lag is told as physics: j2, tuning seed 1620, a 100 Hz torque on 1 kHz rows
named an inertia 25 % too high with 86 % of the held-out error (inertia errors on 8 of 10 tuning
records with a reading every 4-10 rows, on five joints).  Where a column repeats in runs that
start at a steady pace, each run's first row shows a reading (taken on that row, or -- two
loggers merged -- on a clock of its own, up to a row before: ``reading_times`` finds its
instant where the readings pin that clock) and the rows between are
interpolated from the readings about them (a cubic spline: a linear one missed a sine's curvature by 11 %
of the rotary motor's Fc, whose torque is 27x its friction).  Every row is kept: dropping the
rows between (analysing at the slow stream's rate) read j3's Fc 14 % low (seed 1621, 250 Hz
on 1 kHz rows), and j2's 100 Hz held command 44 % low.

The same staircase is what a drive's trace of a slower command it held looks like -- and then
it is right as written (j2, seed 1620, a 100 Hz command on 1 kHz rows: every parameter within
0.2 %, nothing named; interpolated, a torque lag was named).  The motion tells them apart: a
held command steps the acceleration where it changes and a torque read slower does not
(``_held_command``); the report says which was read.  A friction-torque record (inertia 0)
holds readings.  A position read slower than the torque was told as a torque lag (j2, seed
1620, 250 and 100 Hz on 1 kHz rows): it is interpolated the same way.
"""
from __future__ import annotations

import copy

import numpy as np
from scipy import signal
from scipy.interpolate import CubicSpline

from bench.records import Record

# At least half the rows repeat the torque before them (a reading every 2+ rows).
REPEATED_SHARE = 0.5
# Readings every 2 rows were left as they are: half a row late on average, which moved
# nothing (j2, tuning seed 1620: Fc, Fs, sigma2 within 0.2 %, nothing named, as exact); 3 rows
# moved Fc 1.2 %, 4 and 5 rows named an inertia error (j2 1620, j3 1621).
MIN_ROWS_PER_READING = 2.5
# A torque or position read in coarse steps repeats too, changing by one step whenever the
# signal crosses the next (at a pace set by its slope): where most changes are of one size
# the column is a coarse reading, not a stream filled forward (whose changes follow the slope).
ONE_SIZE_SHARE = 0.5
# The runs' starts keep a steady pace: the interval between two (less a whole number of the
# typical one: a reading the same as the one before makes a run two intervals long) wanders
# by a median of at most ``PACE_TOLERANCE`` rows.  A stream's readings arrive on its own clock
# and show at the next row, so the interval wanders by up to a row either way (j2, 30 %
# jitter on a logger in step with the drive, a 100 Hz command: a median 0.77 rows).
PACE_TOLERANCE = 1.0
# A held command: the acceleration follows the staircase's steps with a t statistic of at least
# ``HELD_T`` and, with an inertia declared, a share of 1/M of at least ``HELD_SHARE``.  Measured
# on six joints, clean and 30 % jittered (tuning seeds 1622-1623): held every 6-10 rows, 0.39-0.72
# of 1/M and t 7.9-68; filled forward, at most 0.25 and t 3.8 (every 3-10 rows).  A command held
# every 3-4 rows reads t 1.3-14: mostly undecided, so read as readings (1-1.5 rows early then);
# ``torque_hold: zoh`` (``--torque-hold zoh``) says the column is the command as held.
HELD_T = 6.0
HELD_SHARE = 0.25
# A stream slower than 20 Hz is not one a logger fills forward: a torque held that long is an
# excitation's level (torque steps held for seconds), kept as written.
MAX_INTERVAL = 0.05
# fewer readings than this and the pace says nothing
MIN_READINGS = 20
# a pause in a stream's readings longer than this many of its intervals is a gap: not
# interpolated across
GAP_INTERVALS = 2.5
# A stream on a clock of its own (a merge of two loggers) shows each reading on the first row
# at or after it: up to a row late, at random, which the second derivative amplifies (a 200 Hz
# position so read named a gear spring on j1-j3 and an inertia error on the rotary motor,
# tuning seeds 1670-1675).  Its readings keep a steady pace, so a line through their windows
# (after the row before, at the row) finds their instants; the windows pin it where the line
# is inside at least ``CLOCK_INSIDE`` of them and the room they leave it (2 % left out each
# side) is at most ``CLOCK_ROOM`` of a row either way.  Measured (tuning seeds 1680-1689, 1 kHz
# rows clean, 15 % and 40 % jittered with 0.5-2 % lost): clocks of 2.7-40.3 ms, or 5 ms some
# 20-60 ppm off, inside 0.97-1.0 and room 0.01-0.10 (their own sampling scattered by 0.1 of a
# row: 0.91-0.93, -0.10; by 0.2 and more, not pinned); a clock in step with the rows, one
# phase throughout, room 0.71-1.0.  Not pinned, the line still errs steadily where the rows
# err at random: the readings are placed on it (clipped into their windows) and the report
# says the clock was not pinned.  A 200 Hz position under a PID loop (tuning seeds 1720-1725,
# six joints, the jittered lossy logger) from a clock in step with the rows, 0.37 and 0.8 ms
# after them: on the rows a gear spring, a torque lag or an inertia error named on 7 of 12 and
# the linear stage's, the rotary motor's and j3's Fc undetermined; on the line nothing named
# but where the true instants name it too (a linear stage's gear spring); with their own sampling
# scattered by 0.3 of a row: j2's Fc -5.4 % on the rows, -0.9 % on the line (-0.8 % at the
# true instants).  Readings every 3-10 rows of a logger that lost 1-20 rows (each loss moves
# the rest by a row) never get this far: the clock must first show in readings a row more or
# less apart than usual with no row lost between (a line tilted a row across the record fits
# one lost row as well as a drifting clock).
CLOCK_INSIDE = 0.9
CLOCK_ROOM = 0.25
# a stream on rows of its own (bench.joined_streams): each reading's instant is in the file
JOINED_CLOCK = "the file's: each reading at its own time"
# the report's word for a clock of its own, pinned by its readings' windows or not
OWN_CLOCK = "its own, each reading placed in its row"
# how a column was read (``filled_forward``'s read_as)
READ_BETWEEN = "readings, interpolated between"
HELD = "a command held"
OWN_CLOCK_ROUGH = "its own, not pinned by its readings: each placed in its row on the steadiest clock"


def _last_seen(seen: np.ndarray) -> np.ndarray:
    """Per row, the index of the last row at or before it where ``seen`` holds (0 before any)."""
    return np.maximum.accumulate(np.where(seen, np.arange(len(seen)), 0))


def _run_starts(x: np.ndarray) -> np.ndarray:
    """The rows where ``x`` begins a run of one value (the first row among them)."""
    return np.concatenate(([0], np.nonzero(np.diff(x) != 0)[0] + 1))


def forward_fill_interval(t: np.ndarray, x: np.ndarray, longest: float = MAX_INTERVAL
                          ) -> tuple[float, float] | None:
    """(the interval [s] at which ``x``'s readings arrive, the rows' step [s]) when they are
    filled forward onto rows at times ``t`` coming at least ``MIN_ROWS_PER_READING`` times as
    often, at most ``longest`` apart; else None."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    if len(x) < 2 * MIN_READINGS:
        return None
    d = np.diff(x)
    changed = d != 0
    if np.count_nonzero(~changed) < REPEATED_SHARE * len(changed):
        return None
    starts = _run_starts(x)
    steps = np.diff(t)
    row = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.0
    if len(starts) < MIN_READINGS or row <= 0:
        return None
    size = np.abs(d[changed])
    if np.mean(np.abs(size - np.median(size)) <= 1e-6 * np.median(size)) >= ONE_SIZE_SHARE:
        return None
    gaps = np.diff(t[starts[1:]])       # the first run may have started before the log
    interval = float(np.median(gaps))
    if not MIN_ROWS_PER_READING * row <= interval <= longest:
        return None
    whole = np.maximum(np.round(gaps / interval), 1.0)
    if np.median(np.abs(gaps - whole * interval)) > PACE_TOLERANCE * row:
        return None
    return interval, row


def reading_times(t: np.ndarray, starts: np.ndarray, interval: float
                  ) -> tuple[np.ndarray, float | None, bool, float]:
    """The instants of the readings that show first on the rows ``starts`` (times ``t``), the
    period of their own clock, whether their windows (after the row before, at the row) pin
    it (``CLOCK_INSIDE``, ``CLOCK_ROOM``) and the room [s] they leave it, in whose middle the
    instants are placed -- where the readings show a clock of their own; else the rows' own
    times, None, False and 0.  The first run may have begun before the log: it stays on its
    row."""
    ts = t[starts].copy()
    s = starts[1:]
    if len(s) < MIN_READINGS:
        return ts, None, False, 0.0
    hi, lo = t[s], t[s - 1]
    gaps = np.diff(hi)
    row = float(np.median(np.diff(t)))
    # A clock of its own shows where readings a period apart are a row more or less apart than
    # most, with no row lost between; readings on the rows of a logger that lost a row or two
    # are always a whole number of the usual count of rows apart (every row that is there)
    # and would fit a line tilted a row across the record as well as a drifting clock does.
    apart = np.diff(s)
    whole = np.round(gaps / row) == apart                   # no row lost between
    usual = np.bincount(apart[whole]).argmax() if whole.any() else 0
    if usual == 0 or not np.any(whole & (apart % usual != 0)):
        return ts, None, False, 0.0
    # a reading the same as the one before makes a longer gap
    period = float(np.mean(gaps[gaps < 1.5 * interval]))
    # Each reading is somewhere in its window: the windows' middles scatter about the clock.
    # Counted gap by gap, lost rows can make a gap 1.5 periods and the count slip by one (once
    # in 3700 readings of 5.37 ms on a lossy logger), and a line through a slipped count locks
    # onto a wrong period; so the readings are counted from a line through the first 64, then
    # from one through the first 128, ... (each extends its line by a few hundredths of a row).
    mid = 0.5 * (lo + hi)
    n = np.concatenate(([0.0], np.cumsum(np.maximum(np.round(gaps / period), 1.0))))
    k = 64
    while True:
        offset, period = np.polynomial.polynomial.polyfit(n[:k], mid[:k], 1)
        k = min(2 * k, len(n))
        n[:k] = np.round((mid[:k] - offset) / period)
        if k == len(n):
            break
    offset, period = np.polynomial.polynomial.polyfit(n, mid, 1)
    # The middles are biased where the phase stays put (a reading just after a row sits half a
    # row before its window's middle); the windows are not.  Of the clocks within two rows of
    # that one over the record, take the one leaving the most room between the windows' ends
    # (2 % left out each side: the stream's own scatter), in the middle of that room.
    span = 2.0 * row / max(n[-1] - n[0], 1.0)

    def room(p):
        return np.quantile(hi - p * n, 0.02), np.quantile(lo - p * n, 0.98)

    shifts = np.linspace(-span, span, 81)
    period += shifts[int(np.argmax([np.subtract(*room(period + d)) for d in shifts]))]
    top, bottom = room(period)
    line = 0.5 * (top + bottom) + period * n
    inside = np.mean((line > lo) & (line <= hi))
    ts[1:] = np.clip(line, np.nextafter(lo, np.inf), hi)
    return (ts, float(period), bool(inside >= CLOCK_INSIDE and abs(top - bottom) <= CLOCK_ROOM * row),
            float(max(top - bottom, 0.0)))


def _between(t: np.ndarray, x: np.ndarray, starts: np.ndarray, ts: np.ndarray, interval: float) -> np.ndarray:
    """``x`` at every row, interpolated between its readings (first shown on the rows
    ``starts``, taken at ``ts``); across a gap in the readings (``GAP_INTERVALS``: the faster
    stream's own) it is held, as written."""
    xs = x[starts]
    out = CubicSpline(ts, xs, extrapolate=False)(t) if len(ts) > 3 else np.interp(t, ts, xs)
    after = np.clip(np.searchsorted(ts, t, side="right"), 1, len(ts) - 1)
    held = (ts[after] - ts[after - 1] > GAP_INTERVALS * interval) | (t >= ts[-1]) | ~np.isfinite(out)
    out[held] = x[held]
    return out


def _held_command(t: np.ndarray, q: np.ndarray, stair: np.ndarray, smooth: np.ndarray,
                  interval: float, inertia) -> bool:
    """Does the motion step with the staircase?  Above the readings' rate the staircase less
    the interpolated torque is a sawtooth; a held command puts it into the acceleration (the
    regression of the acceleration's part up there on it reads 0.59-0.72 of 1/M, t 15-68) and
    a stream filled forward does not (-0.03-0.06 of 1/M, |t| <= 3.4): the linear stage, the
    rotary motor, j2 and j3 at 100 Hz on 1 kHz rows, clean and 30 % jittered, tuning seed 1622
    (more at ``HELD_T``)."""
    h = float(np.median(np.diff(t)))
    sos = signal.butter(2, min(0.25 / interval, 0.2 / h), fs=1.0 / h, output="sos")
    # np.gradient twice: a wide stencil, which smooths the encoder's noise more than the
    # sawtooth (the narrowest stencil read 1/M itself but at a third of the t statistic; in
    # the positions, a jittered logger's times swamped it)
    acc = np.gradient(np.gradient(q, t), t)
    saw = stair - smooth
    acc_hi, saw_hi = acc - signal.sosfiltfilt(sos, acc), saw - signal.sosfiltfilt(sos, saw)
    power = float(saw_hi @ saw_hi)
    if power <= 0:
        return False
    c = float(saw_hi @ acc_hi) / power
    rest = acc_hi - c * saw_hi
    t_stat = c / max(np.sqrt(float(rest @ rest) / len(rest) / power), 1e-300)
    m = _number(inertia)
    return t_stat >= HELD_T and (m is None or m <= 0 or c * m >= HELD_SHARE)


def slowest_reading_rate(rec: Record) -> float:
    """The rate [Hz] of the slowest stream read between its readings (``filled_forward``),
    inf when none: what it did between them is interpolated, not measured."""
    return min((ff["rate_hz"] for ff in rec.reading.get("filled_forward", {}).values()
                if ff["read_as"] == READ_BETWEEN), default=float("inf"))


def filled_forward(rec: Record, inertia=None, instants: dict | None = None) -> Record:
    """``rec``, or a copy whose forward-filled torque, position or velocity
    (``forward_fill_interval``) is interpolated between its readings -- a torque only where it
    is not a held command (``_held_command``); ``inertia``: the record's, 0 for a friction
    column; ``instants``: per column placed by ``bench.joined_streams``, the instant of the
    reading on each row (known: no pace or clock to find).  The copy's ``reading`` says what
    was found (``filled_forward``: per column, its rate and how it was read)."""
    t = np.asarray(rec.t, dtype=float)
    steps = np.diff(t)
    if len(t) < 2 * MIN_READINGS or np.any(steps < 0):
        return rec          # time going back is an error bench.resample names
    # a logger writing a time twice: its duplicates are dropped later (bench.resample keeps
    # the first); here each takes its first's value
    first = np.concatenate(([True], steps > 0))
    owner = _last_seen(first)
    tu = t[first]
    cols = {c: np.asarray(getattr(rec, c), dtype=float)[first] for c in ("q", "qd", "tau")
            if getattr(rec, c) is not None}
    m = inertia if inertia is not None else rec.meta.get("inertia")
    said = str(rec.meta.get("torque_hold", "auto")).lower() == "zoh"
    found, new = {}, {}
    for col, x in cols.items():
        if col in (instants or {}):
            at = instants[col][first]
            starts = _run_starts(at)
            ts, period, pinned, room = at[starts], None, True, 0.0
            interval = float(np.median(np.diff(ts))) if len(ts) > 1 else np.inf
            row = float(np.median(steps[steps > 0]))
            if len(ts) < MIN_READINGS or interval > MAX_INTERVAL:
                continue
        else:
            hit = forward_fill_interval(tu, x)
            if hit is None:
                continue
            interval, row = hit
            starts = _run_starts(x)
            ts, period, pinned, room = reading_times(tu, starts, interval)
        between = _between(tu, x, starts, ts, interval)
        held = (col == "tau" and _number(m) != 0.0
                and (said or _held_command(tu, new.get("q", cols["q"]), x, between, interval, m)))
        found[col] = {"rate_hz": 1.0 / (period or interval), "rows_per_reading": (period or interval) / row,
                      "read_as": HELD if held else READ_BETWEEN,
                      # a command held is used as written: on the rows
                      "clock": (JOINED_CLOCK if col in (instants or {})
                                else OWN_CLOCK if period and pinned and not held
                                else OWN_CLOCK_ROUGH if period and not held
                                else "the rows'")}
        if period and not held:
            found[col]["clock_room_s"] = room       # bench.clock_room carries it into the fit
        if not held:
            new[col] = between
    if not found:
        return rec
    out = copy.copy(rec)
    out.reading = dict(rec.reading, filled_forward=found)
    for col, x in new.items():
        full = np.empty(len(t))
        full[first] = x
        setattr(out, col, full[owner])
    return out


def _number(inertia) -> float | None:
    """The inertia as a number; None when not given or 'estimate'."""
    try:
        return float(inertia)
    except (TypeError, ValueError):
        return None
