"""The LuGre friction model (Kermani, Patel & Moallem, eqs. 2-3 and 6c).

This is the one implementation shared by identification (``bench.identify``) and by the
physics of the virtual drives (``virtual_drives.physics``): both call the same compiled
``bristle_step``.

The bristle state obeys  dz/dt = v - sigma0 |v| / s(v) * z.  With the velocity held over a
step of length h this is linear in z, so it is integrated exactly:

    k    = sigma0 |v| / s(v)
    z_ss = v / k = sgn(v) s(v) / sigma0
    z1   = z_ss + (z0 - z_ss) exp(-k h)

which is unconditionally stable: sigma0 = 1e6 at 1 kHz is as well behaved as sigma0 = 1.
The Stribeck level carries an exponent delta, s(v) = Fc + (Fs - Fc) exp(-(alpha |v|)^delta);
the paper's exp(-alpha |v|) is delta = 1.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file

PARAMETER_NAMES = ("Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2")
UNITS = {  # for a revolute joint; a prismatic joint reads N and m
    "Fc": "N·m", "Fs": "N·m", "alpha": "s/rad", "sigma0": "N·m/rad",
    "sigma1": "N·m·s/rad", "sigma2": "N·m·s/rad", "delta": "1",
}


@dataclass(frozen=True)
class LuGreParams:
    Fc: float
    Fs: float
    alpha: float
    sigma0: float
    sigma1: float
    sigma2: float
    delta: float = 1.0  # Stribeck exponent; 1 is the paper's model

    def as_dict(self, with_delta: bool = False) -> dict[str, float]:
        d = {k: float(v) for k, v in asdict(self).items()}
        if not with_delta:
            d.pop("delta")
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "LuGreParams":
        return cls(**{k: float(d[k]) for k in (*PARAMETER_NAMES, "delta") if k in d})

    def with_(self, **changes) -> "LuGreParams":
        return replace(self, **changes)

    def vector(self) -> np.ndarray:
        """(Fc, Fs, alpha, delta, sigma0, sigma1, sigma2): the order the kernels take."""
        return np.array([self.Fc, self.Fs, self.alpha, self.delta,
                         self.sigma0, self.sigma1, self.sigma2], dtype=np.float64)

    def stribeck(self, v):
        """s(v) of eq. 3 (with exponent delta)."""
        return self.Fc + (self.Fs - self.Fc) * np.exp(-np.power(self.alpha * np.abs(v), self.delta))

    def steady_state(self, v):
        """Steady-state friction-velocity map, eq. 6c: sgn(v) s(v) + sigma2 v."""
        v = np.asarray(v, dtype=float)
        return np.sign(v) * self.stribeck(v) + self.sigma2 * v

    def passivity_warning(self) -> str | None:
        """Section II: the model is passive iff eps2 <= eps1 (1 + sigma2/sigma1),
        eps1 = 1/s(0) = 1/Fs, eps2 = 1/s(inf) = 1/Fc."""
        if self.sigma1 <= 0 or self.Fc <= 0 or self.Fs <= 0:
            return None
        eps1, eps2 = 1.0 / self.Fs, 1.0 / self.Fc
        bound = eps1 * (1.0 + self.sigma2 / self.sigma1)
        if eps2 > bound:
            return (f"model is not passive: 1/Fc = {eps2:.4g} > (1/Fs)(1 + sigma2/sigma1) = {bound:.4g}; "
                    "it can inject energy near stick-slip transitions")
        return None


@njit(cache=True, fastmath=False)
def stribeck_level(v, Fc, Fs, alpha, delta):
    x = alpha * abs(v)
    if delta == 1.0:
        return Fc + (Fs - Fc) * math.exp(-x)
    return Fc + (Fs - Fc) * math.exp(-(x ** delta))


@njit(cache=True)
def bristle_step(z0, v, h, s, sigma0):
    """Exact bristle update over a step h with velocity v and Stribeck level s held.
    Returns (z1, mean of z over the step)."""
    if v == 0.0 or s <= 0.0:
        return z0, z0
    k = sigma0 * abs(v) / s
    z_ss = v / k
    kh = k * h
    decay = math.exp(-kh)
    z1 = z_ss + (z0 - z_ss) * decay
    # mean of the exponential relaxation over the step; (1 - e^-x)/x, series for small x
    if kh < 1e-6:
        frac = 1.0 - 0.5 * kh
    else:
        frac = (1.0 - decay) / kh
    return z1, z_ss + (z0 - z_ss) * frac


@njit(cache=True)
def friction_trace(vh, dt, z0, Fc, Fs, alpha, delta, sigma0, sigma1, sigma2, level, visc, damp):
    """Friction along a velocity trace held over intervals of length dt.

    ``vh[i]`` is the velocity held over interval i; the bristle state is advanced exactly and
    ``F[i]`` is the exact mean friction over the interval:
    sigma0 * mean(z) + sigma1 * (z_end - z_start) / dt + sigma2 * vh.  ``level`` scales s(v)
    (position-, direction- or time-dependent friction levels), ``visc`` scales sigma2 and
    ``damp`` sigma1 (``bench.terms.damping``), interval by interval.  Returns (F, z at the start of each interval).
    """
    n = vh.shape[0]
    F = np.empty(n)
    z = np.empty(n)
    zi = z0
    for i in range(n):
        z[i] = zi
        s = level[i] * stribeck_level(vh[i], Fc, Fs, alpha, delta)
        z1, zbar = bristle_step(zi, vh[i], dt, s, sigma0)
        F[i] = sigma0 * zbar + sigma1 * damp[i] * (z1 - zi) / dt + sigma2 * visc[i] * vh[i]
        zi = z1
    return F, z


def interval_to_samples(F_interval: np.ndarray) -> np.ndarray:
    """Mean over the two intervals around each sample: what the central second difference of
    position balances (M (q[i+1] - 2 q[i] + q[i-1]) / dt^2 = tau - mean friction)."""
    out = np.empty(len(F_interval) + 1)
    out[1:-1] = 0.5 * (F_interval[1:] + F_interval[:-1])
    out[0], out[-1] = F_interval[0], F_interval[-1]
    return out


def model_friction(params: LuGreParams, q: np.ndarray, dt: float, z0: float = 0.0,
                   level: np.ndarray | None = None, visc: np.ndarray | None = None):
    """Friction of ``params`` at the samples of a position trace ``q`` (velocity held over
    each interval at (q[i+1] - q[i]) / dt).  Returns (F at samples, z at interval starts)."""
    vh = np.ascontiguousarray(np.diff(np.asarray(q, dtype=np.float64)) / dt)
    ones = np.ones_like(vh)
    level = ones if level is None else np.ascontiguousarray(level, dtype=np.float64)
    visc = ones if visc is None else np.ascontiguousarray(visc, dtype=np.float64)
    F, z = friction_trace(vh, float(dt), float(z0), params.Fc, params.Fs, params.alpha,
                          params.delta, params.sigma0, params.sigma1, params.sigma2, level, visc, ones)
    return interval_to_samples(F), z
