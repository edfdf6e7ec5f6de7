"""Physical terms that extend the LuGre joint: one compiled definition used by the virtual
drives (to inject an effect) and by the effect library (to fit it).

A joint's extra physics is a flat float vector ``ev`` with the slots below.  Position-periodic
terms are written as sine/cosine coefficients so that, for a known pitch, they are linear in
their parameters (a fit can solve them by least squares).

    additive torque   offset + a sin q + b cos q + sum_k (c_k sin(k w q) + d_k cos(k w q))
    level multiplier  (1 + asym sgn v) (1 + sum_k (e_k sin(k w' q) + f_k cos(k w' q)))
                      (1 + c_th (1 - exp(-t / tau_th)))        scales s(v): Fc and Fs
    viscous multiplier (1 + c_v (1 - exp(-t / tau_th)))        scales sigma2
    damping multiplier 1 - g (1 - exp(-(v / v_d)^2))           scales sigma1 (``damping``)
with w = 2 pi / cogging pitch and w' = 2 pi / friction pitch.

The joint's mechanics beyond a rigid body are slots too (zero = rigid, today's path):
    BACKLASH    total width of the dead zone between motor and load
    FLEX_FREQ   locked-rotor resonance of the gear's spring [Hz] (0: a stiff contact, see below)
    FLEX_DAMP   its damping ratio
    LOAD_FRAC   share of the joint inertia on the load side of the gear
    LOAD_FRICTION  share of the joint's friction on the load side (output bearing, gear
                mesh): the motor carries (1 - share) F(v_motor), the load share F(v_load),
                the same LuGre law on each side's own velocity and bristle state
The coupling (``coupling``, ``load_step``) is written once here: the virtual drives
integrate the two-mass joint with it, and the backlash / flexibility effects run the same
load recursion along the measured motor trajectory.
"""
from __future__ import annotations

import math

import numpy as np

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file
from bench.lugre import bristle_step, stribeck_level

OFFSET = 0
GRAV_SIN, GRAV_COS = 1, 2
COG_PITCH = 3
COG_COEF = 4          # 3 harmonics x (sin, cos): slots 4..9
COG_HARMONICS = 3
PF_PITCH = 10
PF_COEF = 11          # 2 harmonics x (sin, cos): slots 11..14
PF_HARMONICS = 2
ASYM = 15
THERM_GAIN, THERM_TAU = 16, 17
BACKLASH, FLEX_FREQ, FLEX_DAMP, LOAD_FRAC, LOAD_FRICTION = 18, 19, 20, 21, 22
THERM_VISC = 23       # the viscous part warms with its own gain (the oil thins)
# The bristles' damping fading with speed: sigma1 (1 - g (1 - exp(-(v / vd)^2))); g = 1 is
# Canudas de Wit et al.'s sigma1(v) = sigma1 exp(-(v / vd)^2), written for passivity
DAMP_GAIN, DAMP_VD = 24, 25
SIZE = 26

# Backlash without a declared flexibility: the teeth meet through a stiff, well damped
# spring-damper rather than an impact law.  An impact needs event detection inside a step,
# which the joint's one implicit step does not have; a contact whose locked-rotor frequency
# lies above every comparison filter (<= 50 Hz, bench.signals.choose_cutoff) and that is
# critically damped acts as an inelastic impact in the band the fit sees: the teeth close
# without a rebound.  The damper acts while the flanks overlap, in both directions (the oil
# film between them resists parting as it resists closing); clipping it at zero force
# instead gives a 5-15 % rebound that sets a frictionless load bouncing between the flanks.
# Both the virtual joint and the fit use these same numbers.
CONTACT_HZ = 100.0
CONTACT_DAMPING = 1.0


def full(ev) -> np.ndarray:
    """``ev`` as a float vector of SIZE slots (older vectors lack the mechanics slots)."""
    ev = np.asarray(ev, dtype=float)
    if ev.shape[0] >= SIZE:
        return np.array(ev[:SIZE], dtype=float)
    out = empty()
    out[:ev.shape[0]] = ev
    return out


def two_mass(ev) -> bool:
    """Does ``ev`` describe a joint with a motor and a load (backlash or a gear spring)?"""
    return ev.shape[0] > FLEX_FREQ and (ev[BACKLASH] > 0.0 or ev[FLEX_FREQ] > 0.0)


def coupling(ev) -> tuple[float, float, float]:
    """(half gap, stiffness / M_load, damping / M_load) of the gear between motor and load:
    a spring of locked-rotor angular frequency w has k / M_load = w^2 and
    c / M_load = 2 zeta w."""
    if ev[FLEX_FREQ] > 0.0:
        f, zeta = ev[FLEX_FREQ], ev[FLEX_DAMP]
    else:
        f, zeta = CONTACT_HZ, CONTACT_DAMPING
    w = 2.0 * np.pi * f
    return 0.5 * max(ev[BACKLASH], 0.0), w * w, 2.0 * zeta * w


def empty() -> np.ndarray:
    return np.zeros(SIZE)


@njit(cache=True)
def fourier(q, pitch, ev, first, harmonics):
    w = 2.0 * np.pi / pitch
    out = 0.0 * q
    for k in range(harmonics):
        a = ev[first + 2 * k]
        b = ev[first + 2 * k + 1]
        if a != 0.0 or b != 0.0:
            out = out + a * np.sin((k + 1) * w * q) + b * np.cos((k + 1) * w * q)
    return out


@njit(cache=True)
def effect_terms(q, v, t, ev):
    """(additive torque, level multiplier, viscous multiplier) at position q, velocity v,
    time t.  Works on scalars (the simulator's inner loop) and on arrays (the fit)."""
    add = ev[OFFSET] + 0.0 * q
    if ev[GRAV_SIN] != 0.0 or ev[GRAV_COS] != 0.0:
        add = add + ev[GRAV_SIN] * np.sin(q) + ev[GRAV_COS] * np.cos(q)
    if ev[COG_PITCH] > 0.0:
        add = add + fourier(q, ev[COG_PITCH], ev, COG_COEF, COG_HARMONICS)
    level = 1.0 + 0.0 * q
    if ev[ASYM] != 0.0:
        level = level * (1.0 + ev[ASYM] * np.sign(v))
    if ev[PF_PITCH] > 0.0:
        level = level * (1.0 + fourier(q, ev[PF_PITCH], ev, PF_COEF, PF_HARMONICS))
    visc = 1.0 + 0.0 * t
    if (ev[THERM_GAIN] != 0.0 or ev[THERM_VISC] != 0.0) and ev[THERM_TAU] > 0.0:
        rise = 1.0 - np.exp(-t / ev[THERM_TAU])
        level = level * (1.0 + ev[THERM_GAIN] * rise)
        visc = visc * (1.0 + ev[THERM_VISC] * rise)
    return add, level, visc


@njit(cache=True)
def damping(v, ev):
    """sigma1's multiplier at velocity v (scalar or array): the bristles' damping fades as the
    joint speeds up, to 1 - g above ~ v_d."""
    g, vd = ev[DAMP_GAIN], ev[DAMP_VD]
    if g == 0.0 or vd <= 0.0:
        return 1.0 + 0.0 * v
    return 1.0 - g * (1.0 - np.exp(-(v / vd) ** 2))


# The additive torque is linear in these slots, column by column of ``additive_columns``:
# a fit evaluates it as a weighted sum of fixed (filtered) columns instead of re-evaluating
# the sines at every call (``bench.fitting.predict``).  The level, viscous and damping
# multipliers are not linear and depend only on these slots:
ADDITIVE_SLOTS = (OFFSET, GRAV_SIN, GRAV_COS) + tuple(range(COG_COEF, COG_COEF + 2 * COG_HARMONICS))
LEVEL_SLOTS = (ASYM, PF_PITCH) + tuple(range(PF_COEF, PF_COEF + 2 * PF_HARMONICS)) + (THERM_GAIN, THERM_TAU, THERM_VISC,
                                                                                   DAMP_GAIN, DAMP_VD)


def additive_columns(q: np.ndarray, cog_pitch: float) -> np.ndarray:
    """The additive torque's columns at positions ``q``, in the order of ``ADDITIVE_SLOTS``:
    1, sin q, cos q, then the cogging columns.  ``effect_terms``' additive torque is
    ``additive_columns(q, pitch) @ ev[ADDITIVE_SLOTS]``."""
    q = np.asarray(q, dtype=float)
    return np.vstack([np.ones_like(q), np.sin(q), np.cos(q), cogging_columns(q, cog_pitch)])


def cogging_columns(q: np.ndarray, pitch: float) -> np.ndarray:
    """sin(k w q), cos(k w q) for the cogging harmonics, w = 2 pi / pitch (zero without one)."""
    q = np.asarray(q, dtype=float)
    cols = np.zeros((2 * COG_HARMONICS, len(q)))
    if pitch > 0.0:
        w = 2.0 * np.pi / pitch
        for k in range(COG_HARMONICS):
            cols[2 * k] = np.sin((k + 1) * w * q)
            cols[2 * k + 1] = np.cos((k + 1) * w * q)
    return cols


@njit(cache=True)
def load_step(ql, vl, qm0, qm1, h, gap, w2, c2):
    """Advance the load over h while the motor moves linearly from qm0 to qm1 (its velocity
    held, as the LuGre kernel holds it).  Implicit midpoint: within one contact regime the
    load equation is linear, so it is solved exactly; the regime is re-read from the
    solution until it stops changing.  In contact (|q_m - q_l| beyond the half gap) the
    coupling torque / M_load is w2 (d -+ gap) + c2 (v_m - v_l); inside the gap it is zero.
    Returns (q_l, v_l) at the end of the step."""
    vm = (qm1 - qm0) / h
    D0 = 0.5 * (qm0 + qm1) - ql - 0.25 * h * vl     # offset at the midpoint, without v1
    V0 = vm - 0.5 * vl
    v1 = vl
    side = 2                                          # none yet
    for _ in range(4):
        d = D0 - 0.25 * h * v1
        s = 1 if d > gap else (-1 if d < -gap else 0)
        if gap == 0.0:
            s = 1
        if s == side:
            break
        side = s
        if s == 0:
            v1 = vl
            continue
        rhs = vl + h * (w2 * (D0 - s * gap) + c2 * V0)
        v1 = rhs / (1.0 + 0.25 * h * h * w2 + 0.5 * h * c2)
    return ql + 0.5 * h * (vl + v1), v1


@njit(cache=True)
def load_trajectory(qm, dt, n_sub, gap, w2, c2, lag0=0.0, v0=0.0):
    """Load position at the samples of a motor trajectory ``qm`` (linear between samples, cut
    into ``n_sub`` steps), starting ``lag0`` behind the motor at speed ``v0``: by default at
    rest, centred in the gap, as the virtual joint starts (``bench.gear_model.load_start``:
    a segment that starts in motion, after a logger's gap)."""
    n = qm.shape[0]
    ql = np.empty(n)
    q, v = qm[0] - lag0, v0
    h = dt / n_sub
    for i in range(n):
        ql[i] = q
        if i + 1 < n:
            for j in range(n_sub):
                a0 = qm[i] + (qm[i + 1] - qm[i]) * j / n_sub
                a1 = qm[i] + (qm[i + 1] - qm[i]) * (j + 1) / n_sub
                q, v = load_step(q, v, a0, a1, h, gap, w2, c2)
    return ql


@njit(cache=True)
def load_step_friction(ql, vl, zl, qm0, qm1, h, gap, w2, c2, p, kappa):
    """``load_step`` for a load with friction of its own: M_l qdd_l = coupling - share F(v_l),
    written per unit load inertia with ``kappa`` = share / M_l; F is the joint's LuGre law
    (``p`` in the kernels' order) on the load's velocity and bristle state ``zl``, the bristle
    integrated exactly over the step with the midpoint velocity held (as the motor's).  The
    implicit midpoint equation is solved for the end velocity by a secant iteration (the
    friction is monotone in it), the contact regime re-read at each iterate.  Returns (q_l,
    v_l, z_l, the mean friction over the step)."""
    Fc, Fs, alpha, delta, s0, s1, s2 = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    vm = (qm1 - qm0) / h
    D0 = 0.5 * (qm0 + qm1) - ql - 0.25 * h * vl
    V0 = vm - 0.5 * vl
    chord_f = kappa * 0.5 * (0.5 * s0 * h + s1 + s2)
    chord_c = 0.25 * h * w2 + 0.5 * c2
    v1 = vl
    v_prev = vl
    g_prev = 0.0
    z1, F = zl, 0.0
    for it in range(30):
        d = D0 - 0.25 * h * v1
        side = 1 if d > gap else (-1 if d < -gap else 0)
        if gap == 0.0:
            side = 1
        coup = 0.0 if side == 0 else w2 * (d - side * gap) + c2 * (V0 - 0.5 * v1)
        vh = 0.5 * (vl + v1)
        z1, zbar = bristle_step(zl, vh, h, stribeck_level(vh, Fc, Fs, alpha, delta), s0)
        F = s0 * zbar + s1 * (z1 - zl) / h + s2 * vh
        g = v1 - vl - h * (coup - kappa * F)
        slope = 1.0 + h * (chord_f + (chord_c if side != 0 else 0.0))
        if it > 0 and v1 != v_prev:
            sec = (g - g_prev) / (v1 - v_prev)
            # g's slope is at least 1 (the friction and the coupling are monotone): a guard
            # relative to the chord held a stiff law (sigma0 8e12, fitted to a sharp static
            # map) to the chord's huge slope, and the step crawled its 30 iterations unconverged
            if 0.1 < sec < 10.0 * slope:
                slope = sec
        dv = g / slope
        v_prev, g_prev = v1, g
        v1 = v1 - dv
        # as the motor's step: the bristle state and friction of the last iterate are kept
        # (the last correction is below 1e-9 of the velocity)
        if abs(dv) <= 1e-12 + 1e-9 * abs(v1):
            break
    return ql + h * 0.5 * (vl + v1), v1, z1, F


@njit(cache=True)
def load_trajectory_friction(qm, dt, n_sub, gap, w2, c2, p, kappa, z0, lag0=0.0, v0=0.0):
    """``load_trajectory`` for a load with friction (``load_step_friction``): the load's
    position at the samples, and its mean friction F(v_l) over each sample interval (per unit
    share), starting ``lag0`` behind the motor at speed ``v0`` (default: at rest) with bristle
    state ``z0``."""
    n = qm.shape[0]
    ql = np.empty(n)
    Fi = np.zeros(max(n - 1, 0))
    q, v, z = qm[0] - lag0, v0, z0
    h = dt / n_sub
    for i in range(n):
        ql[i] = q
        if i + 1 < n:
            acc = 0.0
            for j in range(n_sub):
                a0 = qm[i] + (qm[i + 1] - qm[i]) * j / n_sub
                a1 = qm[i] + (qm[i + 1] - qm[i]) * (j + 1) / n_sub
                q, v, z, F = load_step_friction(q, v, z, a0, a1, h, gap, w2, c2, p, kappa)
                acc += F
            Fi[i] = acc / n_sub
    return ql, Fi


@njit(cache=True)
def motor_step(q0, v0, z0, t, h, tau, M, p, ev, has_terms, v_guess, slope_guess):
    """One implicit sub-step of a mass M under torque ``tau`` against the joint's LuGre law
    (``p`` in the kernels' order) and the extra terms ``ev``: the virtual joint's step
    (``virtual_drives.physics``), and the motor's through a gear's gap seen from the load
    (``motor_lead``).  Returns (q, v, z, the last secant slope) at the end of the step."""
    Fc, Fs, alpha, delta, s0, s1, s2 = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    chord = M + 0.5 * h * (0.5 * s0 * h + s1 + s2)
    # the slope of the implicit equation changes little from step to step: start Newton
    # with the last secant, fall back to the (upper-bound) chord
    last_slope = slope_guess if 0.1 * M < slope_guess < 10.0 * chord else chord
    v1 = v_guess
    g_prev = 0.0
    v_prev = 0.0
    z1 = z0
    add, level, visc, damp = 0.0, 1.0, 1.0, 1.0
    for it in range(12):
        vh = 0.5 * (v0 + v1)
        if has_terms:
            add, level, visc = effect_terms(q0 + 0.5 * h * vh, vh, t + 0.5 * h, ev)
            damp = damping(vh, ev)
        s = level * stribeck_level(vh, Fc, Fs, alpha, delta)
        z1, zbar = bristle_step(z0, vh, h, s, s0)
        Fbar = s0 * zbar + s1 * damp * (z1 - z0) / h + s2 * visc * vh
        g = M * (v1 - v0) - h * (tau - Fbar - add)
        slope = last_slope if it == 0 else chord
        if it > 0 and v1 != v_prev:
            sec = (g - g_prev) / (v1 - v_prev)
            if sec > 0.1 * M and sec < 10.0 * chord:
                slope = sec
                last_slope = sec
        dv = g / slope
        v_prev = v1
        g_prev = g
        v1 = v1 - dv
        # the error left after an update is the update times the Newton contraction (the
        # slope is the last secant): 1e-7 relative leaves ~1e-9, far below the step's
        # discretisation error (~4e-7 of the travel at 1 kHz); the bristle state of
        # this last iterate is kept (the final correction moves vh by less than that)
        if abs(dv) <= 1e-12 + 1e-7 * abs(v1):
            break
    return q0 + h * 0.5 * (v0 + v1), v1, z1, last_slope


@njit(cache=True)
def motor_lead(acc, tau, vl, dt, n_sub, gap, w2, c2, M_motor, p):
    """A gear seen from a load-side encoder: the motor's lead over the load, e = q_m - q_l,
    from the load's measured acceleration ``acc`` and velocity ``vl`` and the torque ``tau``
    (each held over a sample interval), with all the friction on the motor.

    In contact the coupling is all that drives the load, qdd_l = w2 (e - side gap) + c2 de/dt
    (per unit load inertia, as in ``load_step``): a first-order law for e, solved exactly for
    the acceleration held.  The flanks part when that deflection changes sign; in the gap the
    load coasts and the motor runs on its own, M_motor qdd_m = tau - F(v_m, z)
    (``motor_step``), until it meets the other flank.  Each event is timed within its sub-step
    and the rest of the sub-step run in the new regime, so the lead is continuous in the
    width and the inertia (a fit's finite differences see a slope, not a step).  The bristle
    state follows the motor's velocity throughout.  Starts in the gap's middle, moving with
    the load.  Returns (de/dt over each interval, the share of each interval in the gap)."""
    n = acc.shape[0]
    lead = np.empty(n)
    free = np.zeros(n)
    e, side, z = 0.0, 0, 0.0
    vm = vl[0] if n else 0.0
    h = dt / n_sub
    lam = w2 / c2
    ev = np.zeros(SIZE)
    slope = 0.0
    for i in range(n):
        e0 = e
        target = acc[i] / w2
        for _ in range(n_sub):
            left = h
            for _piece in range(4):                  # at most a few events per sub-step
                if left <= 0.0:
                    break
                if side != 0:
                    d0 = e - side * gap
                    d1 = target + (d0 - target) * math.exp(-lam * left)
                    run = left
                    parted = side * d1 < 0.0
                    if parted:                       # d(t) = target + (d0 - target) e^(-lam t) = 0
                        run = min(max(math.log((d0 - target) / -target) / lam, 0.0), left)
                        d1 = 0.0
                    v1 = vl[i] + (acc[i] - w2 * d1) / c2
                    vh = 0.5 * (vm + v1)
                    if run > 0.0:
                        z, _zbar = bristle_step(z, vh, run, stribeck_level(vh, p[0], p[1], p[2], p[3]), p[4])
                    vm = v1
                    e = side * gap + d1
                    if parted:
                        side = 0
                    left -= run
                else:
                    v0, z0 = vm, z
                    _q, v1, z1, slope = motor_step(0.0, v0, z0, 0.0, left, tau[i], M_motor, p, ev, False, v0, slope)
                    e1 = e + left * (0.5 * (v0 + v1) - vl[i])
                    run = left
                    if abs(e1) > gap:                # meets a flank within this step
                        edge = gap if e1 > 0.0 else -gap
                        run = min(max(left * (edge - e) / (e1 - e), 0.0), left)
                        if run > 0.0:
                            _q, v1, z1, slope = motor_step(0.0, v0, z0, 0.0, run, tau[i], M_motor, p, ev,
                                                           False, v0, slope)
                        else:
                            v1, z1 = v0, z0
                        e, side = edge, (1 if edge > 0.0 else -1)
                    else:
                        e = e1
                    vm, z = v1, z1
                    free[i] += run / dt
                    left -= run
        lead[i] = (e - e0) / dt
    return lead, free


# The presliding of friction beyond a gear (``bench.gear_model``) is resolved up to the record's
# Nyquist frequency, pi / dt (h omega <= 0.5 there: 7 sub-steps), not beyond: no sample sees
# it, and the implicit step keeps a faster mode bounded.  A LuGre fit bent to a
# sharp static map (sigma0 8e12 on j4, independent simulator, test seed 5725) otherwise ran every
# load at the 64-sub-step cap (with the step's guard fixed, 39 s against over 15 min before).
SEEN_SUBSTEPS = 7


def substeps_for(dt: float, M: float, sigma0: float, sigma1: float, sigma2: float,
                 max_substeps: int = 64) -> int:
    """Sub-steps per control period so that h resolves the presliding dynamics
    (h * omega0 <= 0.5 and h * (sigma1 + sigma2) / M <= 1)."""
    omega0 = math.sqrt(max(sigma0, 0.0) / M)
    damping = (sigma1 + sigma2) / M
    rate = max(omega0 / 0.5, damping / 1.0, 1e-12)
    return int(min(max_substeps, max(1, math.ceil(dt * rate))))
