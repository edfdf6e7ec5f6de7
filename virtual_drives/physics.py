"""Rigid joint with LuGre friction: M qdd = tau - F(v, z) - extra(q, v, t).

The torque command is held over each control period, which is cut into ``n_sub`` sub-steps.
Each sub-step is a trapezoidal (implicit midpoint-velocity) step: the bristle state is
advanced exactly by ``bench.lugre.bristle_step`` with the midpoint velocity held, and the
momentum balance uses the exact mean friction over the sub-step.  The implicit velocity
equation is solved by a chord-then-secant iteration.  Being A-stable on the linearised
presliding dynamics (M s^2 + (sigma1 + sigma2) s + sigma0), the step stays stable for any
stiffness; sub-steps are there for accuracy, not stability.

A geared joint (``bench.terms.two_mass``) splits the inertia into a motor and a load joined
by the gear: a dead zone (backlash) and/or a spring-damper (flexibility), written once in
``bench.terms`` (``load_step``).  The extra terms act on the motor; so does the friction,
lumped there as the paper identifies it from the motor's torque and encoder, unless a share
of it sits beyond the gear (``LOAD_FRICTION``: the output bearing, the mesh), which then acts
on the load's own velocity and bristle state (``load_step_friction``).  Each sub-step is the same motor step as the rigid joint's with the coupling
torque taken off the command, solved together with the load's implicit step (a secant
iteration on the coupling torque) so that the torque the motor loses is the one the load
gains: momentum is conserved, and eq. 5 holds on the record.
A rigid joint never enters this path.
"""
from __future__ import annotations

import math

import numpy as np

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file
from bench.terms import BACKLASH, LOAD_FRICTION, load_step, load_step_friction
from bench.terms import motor_step as _substep
from bench.terms import substeps_for


@njit(cache=True)
def simulate(tau, dt, n_sub, M, p, ev, q0, v0, z0, t0):
    """Integrate over len(tau) control periods.  Returns q, v, z sampled at the start of each
    period (index i is the state when tau[i] is applied) and the final state."""
    n = tau.shape[0]
    q = np.empty(n)
    v = np.empty(n)
    z = np.empty(n)
    h = dt / n_sub
    has_terms = False
    for x in ev:
        if x != 0.0:
            has_terms = True
    qi, vi, zi = q0, v0, z0
    acc = 0.0
    acc_prev = 0.0
    slope = 0.0
    for i in range(n):
        q[i] = qi
        v[i] = vi
        z[i] = zi
        t = t0 + i * dt
        for j in range(n_sub):
            v_before = vi
            # predictor: the velocity change extrapolated linearly from the last two sub-steps
            # (in smooth motion one Newton evaluation then already meets the tolerance)
            qi, vi, zi, slope = _substep(qi, vi, zi, t + j * h, h, tau[i], M, p, ev, has_terms,
                                         vi + 2.0 * acc - acc_prev, slope)
            acc_prev = acc
            acc = vi - v_before
    return q, v, z, qi, vi, zi


@njit(cache=True)
def simulate_two_mass(tau, dt, n_sub, M_motor, M_load, p, ev, gap, w2, c2,
                      q0, v0, z0, ql0, vl0, t0, zl0=0.0):
    """Like ``simulate`` for a motor (friction, terms) and a load joined by the gear.
    Returns motor q, v, z and load q, v sampled at the start of each period, and the final
    state (q, v, z, q_l, v_l, z_l: the load's bristle state, when it has friction)."""
    n = tau.shape[0]
    q = np.empty(n)
    v = np.empty(n)
    z = np.empty(n)
    ql = np.empty(n)
    vl = np.empty(n)
    h = dt / n_sub
    has_terms = False
    for x in ev[:BACKLASH]:       # the term slots (the mechanics slots come after)
        if x != 0.0:
            has_terms = True
    share = ev[LOAD_FRICTION] if ev.shape[0] > LOAD_FRICTION else 0.0
    pm = p.copy()                  # the motor's part of the friction: every force scaled
    for k in (0, 1, 4, 5, 6):      # (Fc, Fs, sigma0, sigma1, sigma2; the bristle state is
        pm[k] = p[k] * (1.0 - share)   # the same, z_ss = s(v) / sigma0)
    kappa = share / M_load
    qi, vi, zi, qli, vli, zli = q0, v0, z0, ql0, vl0, zl0
    acc = 0.0
    acc_prev = 0.0
    slope = 0.0
    for i in range(n):
        q[i] = qi
        v[i] = vi
        z[i] = zi
        ql[i] = qli
        vl[i] = vli
        t = t0 + i * dt
        for j in range(n_sub):
            v_before = vi
            guess = vi + 2.0 * acc - acc_prev
            q_end = qi + 0.5 * h * (vi + guess)          # motor end position, predicted
            zn, Fl = zli, 0.0
            if share > 0.0:
                qn, vn, zn, Fl = load_step_friction(qli, vli, zli, qi, q_end, h, gap, w2, c2, p, kappa)
            else:
                qn, vn = load_step(qli, vli, qi, q_end, h, gap, w2, c2)
            # the mean torque the gear passes to the load: its momentum change and its friction
            T = M_load * (vn - vli) / h + share * Fl
            T_prev, f_prev = 0.0, 0.0
            q1, v1, z1, s1 = qi, vi, zi, slope
            # the torque the motor gives up must be the torque the load takes: solve
            # T = T_load(q_motor_end(T)) by secant iteration (converges in 2-4 steps)
            for it in range(12):
                q1, v1, z1, s1 = _substep(qi, vi, zi, t + j * h, h, tau[i] - T, M_motor,
                                          pm, ev, has_terms, guess, slope)
                if share > 0.0:
                    qn, vn, zn, Fl = load_step_friction(qli, vli, zli, qi, q1, h, gap, w2, c2, p, kappa)
                else:
                    qn, vn = load_step(qli, vli, qi, q1, h, gap, w2, c2)
                f = M_load * (vn - vli) / h + share * Fl - T
                # 1e-8 of the torques: below the motor step's own Newton tolerance
                if abs(f) <= 1e-8 * (abs(T) + abs(tau[i])) + 1e-300:
                    break
                T_next = T + f
                if it > 0 and f != f_prev:
                    T_next = T - f * (T - T_prev) / (f - f_prev)
                T_prev, f_prev = T, f
                T = T_next
                guess = v1
            qli, vli, zli = qn, vn, zn
            qi, vi, zi, slope = q1, v1, z1, s1
            acc_prev = acc
            acc = vi - v_before
    return q, v, z, ql, vl, qi, vi, zi, qli, vli, zli


def two_mass_substeps(dt: float, M_motor: float, M_load: float, w2: float, c2: float,
                      sigma0: float, sigma1: float, sigma2: float, max_substeps: int = 64,
                      load_friction: float = 0.0) -> int:
    """Sub-steps for the geared joint: the motor's presliding as for a rigid joint, and the
    gear's free-free mode (motor and load swinging against each other, sqrt(1 + M_l/M_m)
    times the locked-rotor frequency) resolved at h * omega <= 0.1: a contact that closes
    inside a coarser step leaves eq. 5 off by several times the noise of a geared record
    (measured on j2 with 3 mrad of backlash: 4 sub-steps 1.8 N·m, 6-24 sub-steps 0.38 N·m,
    the rigid joint's own 0.39 N·m).  A load with a share of the friction resolves its own
    presliding too."""
    n = substeps_for(dt, M_motor, sigma0, sigma1, sigma2, max_substeps)
    if load_friction > 0.0:       # the load's own presliding, as the motor's
        n = max(n, substeps_for(dt, M_load / load_friction, sigma0, sigma1, sigma2, max_substeps))
    omega = math.sqrt(w2 * (1.0 + M_load / M_motor))
    damping = c2 * (1.0 + M_load / M_motor)
    # a load with friction of its own sticks and slips inside the gap, and each contact is
    # found a whole sub-step late: at h omega = 0.094 the linear stage with 40 % of its
    # friction beyond 80 um of backlash drifted 2.2e-4 of its travel from an independent
    # Runge-Kutta integration in 8 s, at 0.047 5e-7 (tests/core/test_independent_physics.py)
    rate = max(omega / (0.05 if load_friction > 0.0 else 0.1), damping / 1.0)
    return int(min(max_substeps, max(n, math.ceil(dt * rate))))
