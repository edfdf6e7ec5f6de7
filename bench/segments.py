"""Zero-phase filtering of a record split at gaps, one segment at a time.

A record resampled from a logger with dropped samples can have a hundred segments, and the
fit low-passes the model's friction thousands of times; scipy's ``sosfiltfilt`` costs about a
millisecond a call in checks alone.  This is the same algorithm (odd extension of 3 (2 n + 1)
samples, steady-state initial conditions scaled by the first sample, forward then backward
through the second-order sections) compiled once for all segments.  Segments shorter than the
extension are padded less: their samples lie inside filter edges and are never scored.
"""
from __future__ import annotations

import numpy as np
from scipy import signal

from bench.kernel_cache import njit  # numba's, its cache stamped with every kernel file


def filtfilt_segments(sos: np.ndarray, x: np.ndarray, bounds: np.ndarray,
                      zi: np.ndarray | None = None) -> np.ndarray:
    """``sosfiltfilt(sos, x[a:b])`` for each (a, b) row of ``bounds``, concatenated (``zi``:
    ``sosfilt_zi(sos)``, when the caller keeps it)."""
    zi = signal.sosfilt_zi(sos) if zi is None else zi
    return _filtfilt_all(np.ascontiguousarray(sos, dtype=np.float64), np.ascontiguousarray(zi),
                         np.ascontiguousarray(x, dtype=np.float64), np.asarray(bounds, dtype=np.int64),
                         3 * (2 * len(sos) + 1))


@njit(cache=True)
def _sosfilt(sos, x, zi):
    y = x.copy()
    ns = sos.shape[0]
    z = zi.copy()
    for i in range(len(y)):
        v = y[i]
        for s in range(ns):
            b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
            out = b0 * v + z[s, 0]
            z[s, 0] = b1 * v - a1 * out + z[s, 1]
            z[s, 1] = b2 * v - a2 * out
            v = out
        y[i] = v
    return y


@njit(cache=True)
def _filtfilt_all(sos, zi, x, bounds, padlen_default):
    out = np.empty(x.shape[0])
    for k in range(bounds.shape[0]):
        a, b = bounds[k, 0], bounds[k, 1]
        n = b - a
        if n <= 1:
            for i in range(a, b):
                out[i] = x[i]
            continue
        seg = x[a:b]
        p = min(padlen_default, n - 1)
        ext = np.empty(n + 2 * p)
        for i in range(p):
            ext[i] = 2.0 * seg[0] - seg[p - i]
            ext[n + p + i] = 2.0 * seg[n - 1] - seg[n - 2 - i]
        ext[p:p + n] = seg
        y = _sosfilt(sos, ext, zi * ext[0])
        y = _sosfilt(sos, y[::-1].copy(), zi * y[-1])
        for i in range(n):
            out[a + i] = y[n + p - 1 - i]
    return out
