"""Uneven timestamps -> evenly sampled segments.

A PC logger samples when it gets round to it (1-13 ms steps around a nominal rate), drops
samples now and then, and sometimes writes a timestamp twice.  Identification needs a fixed
step (the bristle state is integrated over it, the filters assume it), so such a record is
put on a uniform grid at its median step, one signal at a time:

  q    PCHIP (shape-preserving cubic): smooth, so its differences stay meaningful, and no
       overshoot between samples (no invented motion at reversals);
  tau  held (the previous sample) when the record says ``torque_hold: zoh`` (a command held
       until the next one); otherwise sampled, so linear;
  qd   linear.

A step longer than ``GAP_STEPS`` median steps and ``GAP_TYPICAL`` times the 95th percentile
step is a gap: nothing is interpolated across it.
The record is split there into segments analysed together, each with its own filter edges
and its own bristle start (see ``Record.segments``).  Duplicate timestamps keep their first
sample; time that goes backwards is an error.  An evenly sampled record is returned as it is.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from bench import standstill
from bench.errors import InputError
from bench.records import Record
from bench.signals import MIN_SEGMENT_SAMPLES

# A gap: a step longer than 3 median steps *and* twice the record's own long steps (its 95th
# percentile).  An even record's steps are all the median, so 3 median steps decide there.  A PC
# logger's ordinary steps reach 3x its median (1-13 ms around 4 ms): cut there, a 20 s log fell
# into 17-76 segments whose filter edges left little to score (tuning seeds 1209, 1490), while
# PCHIP across one long step or one lost sample is harmless.  A stall (30-300 ms) is still a
# gap: the motion in between is a guess, and splitting costs only filter edges.  Never more
# than 8 median steps: where holes are frequent (over 5 % of the steps) they are the percentile.
GAP_STEPS = 3.0
GAP_TYPICAL = 2.0
GAP_MAX_STEPS = 8.0
# evenly sampled: every step within 1 % of the median (as bench.records.validate checks)
EVEN_TOL = 0.01
# a segment with fewer grid samples than MIN_SEGMENT_SAMPLES is dropped (reported)
# ... or shorter than this: the comparison grid (bench.signals.condition: 10 samples per cutoff
# period, the default cutoff at least 5 Hz) steps up to 20 ms, and its three-stage box average
# leaves MIN_SEGMENT_SAMPLES of a segment only from 3 + 3 grid steps on; a shorter one left an
# empty grid segment that broke the breakaway count (soak seed 30027: 11 ms kept after a
# standstill cut at 2 kHz).  Its filter edges (3 / cutoff each side) cover it whole anyway.
MIN_SEGMENT_TIME = (3 + MIN_SEGMENT_SAMPLES - 1) / (10.0 * 5.0)


def increasing(t: np.ndarray, name: str) -> None:
    """Time that goes back is an error naming where."""
    back = np.nonzero(np.diff(t) < 0)[0]
    if len(back):
        i = int(back[0])
        raise InputError(f"{name}: time is not increasing: it goes back from t={t[i]:g} to t={t[i + 1]:g} "
                         f"at data row {i + 2}")


def regularise(rec: Record, name: str = "record") -> Record:
    """``rec`` on a uniform grid, split at gaps, with ``rec.reading['resampling']`` saying
    what was done.  ``rec``'s arrays must be finite."""
    t = np.asarray(rec.t, dtype=float)
    if len(t) < 2:
        raise InputError(f"{name}: only {len(t)} samples; a record needs at least two excitation cycles")
    increasing(t, name)
    d = np.diff(t)
    keep = np.concatenate(([True], d > 0))
    duplicates = int(len(t) - keep.sum())
    cols = {k: np.asarray(getattr(rec, k), dtype=float)[keep] for k in ("t", "tau", "q")}
    if rec.qd is not None:
        cols["qd"] = np.asarray(rec.qd, dtype=float)[keep]
    t = cols["t"]
    if len(t) < 2:
        raise InputError(f"{name}: every timestamp is the same")
    d = np.diff(t)
    h = float(np.median(d))
    threshold = max(GAP_STEPS * h, min(GAP_TYPICAL * float(np.percentile(d, 95)), GAP_MAX_STEPS * h))
    gaps = np.nonzero(d > threshold)[0]
    steps = np.delete(d, gaps)
    report = {
        "resampled": False, "median_step": h, "rate_hz": 1.0 / h, "max_step": float(d.max()),
        "jitter": float(np.std(steps) / h), "duplicates_dropped": duplicates,
        "gap_threshold": threshold, "gap_threshold_steps": threshold / h, "gaps": int(len(gaps)),
        "longest_gap": float(d[gaps].max()) if len(gaps) else 0.0,
        "torque_resolution": reading_resolution(cols["tau"]),
    }
    meta = dict(rec.meta)
    even = np.max(np.abs(d - h)) <= EVEN_TOL * h + 1e-9
    # lost samples only: every step a whole number of steps, so the grid falls on the drive's
    # own clock and only the lost slots are filled.  A torque read there is what it was -- a
    # command held, say, which identify's auto test then finds as on an even record.  Taken for
    # samples, the rotary motor's held command under two tones at 2 kHz with 1 % of its rows
    # lost was read half a step late: Fc +19 %, determined, structure left (tuning seed 1781)
    on_clock = not even and np.max(np.abs(d / h - np.round(d / h))) <= EVEN_TOL
    pieces_raw = list(zip(np.concatenate(([0], gaps + 1)), np.concatenate((gaps + 1, [len(t)]))))
    still, spans = standstill.standstills(t, cols["q"], pieces_raw)
    if still:
        report["standstills_cut"] = [{"t_start": float(t[a]), "t_end": float(t[b - 1])} for a, b in still]
        # the time between the samples either side of each cut; cuts that meet at a logger's
        # stall (bench.standstill: one standstill) count the stall once
        joined: list[list[int]] = []
        for a, b in still:
            if joined and joined[-1][1] == a:
                joined[-1][1] = b
            else:
                joined.append([a, b])
        report["standstill_time"] = float(sum(t[min(b, len(t) - 1)] - t[max(a - 1, 0)] - h for a, b in joined))
        pieces_raw = _without(pieces_raw, still)
    if even and not still:
        out = Record(t=t, tau=cols["tau"], q=cols["q"], qd=cols.get("qd"), meta=meta)
        report["segments"] = [_segment(t)]
        out.reading = dict(rec.reading, resampling=report)
        return out
    # a command held until the next one is held on the grid too; a friction column (inertia 0)
    # is a measurement, sampled.  An even record cut at standstills keeps its own samples (the
    # grid falls on them), so its torques are what they were.
    held = (not even and str(meta.get("torque_hold", "auto")).lower() == "zoh"
            and meta.get("inertia") not in (0, 0.0, "0"))
    ranges: list[tuple[int, int]] = []
    dropped: list[dict] = []
    for a, b in pieces_raw:
        ts = t[a:b]
        if _grid_length(ts, h) < MIN_SEGMENT_SAMPLES or b - a < 2 or ts[-1] - ts[0] < MIN_SEGMENT_TIME:
            dropped.append(_segment(ts))
        else:
            ranges.append((int(a), int(b)))
    layout = Layout(t=t, q=cols["q"], h=h, ranges=ranges, held=held, tau=cols["tau"])
    pieces = [layout.resample(i, cols["q"][a:b], cols["tau"][a:b], None if "qd" not in cols else cols["qd"][a:b])
              for i, (a, b) in enumerate(ranges)]
    if not pieces:
        raise InputError(f"{name}: segments too short to analyse after splitting at {len(gaps)} gaps "
                         f"(steps > {threshold:.4g} s, {threshold / h:.3g} x the median step)")
    starts = np.cumsum([0] + [len(p["t"]) for p in pieces[:-1]]).tolist()
    cat = {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]}
    if not held and not even and not on_clock:
        meta["torque_hold"] = "sample"   # the grid's torques are samples of it now
    if on_clock:
        report["on_clock"] = True
    report.update(resampled=not even, segments=[_segment(p["t"]) for p in pieces], segments_dropped=dropped,
                  methods={"q": "pchip", "tau": "previous sample (held)" if held else "linear",
                           **({"qd": "linear"} if "qd" in cols else {})})
    out = Record(t=cat["t"], tau=cat["tau"], q=cat["q"], qd=cat.get("qd"), meta=meta,
                 segments=starts if len(pieces) > 1 else None, step=h)
    out.reading = dict(rec.reading, resampling=report, layout=layout)
    if still:   # where the joint stood still, its kept rest included (bench.signals.condition)
        out.reading["standstill_spans"] = spans
    return out


@dataclass
class Layout:
    """Where a resampled record's samples came from: the logger's own (de-duplicated) times
    and positions, the grid step and the raw index range of each segment kept.  The
    perfect-model replay (``bench.perfect_model``) samples its twin at these very times and
    resamples it the same way, so resampling's own errors are in its floor too."""
    t: np.ndarray
    q: np.ndarray
    h: float
    ranges: list
    held: bool
    tau: np.ndarray | None = None      # the logged torque (its reading's dither, bench.perfect_model)

    def resample(self, i: int, q: np.ndarray, tau: np.ndarray, qd: np.ndarray | None = None) -> dict:
        """Segment ``i``'s raw samples (q, tau, qd at ``t[a:b]``) on its grid.  Interpolated in
        time since the record's first sample: a Unix time's grid points (1.7e9 s) round to
        0.24 us, steps that differ by 2e-4 of a millisecond's (a 40 s j2 PC-logger log, tuning
        seed 1111: Fc 0.05 % from the same log stamped from zero; now digit for digit)."""
        a, b = self.ranges[i]
        t0 = self.t[0]
        ts, grid = self.t[a:b] - t0, (self.t[a] - t0) + self.h * np.arange(_grid_length(self.t[a:b], self.h))
        piece = {"t": t0 + grid, "q": PchipInterpolator(ts, q)(grid)}
        if self.held:
            piece["tau"] = tau[np.searchsorted(ts, grid, side="right") - 1]
        else:
            piece["tau"] = np.interp(grid, ts, tau)
        if qd is not None:
            piece["qd"] = np.interp(grid, ts, qd)
        return piece


def _without(pieces: list, cuts: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """``pieces`` (raw index ranges) with the ``cuts`` (each inside one piece) taken out."""
    out = []
    for a, b in pieces:
        for lo, hi in sorted(c for c in cuts if a <= c[0] < b):
            out.append((a, lo))
            a = hi
        out.append((a, b))
    return [(int(a), int(b)) for a, b in out if b > a]


def _grid_length(ts: np.ndarray, h: float) -> int:
    return int(np.floor((ts[-1] - ts[0]) / h + 1e-9)) + 1


def reading_resolution(x: np.ndarray) -> float:
    """The step a reading sits on (an encoder's count; a drive's torque in per-mille of its
    rated torque, an ADC's count), or 0 when its values are not on a grid."""
    d = np.abs(np.diff(x))
    d = d[d > 0]
    if len(d) < 10:
        return 0.0
    res = float(np.percentile(d, 1))
    steps = np.abs(x - x[0]) / res
    return res if np.mean(np.abs(steps - np.round(steps)) < 0.02) > 0.98 else 0.0


def on_grid(rec: Record, name: str = "record") -> Record:
    """``rec`` as identification needs it: unchanged when it is already on a grid (read from a
    file, or evenly sampled); otherwise resampled like a file would be, so a record built in
    memory (a generator, a script) with a logger's timestamps is never analysed as if even."""
    if rec.step is not None or "resampling" in rec.reading:
        return rec
    t = np.asarray(rec.t, dtype=float)
    d = np.diff(t)
    if len(d) == 0 or (np.all(d > 0) and np.max(np.abs(d - np.median(d))) <= EVEN_TOL * np.median(d) + 1e-9
                       and not standstill.stretches(t, np.asarray(rec.q, dtype=float), [(0, len(t))])):
        return rec
    out = regularise(rec, name)
    out.reading.setdefault("raw_t", t.copy())
    return out


def _segment(t: np.ndarray) -> dict:
    return {"t_start": float(t[0]), "t_end": float(t[-1]), "samples": int(len(t))}
