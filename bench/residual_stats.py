"""Statistics on residuals: how many independent samples a correlated residual holds, how
consistently one held-out prediction beats another, how much of a signal one variable
determines."""
from __future__ import annotations

import numpy as np


def effective_sample_fraction(residual: np.ndarray, max_lag: int = 2000) -> float:
    """N_eff / N from the integrated autocorrelation time of a residual (Geyer-style
    truncation at the first non-positive pair), to inflate least-squares standard errors
    for filtered, correlated residuals."""
    r = residual - residual.mean()
    n = len(r)
    if n < 4 or not np.any(r):
        return 1.0
    m = min(max_lag, n - 1)
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[: m + 1]
    ac = ac / ac[0]
    tau_int = 1.0
    for k in range(1, m, 2):
        pair = ac[k] + ac[k + 1]
        if pair <= 0:
            break
        tau_int += 2.0 * pair
    return float(min(1.0, 1.0 / tau_int))


def paired_t(d: np.ndarray) -> float:
    """Paired t statistic of per-segment gains ``d`` (mean over its standard error): how
    consistently a held-out prediction beats its alternative across segments."""
    return float(d.mean() / (d.std(ddof=1) / np.sqrt(len(d)) + 1e-300)) if len(d) > 1 else 0.0


def binned_r2(y: np.ndarray, x: np.ndarray, side: np.ndarray, bins: int = 40) -> float:
    """How much of y's variance x determines on each ``side`` (a boolean: the direction of
    motion): 1 - the variance left about y's means in ``bins`` equal-width bins of x per side,
    over y's variance.  One repeated sine ties the torque, the velocity and the travel since
    reversal to the position this way (``bench.effects.periodic.torque_locked``,
    ``bench.predictability.ties``)."""
    if not np.var(y) > 0:
        return 1.0
    idx = np.clip(np.digitize(x, np.linspace(x.min(), x.max(), bins + 1)) - 1, 0, bins - 1) + bins * side
    counts = np.bincount(idx, minlength=2 * bins)
    means = np.bincount(idx, y, minlength=2 * bins) / np.maximum(counts, 1)
    return 1.0 - float(np.var(y - means[idx]) / np.var(y))
