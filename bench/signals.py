"""Zero-phase signal conditioning for identification.

Friction is estimated from eq. 5, tau_F = tau - M qdd, which needs the second derivative of a
quantised encoder signal.  Every estimate is formed with the same zero-phase low-pass
(forward-backward Butterworth), and the model's friction is passed through that same filter
before it is compared, so the filter smooths noise without biasing the fit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import signal

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file
from bench.errors import InputError
from bench.grid_math import filtfilt, fourth_order_derivative, fourth_order_second_difference, held_torque, second_difference
from bench.lugre import interval_to_samples
from bench.records import Record
from bench.segments import filtfilt_segments
from bench.velocity_column import velocity_source


@dataclass
class Conditioned:
    """A record made ready for identification.

    The model is simulated at the record's full rate (the ``*_full`` and ``*_mid`` arrays);
    everything is compared on a coarser grid: each full-rate signal is decimated by ``decim``
    (cascaded moving averages) and then low-passed (``lowpass``).  Both operations are linear and
    applied identically to measurement and model, so they remove noise without bias, and
    the costly filter runs at the lower rate."""
    dt: float               # full-rate sample period
    t_full: np.ndarray
    q_full: np.ndarray
    v_mid: np.ndarray       # velocity held over each interval, lightly smoothed (model input)
    q_mid: np.ndarray       # position at interval midpoints
    t_mid: np.ndarray
    decim: int              # full-rate samples per grid sample
    t: np.ndarray           # --- the comparison grid ---
    q: np.ndarray
    v: np.ndarray           # velocity, low-passed (maps, regimes)
    a: np.ndarray           # acceleration, low-passed
    tau: np.ndarray         # applied torque, low-passed
    cutoff: float           # Hz, of the low-pass
    frequency: float        # Hz, the excitation's fundamental
    periodic: bool          # the torque is periodic at ``frequency`` (else: the motion's rate)
    sos: np.ndarray         # the low-pass, designed for the grid rate
    # evenly sampled segments [(start, stop)) of the full-rate arrays (one unless the record
    # was split at gaps); every filter runs per segment, nothing crosses a gap
    segments: list = None
    velocity_source: str = "q"
    tau_mid: np.ndarray = None    # torque over each interval, as the joint felt it (held or mean)
    # segments that start at rest beside a long standstill (``rest_starts``)
    rest_starts: frozenset = frozenset()
    velocity_band: float = float("nan")   # Hz, the model velocity's low-pass (``velocity_band``)

    def __post_init__(self):
        if self.segments is None:
            self.segments = [(0, len(self.t_full))]

    @cached_property
    def t_since_start(self) -> np.ndarray:
        """The grid's times since the record's first sample: a lag subtracted there keeps its
        precision when the record is stamped in Unix time (0.24 us at 1.7e9 s)."""
        return self.t - self.t_full[0]

    @cached_property
    def sliding_speed(self) -> float:
        """A speed the joint only reaches sliding: ``SLIDING`` of the top speed."""
        return SLIDING * float(np.percentile(np.abs(self.v), 99.5))

    @property
    def dt_grid(self) -> float:
        return self.dt * self.decim

    def lowpass(self, x_full: np.ndarray) -> np.ndarray:
        """Full-rate signal -> the comparison grid (CIC decimation, then zero-phase low-pass).
        The fit calls this tens of thousands of times per record, so both stages are the
        compiled ones (``box_average``, ``bench.segments``: scipy's ``sosfiltfilt`` algorithm
        without its per-call checks), the filter's initial state computed once."""
        if len(self.segments) == 1:
            x = box_average(x_full, self.decim)
        else:
            x = np.concatenate([box_average(x_full[a:b], self.decim) for a, b in self.segments])
        return filtfilt_segments(self.sos, x, self._grid_bounds, self._zi)

    @cached_property
    def _grid_bounds(self) -> np.ndarray:
        return np.array(self.grid_segments, dtype=np.int64)

    @cached_property
    def _zi(self) -> np.ndarray:
        return np.ascontiguousarray(signal.sosfilt_zi(self.sos))

    def decimate(self, x_full: np.ndarray) -> np.ndarray:
        """Full-rate signal -> the grid without the low-pass (e.g. the time).  Averaged about
        its first value: the running sums of a Unix time (1.7e9 s) over 40 000 samples lose
        milliseconds, and a 40 s log's grid had 221 repeated times and steps of 0-12 ms
        (np.gradient over them divided by zero)."""
        x0 = x_full[0]
        return np.concatenate([box_average(x_full[a:b] - x0, self.decim) for a, b in self.segments]) + x0

    @cached_property
    def interval_segments(self) -> list[tuple[int, int]]:
        """Segments of the interval (``*_mid``) arrays: one interval fewer per segment."""
        return [(a - k, b - k - 1) for k, (a, b) in enumerate(self.segments)]

    @cached_property
    def grid_segments(self) -> list[tuple[int, int]]:
        """Segments of the comparison grid."""
        out, at = [], 0
        for a, b in self.segments:
            n = grid_length(b - a, self.decim)
            out.append((at, at + n))
            at += n
        return out

    def at_samples(self, x_mid: np.ndarray) -> np.ndarray:
        """An interval signal (``*_mid``) at the full-rate samples, segment by segment (the
        mean of the two intervals around each sample, as ``bench.lugre.interval_to_samples``)."""
        return np.concatenate([interval_to_samples(x_mid[ia:ib]) if ib > ia else np.zeros(b - a)
                               for (a, b), (ia, ib) in zip(self.segments, self.interval_segments)])

    def friction(self, inertia: float) -> np.ndarray:
        """Friction estimate of eq. 5 with inertia M, on the grid."""
        return self.tau - inertia * self.a


def box_average(x: np.ndarray, d: int, stages: int = 3) -> np.ndarray:
    """Decimate by ``d`` after ``stages`` cascaded length-d moving averages (a CIC filter:
    sinc^stages response with nulls where aliases would land).  One stage is not enough:
    the quantisation noise of a second difference grows like f^4 and would alias back."""
    x = np.asarray(x, dtype=float)
    if d == 1:
        return x
    return _box_average(np.ascontiguousarray(x), int(d), int(stages))


# a segment with fewer samples than this cannot be filtered (bench.resample drops it)
MIN_SEGMENT_SAMPLES = 4


def grid_length(n: int, d: int, stages: int = 3) -> int:
    """How many samples ``box_average`` leaves of ``n``: each stage keeps n + 1 - d, then every d-th."""
    if d == 1:
        return n
    return -(-max(n - stages * (d - 1), 0) // d)


@njit(cache=True)
def _box_average(x, d, stages):
    # the same sums as np.cumsum (sequential), then differences d apart
    for _ in range(stages):
        n = x.shape[0]
        cs = np.empty(n + 1)
        cs[0] = 0.0
        acc = 0.0
        for i in range(n):
            acc += x[i]
            cs[i + 1] = acc
        out = np.empty(max(n + 1 - d, 0))
        for i in range(out.shape[0]):
            out[i] = (cs[i + d] - cs[i]) / d
        x = out
    return x[::d].copy()


def excitation_frequency(t: np.ndarray, tau: np.ndarray, dt: float | None = None) -> float:
    """Fundamental of the applied torque from the peak of its spectrum (Hann window);
    ``dt``: the sample step, where time was cut out of the record (long standstills)."""
    x = tau - np.mean(tau)
    n = len(x)
    spec = np.abs(np.fft.rfft(x * np.hanning(n)))
    freqs = np.fft.rfftfreq(n, d=dt or (t[-1] - t[0]) / (n - 1))
    spec[0] = 0.0
    k = int(np.argmax(spec))
    if 0 < k < len(spec) - 1:  # parabolic interpolation of the peak
        a, b, c = np.log(spec[k - 1] + 1e-300), np.log(spec[k] + 1e-300), np.log(spec[k + 1] + 1e-300)
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den != 0 else 0.0
        return float((k + shift) * freqs[1])
    return float(freqs[k])


def reversals(v: np.ndarray, threshold: float) -> np.ndarray:
    """Indices where the motion reverses: the velocity goes from above +threshold to below
    -threshold or back (the hysteresis keeps noise around a standstill from counting); each
    reversal is placed at the last sign change of v before the new direction is reached."""
    v = np.asarray(v, dtype=float)
    state = np.where(v > threshold, 1, np.where(v < -threshold, -1, 0))
    held = np.nonzero(state)[0]
    if len(held) < 2:
        return np.zeros(0, dtype=int)
    st = state[held]
    reached = held[1:][st[1:] != st[:-1]]          # first sample in the new direction
    s = np.sign(v)
    changes = np.nonzero(s[1:] != s[:-1])[0] + 1
    k = np.searchsorted(changes, reached, side="right") - 1
    return np.where(k >= 0, changes[np.maximum(k, 0)], reached).astype(int)


def motion_frequency(t: np.ndarray, q: np.ndarray, dt: float | None = None,
                     span: float | None = None) -> tuple[float, int]:
    """(reversals per second / 2, number of reversals) of the motion: the fundamental of a
    back-and-forth motion, whatever drives it (a torque sine, two tones, a closed loop, a
    log of ordinary motion).  The velocity is a smoothed difference of the encoder (20 ms:
    well below the excitations friction is identified with, well above a coarse encoder's
    count-to-count chatter); a reversal needs 10 % of the top speed in each direction.
    ``dt`` and ``span`` (the step and the time covered) where time was cut out of the record:
    long standstills (``bench.standstill``) would otherwise dilute the rate."""
    span = span or t[-1] - t[0]
    n = len(motion_reversals(q, dt or (t[-1] - t[0]) / (len(t) - 1))[0])
    return n / (2.0 * span), n


def smoothed_velocity(q: np.ndarray, dt: float, steps: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """(the motion's velocity, smoothed over 20 ms: a coarse encoder's count-to-count chatter
    gone; the width w in samples).  Sample i is the difference after w // 2 + i over ``dt``, or
    over each of ``steps`` (the record's own, uneven: ``steps[j]`` is t[j + 1] - t[j])."""
    w = max(1, int(round(0.02 / dt)))
    qs = np.convolve(q, np.ones(w) / w, mode="valid") if w > 1 else q
    h = dt if steps is None else np.maximum(steps[w // 2: w // 2 + len(qs) - 1], 1e-12)
    return np.diff(qs) / h, w


def white_noise_rms(pieces) -> float:
    """RMS of white noise on a signal, read from the fourth differences of its ``pieces``
    (evenly sampled runs): a smooth motion has next to none at the sample rate, white noise
    sigma has 70 sigma^2."""
    d4 = [np.diff(np.asarray(x, dtype=float), 4) for x in pieces if len(x) > 8]
    return float(np.std(np.concatenate(d4))) / math.sqrt(70.0) if d4 else 0.0


def motion_reversals(q: np.ndarray, dt: float, steps: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """(the reversals of ``motion_frequency``'s smoothed velocity, the smoothing's width w):
    reversal i lies between samples w // 2 + k[i] and the next of ``q``.  The velocity is the
    smoothed position's difference over ``dt``, or over each of ``steps`` (the record's own,
    uneven: ``steps[j]`` is t[j + 1] - t[j])."""
    v, w = smoothed_velocity(q, dt, steps)
    vmax = float(np.percentile(np.abs(v), 99.5)) if len(v) else 0.0
    if vmax <= 0:
        return np.zeros(0, dtype=int), w
    return reversals(v, 0.1 * vmax), w


# The velocity that drives the model keeps more bandwidth than the comparison filter: near
# stick the joint rings (the presliding spring against the inertia and a loop's gains) and the
# bristle state, integrating |v|, needs that ring; the position's own noise (encoder counts,
# positions interpolated across a logger's jitter) sets the ceiling, since a noisy velocity
# dithers the model's bristles loose.  Tuning seeds 1950-1970 (independent simulator, robot
# point-to-point logs under a 6 Hz PD, a felt disturbance of 1 % of Fc): at 4x the cutoff,
# the true parameters left 2 % of Fc at creep speeds (30.8 against 16.3 N m rms on j1 at
# 12x, seed 1906) and the fit bent the Stribeck dip to absorb it: Fc unidentifiable or 5-99 %
# off on 4 of 6 geared joints; at 12x all six within 1.4 %, the reading-noise logs as before.
# At 40x (the position's noise at creep speeds) they broke again (Fs 0.7-4000x).  The
# position noise's velocity rms within the band, over the top speed: coarse encoders (tuning
# seeds 1520-1537, 2^12-2^14 counts over the travel) were as at 4x up to 1.5e-2 and broke at
# 1.7e-2 (j3: Fs 292x); the logs above needed the whole 12x (at 8x j3 was still 10 % off) at
# 2.2-2.7e-3.  So the band is 12x where the position's noise allows V_NOISE there, else 4x:
# a band in between helped neither (a continuous rule, 4-12x by the noise, missed 3 and then
# 2 of 20 coarse-encoder records of the conditions' test seeds 6300+, where 4x missed <= 1).
V_BAND = (4.0, 12.0)
V_NOISE = 3e-3


def velocity_band(q: np.ndarray, bounds, dt: float, fc: float, load_encoder: bool = False) -> float:
    """The model velocity's low-pass corner [Hz] (``V_BAND``, ``V_NOISE``): white position noise
    of rms s (fourth differences) gives a velocity rms of 2 pi s sqrt(2 B^3 / (3 fs)) below B;
    the wide band where that is within V_NOISE of the top speed.
    Rounded to 3 digits, so one record in other units gets the same filter.  An encoder on the
    load (``encoder: load``) keeps 4x: it sees the motor's ring only through the gear, and the
    load-side models (``bench.load_side``) read the motor's lead off the load's motion at that
    band (a spring seen from the load was told as backlash at 12x, j1 and j3)."""
    fs = 1.0 / dt
    lo, hi = V_BAND[0] * fc, min(V_BAND[1] * fc, 0.4 * fs)
    if hi <= lo or load_encoder:
        return min(lo, 0.4 * fs)
    w = max(1, int(round(0.02 / dt)))     # smoothed_velocity's width
    runs = [q[a:b] for a, b in bounds if b - a > w + 1]
    if not runs or not any(b - a > 8 for a, b in bounds):
        return lo
    s_q = white_noise_rms(q[a:b] for a, b in bounds)
    # the top speed from the smoothed motion, not from its noise
    v_top = float(np.percentile(np.abs(np.concatenate([smoothed_velocity(r, dt)[0] for r in runs])), 99.5))
    if not v_top > 0.0:
        return lo
    noise = 2.0 * math.pi * s_q * math.sqrt(2.0 * hi ** 3 / (3.0 * fs)) / v_top
    return float(f"{hi if noise <= V_NOISE else lo:.3g}")


def choose_cutoff(fs: float, f_exc: float) -> float:
    """Low-pass cutoff: high enough to keep the presliding transients of a few tens of
    excitation harmonics, low enough to keep double differentiation noise in check."""
    return float(np.clip(40.0 * f_exc, 5.0, 0.05 * fs))


def condition(rec: Record, cutoff: float | None = None, min_cycles: float = 2.0,
              name: str = "record", hold: str | None = None) -> Conditioned:
    t, q = rec.t, rec.q
    dt = rec.dt
    fs = 1.0 / dt
    # the motion's own back-and-forth rate sets the filters and the held-out segments, so any
    # excitation works; a torque sine's spectral peak is more precise, and used when it agrees
    # time cut out at long standstills is not time the joint moved in
    cut = rec.reading.get("resampling", {}).get("standstill_time", 0.0)
    f_motion, n_rev = motion_frequency(t, q, dt if cut else None, rec.duration - cut if cut else None)
    if n_rev < 2 * min_cycles:
        raise InputError(f"{name}: the joint reverses {n_rev} times in {rec.duration:.4g} s, "
                         f"{n_rev / 2:.2f} back-and-forth cycles; at least {min_cycles:g} are needed: "
                         f"record a longer or faster back-and-forth motion")
    f_exc = excitation_frequency(t, rec.tau, dt if cut else None)
    periodic = bool(np.isfinite(f_exc) and abs(f_exc / f_motion - 1.0) < 0.25)
    if not periodic:
        f_exc = f_motion
    fc = choose_cutoff(fs, f_exc) if cutoff is None else float(cutoff)
    if not 0 < fc < 0.5 * fs:
        raise InputError(f"{name}: filter cutoff {fc:g} Hz must lie between 0 and the Nyquist frequency {0.5 * fs:g} Hz")
    # grid rate: at least 10 samples per cutoff period
    decim = max(1, int(fs / (10.0 * fc)))
    sos = signal.butter(4, fc, fs=fs / decim, output="sos")
    bounds = rec.segment_bounds()
    short = [(a, b) for a, b in bounds if grid_length(b - a, decim) < MIN_SEGMENT_SAMPLES]
    if short:   # bench.resample drops segments too short for the default cutoff's grid
        a, b = short[0]
        raise InputError(f"{name}: a segment of {(b - a) * dt:.3g} s at t = {t[a] - t[0]:.4g} s is too short for "
                         f"the comparison grid of a {fc:g} Hz cutoff (a step of {decim * dt:.3g} s): "
                         f"raise --cutoff or leave it to its default")
    band = velocity_band(q, bounds, dt, fc, rec.load_encoder)
    sos_v = signal.butter(2, band, fs=fs, output="sos")
    use_qd, source = velocity_source(rec, dt, name, sos_v)
    # 'torque_hold: sample' marks torques sampled at t; 'zoh' commands held until the next
    # sample (a digital drive); 'auto' or no key: zoh here, and identify() checks the data
    hold = hold or torque_hold(rec, name)
    if hold == "auto":
        hold = "zoh"
    pieces = [_segment_signals(t[a:b], q[a:b], None if not use_qd else rec.qd[a:b], rec.tau[a:b], dt,
                               sos_v, hold == "zoh")
              for a, b in bounds]
    cat = (lambda k: pieces[0][k]) if len(pieces) == 1 else (lambda k: np.concatenate([p[k] for p in pieces]))
    c = Conditioned(dt=dt, t_full=t, q_full=q, v_mid=cat("v_mid"), q_mid=cat("q_mid"),
                    t_mid=cat("t_mid"), decim=decim, t=np.empty(0),
                    q=np.empty(0), v=np.empty(0), a=np.empty(0), tau=np.empty(0), cutoff=fc,
                    frequency=f_exc, periodic=periodic, sos=sos, segments=bounds,
                    velocity_source=source, tau_mid=cat("tau_mid"), velocity_band=band)
    c.t = c.decimate(t)
    c.q, c.v, c.a, c.tau = c.lowpass(q), c.lowpass(cat("v_raw")), c.lowpass(cat("a_raw")), c.lowpass(cat("tau_raw"))
    c.rest_starts = rest_starts(c, rec.reading.get("standstill_spans", ()))
    return c


# Sliding, for a segment's start after a standstill: the share of the top speed at which
# ``reversals`` counts a direction as reached.
SLIDING = 0.1


def rest_starts(c: Conditioned, spans) -> frozenset:
    """The segments that start before the joint slid again after a long standstill
    (``bench.standstill``): inside it, or after a logger's gap between its end and the first
    sliding; and then the record's first too, whose bristle start is read at its first sample
    as theirs is.  Empty where no standstill was cut."""
    if not spans:
        return frozenset()
    fast = c.t[np.abs(c.v) >= c.sliding_speed]
    later = set()
    for s0, s1 in spans:
        after = fast[fast >= s1]
        slid = after[0] if len(after) else np.inf       # the first sliding after the standstill
        # the record's first counts too: the rest kept before a cut at the record's start is
        # dropped when under 0.12 s (bench.resample.MIN_SEGMENT_TIME), and the motion's
        # segment after the cut is then the first (the linear stage's robot log, seed 5471)
        later |= {k for k, (g, _) in enumerate(c.grid_segments) if s0 <= c.t[g] <= s1 or s1 < c.t[g] < slid}
    return frozenset(later | {0}) if later else frozenset()


def _segment_signals(t, q, qd, tau, dt, sos_v, held) -> dict:
    """Full-rate signals of one evenly sampled segment; interval arrays have one sample less."""
    if qd is not None:
        v_raw = np.asarray(qd, dtype=float)
        a_raw = np.gradient(v_raw, dt) if held else fourth_order_derivative(v_raw, dt)
        v_int = 0.5 * (v_raw[1:] + v_raw[:-1])
    else:
        v_raw = np.gradient(q, dt)
        a_raw = second_difference(q, dt) if held else fourth_order_second_difference(q, dt)
        v_int = np.diff(q) / dt
    return {"v_raw": v_raw, "a_raw": a_raw, "v_mid": filtfilt(sos_v, v_int),
            "q_mid": 0.5 * (q[1:] + q[:-1]), "t_mid": 0.5 * (t[1:] + t[:-1]),
            "tau_raw": held_torque(tau) if held else tau,
            "tau_mid": np.asarray(tau[:-1], float) if held else 0.5 * (tau[1:] + tau[:-1])}


def torque_hold(rec: Record, name: str = "record") -> str:
    hold = str(rec.meta.get("torque_hold", "auto")).lower()
    if hold not in ("zoh", "sample", "auto"):
        raise InputError(f"{name}: torque_hold must be 'zoh', 'sample' or 'auto', not {hold!r}")
    return hold
