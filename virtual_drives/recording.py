"""Records shaped like users' data: how the noise enters, how the logger samples, what the
torque column holds, and what drives the joint.

The joint is simulated on a uniform control grid (``rate``, the command held over each
period, as ``virtual_drives.physics`` does).  What reaches the record is then chosen:

- **process noise** ``d``: a disturbance torque the joint feels and the record does not
  contain (current ripple, load disturbances): white, first-order low-pass (AR(1), a
  correlation time) or 1/f-like (a sum of AR(1) octaves), held over each control period;
- **measurement noise**: white noise on the torque reading only; encoder quantisation;
- **excitation**: the paper's torque sine, two incommensurate torque tones, or PD tracking of
  a smooth reference (the recorded torque is the controller's output; the controller sees the
  quantised encoder);
- **output**: the applied torque (``torque``), or the friction torque a torque-sensing arm
  publishes (``friction``: tau - M q'' from the true states, inertia 0 in the metadata);
  a constant offset and an uncompensated gravity term may be left in that column;
- **logger**: uniform samples at the control rate, or a PC logger's jittered timestamps with
  dropped samples and occasional gaps (true position interpolated at the logger's times,
  the torque as held by the drive at that moment).

Effects from the library are injected as everywhere else (``bench.effects.inject``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.signal import lfilter

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file
from bench import terms
from bench.errors import InputError
from bench.lugre import LuGreParams, interval_to_samples
from bench.records import ENCODER_SIDES, Record
from bench.validate import MAX_RATE, MAX_SAMPLES, in_range
from virtual_drives.joint import Gear, JointSpec, lagged, quantise, sine_torque
from virtual_drives.physics import simulate, simulate_two_mass, substeps_for

EXCITATIONS = ("sine", "two-tone", "pd", "sweep")   # sweep: bench simulate --map (velocity_sweep)
OUTPUTS = ("torque", "friction")
COLOURS = ("white", "lowpass", "pink")
GOLDEN = 0.5 * (1.0 + math.sqrt(5.0))  # the most irrational ratio: two tones never re-align


@dataclass(frozen=True)
class Logger:
    """A PC logger: steps of ``min_step`` plus a gamma-distributed delay (mean ``step``),
    capped at ``max_step``; each sample lost with probability ``drop``; stalls of
    ``gap`` (min, max) seconds at ``gaps_per_minute``.  Timestamps count from ``start`` (a
    logger's clock: e.g. a Unix time)."""
    step: float = 0.004
    min_step: float = 0.001
    max_step: float = 0.013
    drop: float = 0.01
    gaps_per_minute: float = 2.0
    gap: tuple[float, float] = (0.03, 0.3)
    start: float = 0.0

    def times(self, duration: float, rng: np.random.Generator) -> np.ndarray:
        n = int(duration / self.min_step) + 2
        theta = 0.5 * (self.step - self.min_step)            # gamma, shape 2: mean min + 2 theta
        steps = np.minimum(self.min_step + rng.gamma(2.0, theta, n), self.max_step)
        t = np.concatenate(([0.0], np.cumsum(steps)))
        t = t[t < duration]
        keep = rng.random(len(t)) >= self.drop
        keep[0] = True
        n_gaps = rng.poisson(self.gaps_per_minute * duration / 60.0)
        for start, length in zip(rng.uniform(0.05, 0.95, n_gaps) * duration,
                                 rng.uniform(*self.gap, n_gaps)):
            keep &= ~((t > start) & (t < start + length))
        return t[keep]


@dataclass(frozen=True)
class Recording:
    """How a record is made.  Noise magnitudes are in the joint's torque units; ``None``
    takes the joint's own value (torque noise, encoder, excitation)."""
    excitation: str = "sine"
    amplitude: float | None = None        # sine / two-tone: torque amplitude (tone 1)
    frequency: float | None = None        # Hz (tone 1; PD: the reference's first sine)
    tone2: tuple[float, float] | None = None  # (amplitude, frequency) of the second tone
    reference: tuple[tuple[float, float], ...] | None = None  # PD: ((amplitude, Hz), ...)
    bandwidth: float | None = None        # PD: natural frequency [rad/s] (None: from the reference)
    damping: float = 1.0
    rate: float = 1000.0                  # control (and uniform record) rate, Hz
    process_noise: float = 0.0            # std of the disturbance torque
    process_noise_tau: float = 0.0        # its correlation time [s] (lowpass), longest (pink)
    process_noise_colour: str = "white"
    torque_noise: float | None = None     # std of the torque (or friction) reading noise
    torque_resolution: float = 0.0        # the reading's step (a drive's per-mille of rated torque)
    encoder_resolution: float | None = None
    logger: Logger | None = None          # None: uniform samples at ``rate``
    output: str = "torque"
    torque_offset: float = 0.0            # left in the recorded column (the joint never feels it)
    gravity_left: tuple[float, float] = (0.0, 0.0)  # a sin q + b cos q left in the recorded column
    velocity_column: bool = False         # write qd (the true velocity, as a drive reports it)
    encoder: str = "motor"                # a geared joint's encoder: on the motor or the load
    rest: float = 0.0                     # s held still before the motion and after it (a robot holding its pose)
    pause: float = 0.0                    # s held still in the middle of the motion (between two moves)
    speeds: int = 12                      # sweep: constant speeds (velocity_sweep)

    def with_(self, **changes) -> "Recording":
        return replace(self, **changes)

    def check(self) -> None:
        """One line naming the first setting out of range (InputError)."""
        for name, value, choices in (("--excitation", self.excitation, EXCITATIONS),
                                     ("--output-kind", self.output, OUTPUTS),
                                     ("--process-noise-colour", self.process_noise_colour, COLOURS),
                                     ("--encoder", self.encoder, ENCODER_SIDES)):
            if value not in choices:
                raise InputError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
        _number("--rate", self.rate, 1.0, MAX_RATE)
        for name in ("amplitude", "frequency", "bandwidth", "damping"):
            if getattr(self, name) is not None:
                _number("--" + name, getattr(self, name), 0.0, math.inf, low_open=True)
        if self.tone2 is not None:
            _number("--tone2-amplitude", self.tone2[0], 0.0, math.inf, low_open=True)
            _number("--tone2-frequency", self.tone2[1], 0.0, math.inf, low_open=True)
        _number("--process-noise", self.process_noise, 0.0, math.inf)
        _number("--process-noise-tau", self.process_noise_tau, 0.0, 1e4)
        if self.process_noise > 0 and self.process_noise_colour != "white" \
                and not self.process_noise_tau > 1.0 / self.rate:
            raise InputError(f"{self.process_noise_colour} process noise needs --process-noise-tau longer "
                             f"than the control period {1.0 / self.rate:g} s, got {self.process_noise_tau:g}")
        for name in ("torque_noise", "encoder_resolution", "torque_resolution"):
            if getattr(self, name) is not None:
                _number("--" + name.replace("_", "-"), getattr(self, name), 0.0, math.inf)
        _number("--torque-offset", self.torque_offset, -math.inf, math.inf)
        _number("--rest", self.rest, 0.0, 1e5)
        _number("--pause", self.pause, 0.0, 1e5)
        for x in self.gravity_left:
            _number("--gravity-left", x, -math.inf, math.inf)
        if self.logger is not None:
            lg = self.logger
            _number("logger min step", lg.min_step, 0.0, 1.0, low_open=True)
            _number("logger max step", lg.max_step, lg.min_step, 10.0)
            _number("--logger-step", lg.step, lg.min_step, lg.max_step, low_open=True)
            _number("--logger-drop", lg.drop, 0.0, 0.5)
            _number("--logger-gaps", lg.gaps_per_minute, 0.0, 60.0)
            _number("logger gap length", lg.gap[0], 0.0, lg.gap[1], low_open=True)
            _number("--logger-start", lg.start, 0.0, 1e10)


def _number(what: str, x, lo: float, hi: float, low_open: bool = False) -> float:
    """bench.validate.in_range with infinite bounds meaning none."""
    return in_range(x, what, lo if math.isfinite(lo) else None, hi if math.isfinite(hi) else None,
                    lo_open=low_open)


@dataclass
class Truth:
    """What a simulated record knows and a measured one never does (on the control grid)."""
    spec: JointSpec
    recording: Recording
    t: np.ndarray                 # control grid (period starts)
    q: np.ndarray                 # true position, velocity, bristle state at period starts
    v: np.ndarray
    z: np.ndarray
    command: np.ndarray           # torque commanded (what a torque record logs, before noise)
    felt: np.ndarray              # torque the joint felt: lagged command + disturbance
    disturbance: np.ndarray       # process noise
    friction: np.ndarray          # command - M_declared q'' at the grid instants (true states, no
                                  # sensor noise): the friction column before noise and offsets
    ev: np.ndarray = field(default_factory=terms.empty)
    torque_lag: float = 0.0
    declared_inertia: float = 0.0
    friction_params: LuGreParams | None = None
    q_ref: np.ndarray | None = None   # PD reference
    record_index: np.ndarray | None = None  # control period holding each record sample

    def at_record(self, x: np.ndarray, record: Record) -> np.ndarray:
        """A grid signal interpolated at the record's timestamps."""
        start = self.recording.logger.start if self.recording.logger is not None else 0.0
        return np.interp(record.t - start, self.t, x)


def process_noise(n: int, dt: float, std: float, tau: float, colour: str,
                  rng: np.random.Generator) -> np.ndarray:
    """Zero-mean disturbance with standard deviation ``std`` on a grid of step ``dt``."""
    if std <= 0:
        return np.zeros(n)
    if colour == "white":
        return std * rng.standard_normal(n)
    if colour == "lowpass":
        taus = [tau]
    else:  # 1/f between the grid step and tau: equal-variance AR(1) octaves, 4x apart
        taus = list(dt * 4.0 ** np.arange(0, max(1, int(math.log(tau / dt, 4)) + 1)))
    out = np.zeros(n)
    for tc in taus:
        rho = math.exp(-dt / tc)
        e = rng.standard_normal(n)
        # start in the stationary state so the record has no warm-up transient
        out += lfilter([math.sqrt(1.0 - rho * rho)], [1.0, -rho], e, zi=[rho * rng.standard_normal()])[0]
    return std * out / math.sqrt(len(taus))


def centred(spec: JointSpec) -> float:
    lo, hi = spec.position_limits
    return 0.5 * (lo + hi)


def reference_components(spec: JointSpec, rec: Recording) -> tuple[tuple[float, float], ...]:
    """A smooth sum of sines about the workspace centre, faded in over the first period of
    the slowest (it starts at rest at the centre).  Default: two sines, amplitudes 5 : 3,
    frequencies 1 : golden ratio, the first at the joint's sine-test frequency, as large as
    allows a peak speed of 3/4 of the velocity limit, 40 % of the half range and a peak
    acceleration that needs under half the torque limit (beyond the friction)."""
    if rec.reference is not None:
        comps = rec.reference
    else:
        lo, hi = spec.position_limits
        w = 2 * math.pi * (rec.frequency if rec.frequency is not None else spec.excitation[1])
        c_v, c_a = 0.625 + 0.375 * GOLDEN, 0.625 + 0.375 * GOLDEN ** 2  # peak speed, acceleration / (A w^n)
        a_max = max(0.5 * spec.torque_limit - spec.friction.Fs, 0.1 * spec.torque_limit) / spec.inertia
        amp = min(0.75 * spec.velocity_limit / (w * c_v), 0.2 * (hi - lo), a_max / (w * w * c_a))
        comps = ((0.625 * amp, w / (2 * math.pi)), (0.375 * amp, GOLDEN * w / (2 * math.pi)))
    for a, f in comps:
        if not (math.isfinite(a) and math.isfinite(f) and a > 0 and f > 0):
            raise InputError(f"reference sines need positive amplitudes and frequencies, got {a:g} at {f:g} Hz")
    return tuple(comps)


def pd_reference(comps, centre: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """q_ref = centre + fade-in * sum a sin(2 pi f t), and its derivative."""
    s = np.zeros_like(t)
    for a, f in comps:
        s += a * np.sin(2 * math.pi * f * t)
    env = np.clip(t * min(f for _, f in comps), 0.0, 1.0)
    env = env * env * (3.0 - 2.0 * env)
    q_ref = centre + env * s
    return q_ref, np.gradient(q_ref, t)


def pd_gains(spec: JointSpec, rec: Recording, comps) -> tuple[float, float]:
    """Kp = M wn^2, Kd = 2 zeta M wn; wn defaults to 5x the reference's fastest angular
    frequency, at least 60 rad/s (a stiff position loop: friction leaves a few % error)."""
    w_top = 2 * math.pi * max(f for _, f in comps)
    wn = rec.bandwidth if rec.bandwidth is not None else max(60.0, 5.0 * w_top)
    return spec.inertia * wn * wn, 2.0 * rec.damping * spec.inertia * wn


@njit(cache=True)
def _closed_loop(q_ref, v_ref, dist, lag_steps, dt, n_sub, M, p, ev, q0, kp, kd, res, limit,
                 gear_sub=0, M_motor=0.0, M_load=0.0, gap=0.0, w2=0.0, c2=0.0, load=False):
    """PD on the quantised encoder (velocity by backward difference), stepped one control
    period at a time through the shared physics.  A geared joint (``gear_sub`` sub-steps
    and the ``Gear``'s split) steps the motor and the load together; the loop closes on the
    motor's encoder, as a drive's does (closed on the load's through a 6-24 Hz gear spring,
    the condition's PD left every preset's record refused as never sliding: tuning seeds
    1520-1525), and the record holds the side the record's encoder reads (the load's when
    ``load``)."""
    n = q_ref.shape[0]
    cmd, felt = np.empty(n), np.empty(n)
    q, v, z = np.empty(n), np.empty(n), np.empty(n)
    one = np.empty(1)
    qi, vi, zi = q0, 0.0, 0.0
    ql, vl, zl = q0, 0.0, 0.0     # the load's state, when geared
    qm_prev = q0 if res <= 0 else round(q0 / res) * res
    k = int(math.floor(lag_steps))
    frac = lag_steps - k
    for i in range(n):
        q[i], v[i], z[i] = (ql, vl, zi) if load else (qi, vi, zi)
        qm = qi if res <= 0 else round(qi / res) * res
        vm = 0.0 if i == 0 else (qm - qm_prev) / dt
        qm_prev = qm
        u = kp * (q_ref[i] - qm) + kd * (v_ref[i] - vm)
        cmd[i] = min(limit, max(-limit, u))
        # the command the joint feels, lag_steps periods late (linear between periods)
        a = cmd[i - k] if i - k >= 0 else 0.0
        b = cmd[i - k - 1] if i - k - 1 >= 0 else 0.0
        felt[i] = (1.0 - frac) * a + frac * b + dist[i]
        one[0] = felt[i]
        if gear_sub == 0:
            _, _, _, qi, vi, zi = simulate(one, dt, n_sub, M, p, ev, qi, vi, zi, i * dt)
        else:
            _, _, _, _, _, qi, vi, zi, ql, vl, zl = simulate_two_mass(
                one, dt, gear_sub, M_motor, M_load, p, ev, gap, w2, c2, qi, vi, zi, ql, vl, i * dt, zl)
    return cmd, felt, q, v, z, (ql if load else qi), (vl if load else vi)


def open_loop_torque(spec: JointSpec, rec: Recording, t: np.ndarray) -> np.ndarray:
    """The open-loop torque of a sine or two-tone recording at times t."""
    a = rec.amplitude if rec.amplitude is not None else spec.excitation[0]
    f = rec.frequency if rec.frequency is not None else spec.excitation[1]
    if rec.excitation == "sine":
        return sine_torque(a, f, t)
    # default: the sine's peak split 65 : 35 between f and golden-ratio f, so the joint
    # stays inside the speeds and travel of its sine test
    if rec.tone2 is None:
        a, (a2, f2) = 0.65 * a, (0.35 * a, GOLDEN * f)
    else:
        a2, f2 = rec.tone2
    # both tones start at their negative peak, like the sine: the motion stays centred
    return sine_torque(a, f, t) + sine_torque(a2, f2, t, ramp_cycles=0.05 * f2 / f)


def motion_envelope(t: np.ndarray, rest: float, duration: float, f: float,
                    pause: float = 0.0) -> np.ndarray:
    """0 for ``rest`` seconds at each end of the record and ``pause`` seconds in its middle,
    smoothstepping to 1 over a period of the slowest frequency ``f`` around each."""
    up = np.clip((t - rest) * f, 0.0, 1.0)
    down = np.clip((duration - rest - t) * f, 0.0, 1.0)
    env = np.minimum(up, down)
    if pause > 0:
        env = np.minimum(env, np.clip((np.abs(t - 0.5 * duration) - 0.5 * pause) * f, 0.0, 1.0))
    return env * env * (3.0 - 2.0 * env)


def _slowest(spec: JointSpec, rec: Recording) -> float:
    if rec.excitation == "pd":
        return min(f for _, f in reference_components(spec, rec))
    return rec.frequency if rec.frequency is not None else spec.excitation[1]


def make(spec: JointSpec, rec: Recording, duration: float, seed: int = 0,
         extra: np.ndarray | None = None, torque_lag: float = 0.0,
         declared_inertia: float | None = None) -> tuple[Record, Truth]:
    """Simulate ``spec`` as ``rec`` describes; returns the record and the truth."""
    rec.check()
    _number("--duration", duration, 10.0 / rec.rate, MAX_SAMPLES / rec.rate)
    if spec.joint_type != "revolute" and any(rec.gravity_left):
        raise InputError("--gravity-left applies to revolute joints only")
    rng = np.random.default_rng(seed)
    dt = 1.0 / rec.rate
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    still = rec.rest > 0 or rec.pause > 0
    if still and duration - 2 * rec.rest - rec.pause < (8.0 if rec.pause > 0 else 4.0) / _slowest(spec, rec):
        raise InputError(f"--rest {rec.rest:g} s before and after and --pause {rec.pause:g} s leave under two "
                         f"motion periods (each side of a pause) of the {duration:g} s record: lengthen "
                         f"--duration or shorten --rest / --pause")
    f = spec.friction
    M = spec.inertia
    ev = terms.empty() if extra is None else terms.full(extra)
    if rec.encoder == "load" and not terms.two_mass(ev):
        raise InputError("--encoder load needs a geared joint: inject backlash or joint_flexibility "
                         "(a rigid joint's motor and load are one)")
    n_sub = substeps_for(dt, M, f.sigma0, f.sigma1, f.sigma2)
    dist = process_noise(n, dt, rec.process_noise, rec.process_noise_tau, rec.process_noise_colour, rng)
    res = spec.encoder_resolution if rec.encoder_resolution is None else rec.encoder_resolution
    q_ref = None
    if rec.excitation == "sweep":   # constant speeds under the PD loop, its length its own
        from virtual_drives import velocity_sweep
        if still:
            raise InputError("--rest and --pause apply to sine, two-tone and pd: a sweep holds at each pass's end")
        q_ref, v_ref = velocity_sweep.reference(spec, rec.speeds, dt)
        q_ref = np.concatenate([q_ref, np.full(max(0, n - len(q_ref)), q_ref[-1])])[:n]
        v_ref = np.concatenate([v_ref, np.zeros(max(0, n - len(v_ref)))])[:n]
        comps = velocity_sweep.NO_SINES
    elif rec.excitation == "pd":
        comps = reference_components(spec, rec)
        q_ref, v_ref = pd_reference(comps, centred(spec), t)
        if still:   # the reference holds the start pose, then fades in; it fades out to it
            env = motion_envelope(t, rec.rest, duration, min(f for _, f in comps), rec.pause)
            q_ref = centred(spec) + env * (pd_reference(comps, 0.0, t - rec.rest)[0])
            v_ref = np.gradient(q_ref, t)
    if q_ref is not None:
        kp, kd = pd_gains(spec, rec, comps)
        gear = Gear.of(spec, ev, dt)
        split = () if gear is None else (gear.n_sub, gear.M_motor, gear.M_load, gear.gap, gear.w2, gear.c2,
                                         rec.encoder == "load")
        cmd, felt, q, v, z, q_end, v_end = _closed_loop(
            q_ref, v_ref, dist, torque_lag / dt, dt, n_sub, M, f.vector(), ev,
            centred(spec), kp, kd, res, spec.torque_limit, *split)
    else:
        cmd = open_loop_torque(spec, rec, t - rec.rest)
        if still:   # no torque while the joint rests
            cmd = cmd * motion_envelope(t, rec.rest, duration, _slowest(spec, rec), rec.pause)
        felt = lagged(t, cmd, torque_lag) + dist
        gear = Gear.of(spec, ev, dt)
        if gear is None:
            q, v, z, q_end, v_end, _ = simulate(felt, dt, n_sub, M, f.vector(), ev, centred(spec), 0.0, 0.0, 0.0)
        else:   # a geared joint (backlash, a gear spring): the encoder reads the motor or the load
            out = simulate_two_mass(
                felt, dt, gear.n_sub, gear.M_motor, gear.M_load, f.vector(), ev, gear.gap, gear.w2,
                gear.c2, centred(spec), 0.0, 0.0, centred(spec), 0.0, 0.0)
            z = out[2]
            q, v, q_end, v_end = (out[3], out[4], out[8], out[9]) if rec.encoder == "load" else \
                                 (out[0], out[1], out[5], out[6])
    declared = M if declared_inertia is None else declared_inertia
    # tau - M q'' per period from the true states (the integrator's momentum balance makes
    # this the exact mean friction over the period), then at the instants between periods
    acc = np.diff(np.append(v, v_end)) / dt
    friction = interval_to_samples(cmd - declared * acc)[:n]

    if rec.logger is None:
        idx = np.arange(n)
        t_rec, q_rec, v_rec = t, q, v
        column = cmd if rec.output == "torque" else friction
    else:
        t_rec = rec.logger.times(t[-1], rng)
        idx = np.minimum((t_rec / dt).astype(np.int64), n - 1)
        q_all, v_all = np.append(q, q_end), np.append(v, v_end)
        q_rec = _hermite(t_rec, dt, q_all, v_all)
        v_rec = np.interp(t_rec, np.append(t, n * dt), v_all)
        # the torque as the drive held it at that moment; a friction sensor samples
        column = cmd[idx] if rec.output == "torque" else np.interp(t_rec, t, friction)
    q_meas = quantise(q_rec, res)
    sigma = spec.torque_noise if rec.torque_noise is None else rec.torque_noise
    column = column + rec.torque_offset + sigma * rng.standard_normal(len(t_rec))
    a, b = rec.gravity_left
    if a or b:
        column = column + a * np.sin(q_meas) + b * np.cos(q_meas)
    column = quantise(column, rec.torque_resolution)   # what the drive's register holds
    meta = {
        "inertia": 0.0 if rec.output == "friction" else declared,
        "joint_type": spec.joint_type,
        "position_unit": spec.position_unit,
        "torque_unit": spec.torque_unit,
        "torque_hold": "zoh" if rec.logger is None and rec.output == "torque" else "sample",
        "joint": spec.name,
        "source": "virtual",
        "excitation": rec.excitation,
        "seed": seed,
    }
    if rec.output == "friction":
        meta["torque_column"] = "friction (tau - M q'')"
    if terms.two_mass(ev):
        meta["encoder"] = rec.encoder
    if rec.logger is not None:
        t_rec = t_rec + rec.logger.start
    record = Record(t=t_rec, tau=column, q=q_meas, qd=v_rec.copy() if rec.velocity_column else None,
                    meta=meta)
    truth = Truth(spec=spec, recording=rec, t=t, q=q, v=v, z=z, command=cmd, felt=felt,
                  disturbance=dist, friction=friction, ev=ev, torque_lag=torque_lag,
                  declared_inertia=declared, friction_params=f, q_ref=q_ref, record_index=idx)
    return record, truth


def _hermite(tq: np.ndarray, dt: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation of position from its values and slopes on the grid."""
    i = np.minimum((tq / dt).astype(np.int64), len(q) - 2)
    s = tq / dt - i
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    return h00 * q[i] + h10 * dt * v[i] + h01 * q[i + 1] + h11 * dt * v[i + 1]
