"""Operations on an evenly sampled grid: the zero-phase filter every estimate and model output
passes through, the finite differences that give velocity and acceleration (their stencils
chosen for how the torque was held, ``bench.signals.condition``), and sign changes."""
from __future__ import annotations

import numpy as np
from scipy import signal


def filtfilt(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Zero-phase filter; a segment shorter than the default padding is padded less (its
    samples are never scored: they lie within the filter's edge)."""
    pad = 3 * (2 * len(sos) + 1)
    if len(x) > pad:
        return signal.sosfiltfilt(sos, x)
    return signal.sosfiltfilt(sos, x, padlen=len(x) - 1) if len(x) > 1 else np.array(x, dtype=float)


def second_difference(q: np.ndarray, dt: float) -> np.ndarray:
    """(q[i+1] - 2 q[i] + q[i-1]) / dt^2: the narrowest stencil, so the torque it balances is
    the one applied over [t[i-1], t[i+1]] (see ``held_torque``)."""
    a = np.empty_like(q, dtype=float)
    a[1:-1] = (q[2:] - 2.0 * q[1:-1] + q[:-2]) / dt ** 2
    a[0], a[-1] = a[1], a[-2]
    return a


def fourth_order_second_difference(q: np.ndarray, dt: float) -> np.ndarray:
    """q'' with error O(h^4), for torques sampled at t (not held).  The narrow stencil reads
    q'' low by (w h)^2 / 12, which a held torque's mean balances but a sampled one does not: on
    a 4 ms logger grid that is 2.5e-4 of the inertial torque at 2 Hz, 0.7 % of Fc on the rotary
    motor (its torque is 27x its friction), and it reads as an inertia error (tuning seed 1209)."""
    a = second_difference(q, dt)
    if len(q) >= 5:
        a[2:-2] = (-q[4:] + 16.0 * q[3:-1] - 30.0 * q[2:-2] + 16.0 * q[1:-3] - q[:-4]) / (12.0 * dt ** 2)
    return a


def fourth_order_derivative(v: np.ndarray, dt: float) -> np.ndarray:
    """v' with error O(h^4) (central differences read it low by (w h)^2 / 6)."""
    a = np.gradient(v, dt)
    if len(v) >= 5:
        a[2:-2] = (-v[4:] + 8.0 * v[3:-1] - 8.0 * v[1:-3] + v[:-4]) / (12.0 * dt)
    return a


def held_torque(tau: np.ndarray) -> np.ndarray:
    """Torque seen by the second difference at sample i when each command is held until the
    next sample (zero-order hold): the mean of tau[i-1] and tau[i]."""
    out = np.empty_like(tau, dtype=float)
    out[1:] = 0.5 * (tau[1:] + tau[:-1])
    out[0] = tau[0]
    return out


def zero_crossings(x: np.ndarray) -> np.ndarray:
    """Indices i where x changes sign between i and i+1 (zeros count as the previous sign)."""
    s = np.sign(x)
    for i in range(1, len(s)):  # carry signs across exact zeros
        if s[i] == 0:
            s[i] = s[i - 1]
    return np.nonzero(s[:-1] * s[1:] < 0)[0]
