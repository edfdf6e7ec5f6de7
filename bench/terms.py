"""Physical terms that extend the LuGre joint: one compiled definition used by the virtual
drives (to inject an effect) and by the effect library (to fit it).

A joint's extra physics is a flat float vector ``ev`` with the slots below.  Position-periodic
terms are written as sine/cosine coefficients so that, for a known pitch, they are linear in
their parameters (a fit can solve them by least squares).

    additive torque   offset + a sin q + b cos q + sum_k (c_k sin(k w q) + d_k cos(k w q))
    level multiplier  (1 + asym sgn v) (1 + sum_k (e_k sin(k w' q) + f_k cos(k w' q)))
                      (1 + c_th (1 - exp(-t / tau_th)))        scales s(v): Fc and Fs
    viscous multiplier (1 + c_th (1 - exp(-t / tau_th)))       scales sigma2
with w = 2 pi / cogging pitch and w' = 2 pi / friction pitch.
"""
from __future__ import annotations

import numpy as np
from numba import njit

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
SIZE = 18


def empty() -> np.ndarray:
    return np.zeros(SIZE)


@njit(cache=True)
def _fourier(q, pitch, ev, first, harmonics):
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
        add = add + _fourier(q, ev[COG_PITCH], ev, COG_COEF, COG_HARMONICS)
    level = 1.0 + 0.0 * q
    if ev[ASYM] != 0.0:
        level = level * (1.0 + ev[ASYM] * np.sign(v))
    if ev[PF_PITCH] > 0.0:
        level = level * (1.0 + _fourier(q, ev[PF_PITCH], ev, PF_COEF, PF_HARMONICS))
    visc = 1.0 + 0.0 * t
    if ev[THERM_GAIN] != 0.0 and ev[THERM_TAU] > 0.0:
        drift = 1.0 + ev[THERM_GAIN] * (1.0 - np.exp(-t / ev[THERM_TAU]))
        level = level * drift
        visc = visc * drift
    return add, level, visc
