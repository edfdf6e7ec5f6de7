"""A joint simulator written apart from the project's physics, for tests that must not pass
only on our own generator.

Nothing here comes from ``virtual_drives`` or ``bench.lugre``/``bench.terms``: the state
(motor angle and speed, bristle deflection, load angle and speed) is integrated by classic
fourth-order Runge-Kutta at a fine fixed step, the gear's dead zone and spring written out
directly, the disturbance an Ornstein-Uhlenbeck process inside the integration, the record
sampled the way a logger would (jittered instants, lost samples, a quantised encoder, a noisy
torque reading).  Conventions differ on purpose where physics allows it: the contact between
the teeth is an underdamped spring, not the virtual joint's critically damped one, and the
friction may sit on the motor, on the load, or be shared.

Only ``LuGreParams`` and ``JointSpec`` (plain data) and ``Record`` (the file format) are
borrowed."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bench.records import Record


@njit(cache=True)
def _rates(x, u, d, P, t):
    """d/dt of (q_m, v_m, z_m, q_l, v_l, z_l, applied torque).  P: Fc, Fs, alpha, sigma0,
    sigma1, sigma2, J_m, J_l, half gap, stiffness, damping, geared, share of friction on the
    load; then the direct joint's own physics: m g l, its angle offset, current-loop time
    constant, detent amplitude, detent pitch, its second harmonic, bearing ripple (relative),
    its pitch, viscous warm-up (relative) and its time constant, constant torque, Coulomb
    level going negative (relative), a sudden change of both levels (relative) and its time,
    Coulomb/Stribeck levels growing with the transmitted torque (mu: added level per |torque|),
    a static map's regularising speed, the bristle damping's fade speed, Stribeck's exponent,
    1 for Simscape's map in place of the static one, frictional lag's time constant (the
    Stribeck curve sees the velocity through a first-order lag: Hess & Soom, Armstrong's
    seven-parameter model), and static friction's rise with dwell time (relative), its growth
    and fade times.  x[7]: the lagged velocity; x[8]: the dwell's share of its full rise."""
    Fc, Fs, al, s0, s1, s2 = P[0], P[1], P[2], P[3], P[4], P[5]
    Jm, Jl, gap, k, c, geared, share = P[6], P[7], P[8], P[9], P[10], P[11], P[12]
    mgl, q0, lag, cog, cog_p, cog_h2 = P[13], P[14], P[15], P[16], P[17], P[18]
    rip, rip_p, warm, warm_t, const, asym = P[19], P[20], P[21], P[22], P[23], P[24]
    jump, jump_t, load_mu, static_eps, s1_vd, dexp = P[25], P[26], P[27], P[28], P[29], P[30]
    simscape, f_lag, rise, rise_t, fade_t = P[31], P[32], P[33], P[34], P[35]
    out = np.zeros(9)
    vm, vl = x[1], x[4]
    # the drive's current loop: a first-order lag between the command and the torque felt
    if lag > 0:
        out[6] = (u - x[6]) / lag
        u = x[6]
    # torques the recorded command does not hold: a link's weight, detents, a constant
    ext = const - mgl * math.sin(x[0] + q0)
    if cog != 0.0:
        ph = 2.0 * math.pi * x[0] / cog_p
        ext -= cog * (math.sin(ph) + cog_h2 * math.sin(2.0 * ph + 0.7))
    # LuGre on the motor's velocity; the bearing's ripple scales both levels, warming thins
    # the oil (viscous part only), and the Coulomb level may differ going negative
    scale = 1.0 + rip * math.cos(2.0 * math.pi * x[0] / rip_p) if rip != 0.0 else 1.0
    if asym != 0.0 and vm < 0:
        scale *= 1.0 + asym
    if jump != 0.0 and t >= jump_t:
        scale *= 1.0 + jump
    if load_mu != 0.0:   # the mesh's friction grows with the torque it carries
        scale *= 1.0 + load_mu * abs(u) / Fc
    visc = s2 * (1.0 - warm * (1.0 - math.exp(-t / warm_t))) if warm != 0.0 else s2
    # frictional lag: the Stribeck level follows the velocity a time constant late
    v_s = vm
    if f_lag > 0.0:
        out[7] = (vm - x[7]) / f_lag
        v_s = x[7]
    # static friction rising with dwell time: grows while stuck (|v| well under the Stribeck
    # speed), fades once sliding; smooth in v so the integrator sees no switch
    fs_scale = 1.0
    if rise > 0.0:
        stuck = math.exp(-(al * vm / 0.05) ** 2)
        out[8] = stuck * (1.0 - x[8]) / rise_t - (1.0 - stuck) * x[8] / fade_t
        fs_scale = 1.0 + rise * x[8]
    # Stribeck's dip, exp(-|v/vs|^dexp): many simulators write it Gaussian (dexp = 2, Armstrong)
    g = scale * (Fc + (Fs * fs_scale - Fc) * math.exp(-abs(al * v_s) ** dexp))
    if static_eps > 0.0 and simscape != 0.0:
        # Simscape's Rotational Friction: sqrt(2e) (Fbrk - Fc) exp(-(v/v_St)^2) v/v_St
        # + Fc tanh(v/v_Coul) + f v, with v_St = sqrt(2) v_brk and v_Coul = v_brk / 10; here
        # Fbrk = Fs, v_brk = 10 static_eps; it peaks at Fs at v_brk and starts from Fc, not Fs
        v_st = math.sqrt(2.0) * 10.0 * static_eps
        Fm = scale * (math.sqrt(2.0 * math.e) * (Fs - Fc) * math.exp(-(vm / v_st) ** 2) * vm / v_st
                      + Fc * math.tanh(vm / static_eps)) + visc * vm
    elif static_eps > 0.0:   # a static map, regularised: no bristles, the joint creeps in stick
        Fm = g * math.tanh(vm / static_eps) + visc * vm
    else:
        zdm = vm - s0 * abs(vm) / g * x[2]
        # the bristle damping may fade with speed, Canudas de Wit's variant for passivity
        s1m = s1 * math.exp(-(vm / s1_vd) ** 2) if s1_vd > 0.0 else s1
        Fm = s0 * x[2] + s1m * zdm + visc * vm
        out[2] = zdm
    if geared == 0.0:
        out[0] = vm
        out[1] = (u + d + ext - Fm) / (Jm + Jl)
        return out
    # ... and on the load's
    g = Fc + (Fs - Fc) * math.exp(-abs(al * vl) ** dexp)
    zdl = vl - s0 * abs(vl) / g * x[5]
    Fl = s0 * x[5] + s1 * zdl + s2 * vl
    out[5] = zdl
    e = x[0] - x[3]
    if e > gap:
        T = k * (e - gap) + c * (vm - vl)
    elif e < -gap:
        T = k * (e + gap) + c * (vm - vl)
    else:
        T = 0.0
    out[0] = vm
    out[1] = (u + d + ext - (1.0 - share) * Fm - T) / Jm
    out[3] = vl
    out[4] = (T - share * Fl) / Jl
    return out


@njit(cache=True)
def _run(u, n_sub, h, P, dist_std, dist_tau, seed, x0, pd, ref):
    """Integrate; ``pd`` = (kp, kd, encoder resolution, ki): with kp > 0 the torque of each
    period is a PID controller's on the (quantised) motor encoder and its finite-difference
    velocity, tracking ``ref`` (position, velocity per period), written back into ``u`` (what
    a log holds)."""
    np.random.seed(seed)
    n = u.shape[0]
    path = np.empty((n * n_sub + 1, 2))
    x = x0.copy()
    path[0, 0], path[0, 1] = x[0], x[3]
    a = math.exp(-h / dist_tau) if dist_tau > 0 else 0.0
    d = 0.0
    kp, kd, res, ki = pd[0], pd[1], pd[2], pd[3]
    period = n_sub * h
    q_prev = 0.0
    e_int = 0.0
    for i in range(n):
        if kp > 0:
            qe = math.floor(x[0] / res + 0.5) * res if res > 0 else x[0]
            ve = (qe - q_prev) / period if i > 0 else 0.0
            q_prev = qe
            e_int += (ref[i, 0] - qe) * period
            u[i] = kp * (ref[i, 0] - qe) + kd * (ref[i, 1] - ve) + ki * e_int
        for j in range(n_sub):
            if dist_std > 0:
                d = a * d + dist_std * math.sqrt(1.0 - a * a) * np.random.randn()
            t = (i * n_sub + j) * h
            k1 = _rates(x, u[i], d, P, t)
            k2 = _rates(x + 0.5 * h * k1, u[i], d, P, t + 0.5 * h)
            k3 = _rates(x + 0.5 * h * k2, u[i], d, P, t + 0.5 * h)
            k4 = _rates(x + h * k3, u[i], d, P, t + h)
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            m = i * n_sub + j + 1
            path[m, 0], path[m, 1] = x[0], x[3]
    return path


def independent_record(spec, duration: float = 20.0, seed: int = 0, *, torque=None,
                       dt: float = 1e-3, n_sub: int = 40, backlash: float = 0.0,
                       contact_hz: float = 60.0, contact_damping: float = 0.15,
                       flex_hz: float = 0.0, flex_damping: float = 0.05, load_share: float = 0.5,
                       friction_on_load: float = 0.0, disturbance: float = 0.0,
                       disturbance_tau: float = 0.01, torque_noise: float | None = None,
                       resolution: float | None = None, jitter: float = 0.0, drop: float = 0.0,
                       encoder: str = "motor", physics: dict | None = None,
                       pd: tuple[float, ...] | None = None,
                       reference=None) -> tuple[Record, np.ndarray]:
    """A record of ``spec``'s joint under its sine test (or ``torque``, held per ``dt``):
    ``backlash`` (total width; the teeth meet through a ``contact_hz`` spring of damping ratio
    ``contact_damping``) and/or a gear spring ``flex_hz``; ``load_share`` of the inertia beyond
    the gear; ``friction_on_load`` of the friction there.  ``disturbance``: std of a torque the
    joint feels and the record does not hold (correlation time ``disturbance_tau``).  Sampled
    at 1/dt with ``jitter`` (fraction of dt) and ``drop`` (lost samples).  Returns the record
    and the fine path (motor, load angle) every dt / n_sub.

    ``pd`` = (bandwidth Hz, reference amplitude): closed loop instead, the joint tracking
    amplitude sin(2 pi f t) at the sine test's frequency f under a PD controller of that
    bandwidth (kp = M w^2, kd = 1.4 M w, on the quantised motor encoder), the log holding the
    controller's torque; a third entry, the integral's corner (Hz, ki = kp 2 pi corner), makes
    it a PID, as most robot joints run.  ``reference`` (positions per ``dt``; with ``pd``, whose
    amplitude it replaces) is tracked instead of the sine: point-to-point moves with dwells, say.

    ``physics`` adds, in this simulator's own conventions (not the effect library's): ``mgl``
    and ``q0`` (a link's weight, -mgl sin(q + q0)), ``lag`` (a first-order current loop, s),
    ``detent``/``detent_pitch``/``detent_h2`` (two harmonics), ``ripple``/``ripple_pitch``
    (both friction levels scaled by 1 + ripple cos), ``warm``/``warm_tau`` (the viscous
    coefficient falls by ``warm`` as the joint warms), ``constant`` (a torque the record does
    not hold), ``asym`` (the friction levels going negative scaled by 1 + asym) and
    ``jump``/``jump_t`` (both levels change by ``jump`` at ``jump_t``: outside the library) and
    ``load_mu`` (the levels grow by ``load_mu`` |torque|, a loaded mesh: outside the library);
    ``static_eps`` replaces the motor's LuGre by a static map, s(v) tanh(v / eps) + sigma2 v,
    as many simulators write friction: no presliding spring, the joint creeps in stick;
    ``sigma1_vd`` fades the motor's bristle damping with speed, sigma1 exp(-(v / vd)^2);
    ``stribeck_delta`` shapes Stribeck's dip, exp(-|alpha v|^delta) (2: Armstrong's Gaussian);
    ``simscape`` (with ``static_eps``) writes the static map as Simscape's Rotational Friction
    block does: breakaway Fs at v_brk = 10 static_eps, Fc at rest and at speed.  Outside the
    library too: ``fric_lag`` (s), frictional lag, the Stribeck level following the velocity
    through a first-order lag; ``dwell_rise`` (relative, with ``dwell_tau``, ``dwell_fade``, s),
    static friction Fs (1 + dwell_rise w), w growing towards 1 while the joint sticks and
    fading while it slides."""
    ph = dict(physics or {})
    unknown = set(ph) - {"mgl", "q0", "lag", "detent", "detent_pitch", "detent_h2", "ripple",
                         "ripple_pitch", "warm", "warm_tau", "constant", "asym", "jump", "jump_t", "load_mu",
                         "static_eps", "sigma1_vd", "stribeck_delta", "simscape", "fric_lag",
                         "dwell_rise", "dwell_tau", "dwell_fade"}
    assert not unknown, unknown
    rng = np.random.default_rng([seed, 77])
    f = spec.friction
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    if torque is None:
        A, fr = spec.excitation
        torque = A * np.sin(2.0 * np.pi * fr * t)
    u = np.ascontiguousarray(torque, dtype=float)
    geared = backlash > 0 or flex_hz > 0
    Jl = load_share * spec.inertia if geared else 0.0
    Jm = spec.inertia - Jl
    hz, zeta = (flex_hz, flex_damping) if flex_hz > 0 else (contact_hz, contact_damping)
    w = 2.0 * math.pi * hz
    P = np.array([f.Fc, f.Fs, f.alpha, f.sigma0, f.sigma1, f.sigma2, Jm, Jl, 0.5 * backlash,
                  Jl * w * w, 2.0 * zeta * w * Jl, 1.0 if geared else 0.0, friction_on_load,
                  ph.get("mgl", 0.0), ph.get("q0", 0.0), ph.get("lag", 0.0),
                  ph.get("detent", 0.0), ph.get("detent_pitch", 1.0), ph.get("detent_h2", 0.0),
                  ph.get("ripple", 0.0), ph.get("ripple_pitch", 1.0), ph.get("warm", 0.0),
                  ph.get("warm_tau", 1.0), ph.get("constant", 0.0), ph.get("asym", 0.0),
                  ph.get("jump", 0.0), ph.get("jump_t", 0.0), ph.get("load_mu", 0.0),
                  ph.get("static_eps", 0.0), ph.get("sigma1_vd", 0.0), ph.get("stribeck_delta", 1.0),
                  1.0 if ph.get("simscape") else 0.0, ph.get("fric_lag", 0.0),
                  ph.get("dwell_rise", 0.0), ph.get("dwell_tau", 1.0), ph.get("dwell_fade", 0.05)])
    gains = np.zeros(4)
    ref = np.zeros((n, 2))
    if pd is not None:
        wc = 2.0 * math.pi * pd[0]
        kp = spec.inertia * wc * wc
        corner = pd[2] if len(pd) > 2 else 0.0
        gains[:] = (kp, 1.4 * spec.inertia * wc, spec.encoder_resolution,
                    kp * 2.0 * math.pi * corner)
        if reference is None:
            w = 2.0 * math.pi * spec.excitation[1]
            ref[:, 0], ref[:, 1] = pd[1] * np.sin(w * t), pd[1] * w * np.cos(w * t)
        else:
            ref[:, 0] = np.asarray(reference, dtype=float)[:n]
            ref[:, 1] = np.gradient(ref[:, 0], dt)
        u = np.zeros(n)
    path = _run(u, n_sub, dt / n_sub, P, disturbance, disturbance_tau, int(seed), np.zeros(9),
                gains, ref)
    fine_t = np.arange(n * n_sub + 1) * (dt / n_sub)
    ts = np.sort(t + jitter * dt * rng.uniform(-0.5, 0.5, n))
    ts[0] = 0.0
    keep = rng.uniform(size=n) >= drop
    keep[:5] = True
    ts = ts[keep]
    q = np.interp(ts, fine_t, path[:, 1 if encoder == "load" else 0])
    res = spec.encoder_resolution if resolution is None else resolution
    if res > 0:
        q = np.floor(q / res + 0.5) * res
    sigma = spec.torque_noise if torque_noise is None else torque_noise
    tau = u[np.minimum((ts / dt).astype(int), n - 1)] + sigma * rng.standard_normal(len(ts))
    # the drive holds its command on its own clock; sampled at jittered instants the column
    # is no longer held between the record's samples, so no ``torque_hold: zoh`` then
    meta = {"inertia": spec.inertia, "joint_type": spec.joint_type, "source": "independent simulator"}
    if not (jitter or drop):
        meta["torque_hold"] = "zoh"
    if encoder == "load":
        meta["encoder"] = "load"
    return Record(t=ts, tau=tau, q=q, meta=meta), path


def two_tones(spec, duration: float = 20.0, dt: float = 1e-3, split: tuple[float, float] = (0.65, 0.35),
              ratio: float = 1.618) -> np.ndarray:
    """Two torque tones (held per ``dt``): ``split`` of the sine test's amplitude at its
    frequency and at ``ratio`` times it (golden ratio: incommensurate), the second shifted 1 rad."""
    A, fr = spec.excitation
    t = np.arange(int(round(duration / dt))) * dt
    return A * (split[0] * np.sin(2 * np.pi * fr * t) + split[1] * np.sin(2 * np.pi * ratio * fr * t + 1.0))


def point_to_point(travel: float, half_period: float, duration: float, rng, dt: float = 1e-3,
                   dwell: tuple[float, float] = (0.3, 1.5), homing: float = 0.0,
                   moves: tuple[float, float] = (0.6, 1.4)) -> np.ndarray:
    """A robot's reference (positions per ``dt``) of the shape real joint logs have: minimum-jerk
    moves of ``moves`` half periods between random targets within ``travel`` (mostly
    alternating sides), each after a dwell of ``dwell`` half periods.  ``homing`` > 0: the log
    opens with a move of ``homing`` half periods from 0 to the travel's lower end."""
    n = int(round(duration / dt))
    ref = np.zeros(n)
    pos, side, k = -0.5 * travel * rng.uniform(0.3, 1.0), 1.0, 0

    def move(k, a, b, m):
        s = np.arange(1, m + 1) / m
        seg = a + (b - a) * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
        ref[k:k + m] = seg[:n - k]
        return k + m

    if homing > 0:
        pos = -0.5 * travel
        k = move(0, 0.0, pos, int(homing * half_period / dt))
    while k < n:
        d = int(rng.uniform(*dwell) * half_period / dt)
        ref[k:k + d] = pos
        k += d
        if k >= n:
            break
        target = side * 0.5 * travel * rng.uniform(0.3, 1.0)
        k = move(k, pos, target, int(rng.uniform(*moves) * half_period / dt))
        pos = target
        side = -side if rng.uniform() < 0.85 else side
    return ref


def velocity_steps(travel: float, levels, dt: float = 1e-3, ramp: float = 0.15,
                   dwell: float = 0.3) -> np.ndarray:
    """The industrial friction-velocity map experiment's reference (positions per ``dt``):
    back and forth over ``travel`` once at each speed of ``levels`` (slowest first), at constant
    speed between smooth ramps of ``ramp`` s, holding ``dwell`` s at each end."""
    def shape(x):       # a raised-cosine ramp from 0 to 1
        return 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))

    out, pos = [np.full(int(dwell / dt), -0.5 * travel)], -0.5 * travel
    for v in levels:
        for d in (1.0, -1.0):
            T = travel / v + ramp
            s = np.arange(1, int(T / dt) + 1) * dt
            speed = v * np.minimum(shape(s / ramp), shape((T - s) / ramp))
            seg = pos + d * np.cumsum(speed) * dt
            out += [seg, np.full(int(dwell / dt), seg[-1])]
            pos = seg[-1]
    return np.concatenate(out)


def fourier_trajectory(travel: float, top_speed: float, duration: float, rng, harmonics: int = 5,
                       dt: float = 1e-3) -> tuple[np.ndarray, float]:
    """A robot-identification excitation trajectory (Swevers, Ganseman et al. 1997, the
    standard for rigid-body identification): a finite Fourier series of ``harmonics``
    harmonics with random coefficients, periodic, spanning ``travel`` about 0, its base
    frequency set so that the top speed is ``top_speed``; faded in from rest over a quarter
    period.  Returns (positions per ``dt``, base frequency Hz)."""
    k = np.arange(1, harmonics + 1)
    a, b = rng.uniform(-1.0, 1.0, harmonics) / k, rng.uniform(-1.0, 1.0, harmonics) / k

    def series(phase):          # the position at base-frequency phases ``phase`` (cycles)
        ph = 2.0 * np.pi * np.outer(phase, k)
        return np.sin(ph) @ a - np.cos(ph) @ b

    one = series(np.arange(0.0, 1.0, 1e-4))          # one period at f0 = 1 Hz
    centre, scale = 0.5 * (one.max() + one.min()), travel / np.ptp(one)
    f0 = top_speed / (scale * np.abs(np.gradient(one, 1e-4)).max())
    t = np.arange(int(round(duration / dt))) * dt
    fade = 0.5 - 0.5 * np.cos(np.pi * np.clip(4.0 * f0 * t, 0.0, 1.0))
    return fade * scale * (series(f0 * t) - centre), float(f0)
