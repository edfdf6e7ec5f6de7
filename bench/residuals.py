"""Where does the model fail?  The residual (measured - model friction) broken down by
regime, direction, position and time, its whiteness, and its correlation with the signals
that point to physics: acceleration (inertia), sgn v (asymmetry, offset), position
harmonics (cogging, gravity), time (drift), torque rate (a lag of the applied torque)."""
from __future__ import annotations

import numpy as np

from bench.fitting import FitData
from bench.residual_stats import effective_sample_fraction

REGIMES = ("presliding", "breakaway", "stribeck", "viscous")


def regimes(data: FitData, alpha: float) -> np.ndarray:
    """Regime index per sample: presliding (nearly stuck), breakaway (leaving stick,
    alpha|v| < 2, speeding up), Stribeck (alpha|v| < 2, slowing down), viscous (alpha|v| >= 2)."""
    v, a = data.c.v, data.c.a
    speed = np.abs(v)
    vmax = float(np.percentile(speed, 99.5)) or 1.0
    reg = np.full(len(v), 3)
    low = alpha * speed < 2.0
    reg[low & (v * a > 0)] = 1
    reg[low & (v * a <= 0)] = 2
    reg[speed < 0.02 * vmax] = 0
    return reg


def _rms(x: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(x * x))) if len(x) else None


def _corr(x: np.ndarray, y: np.ndarray) -> float:
    x = x - x.mean()
    y = y - y.mean()
    d = np.sqrt((x @ x) * (y @ y))
    return float(x @ y / d) if d > 0 else 0.0


def breakdown(data: FitData, residual: np.ndarray, alpha: float, bins: int = 12) -> dict:
    m = data.mask
    c = data.c
    r = residual[m]
    reg = regimes(data, alpha)[m]
    v, q, t, a = c.v[m], c.q[m], c.t[m], c.a[m]
    out = {"rms": _rms(r)}
    out["by_regime"] = {name: {"rms": _rms(r[reg == i]), "mean": float(r[reg == i].mean()) if np.any(reg == i) else None,
                               "fraction": float(np.mean(reg == i))} for i, name in enumerate(REGIMES)}
    out["by_direction"] = {
        "positive": {"rms": _rms(r[v > 0]), "mean": float(r[v > 0].mean()) if np.any(v > 0) else None},
        "negative": {"rms": _rms(r[v < 0]), "mean": float(r[v < 0].mean()) if np.any(v < 0) else None},
    }
    edges = np.linspace(q.min(), q.max(), bins + 1)
    which = np.clip(np.digitize(q, edges) - 1, 0, bins - 1)
    out["by_position"] = [{"from": float(edges[i]), "to": float(edges[i + 1]),
                           "mean": float(r[which == i].mean()) if np.any(which == i) else None,
                           "rms": _rms(r[which == i])} for i in range(bins)]
    cyc = np.floor((t - c.t[0]) * c.frequency).astype(int)
    out["by_cycle"] = [{"cycle": int(k), "rms": _rms(r[cyc == k]), "mean": float(r[cyc == k].mean())}
                       for k in np.unique(cyc)]
    # whiteness: the residual is low-passed, so compare its correlation time with that of
    # white noise through the same filter
    tau_res = 1.0 / effective_sample_fraction(r)
    noise = c.lowpass(np.random.default_rng(0).standard_normal(len(c.t_full)))[m]
    tau_noise = 1.0 / effective_sample_fraction(noise)
    lags = np.unique(np.geomspace(1, max(2, len(r) // 10), 24).astype(int))
    rr = r - r.mean()
    denom = float(rr @ rr) or 1.0
    out["whiteness"] = {
        "correlation_time_ratio": float(tau_res / tau_noise),
        "autocorrelation": [{"lag_s": float(k * c.dt_grid), "value": float(rr[:-k] @ rr[k:] / denom)} for k in lags],
    }
    span = float(np.ptp(q)) or 1.0
    out["cross_correlation"] = {
        "acceleration": _corr(r, a),
        "sign_velocity": _corr(r, np.sign(v)),
        "velocity": _corr(r, v),
        "position": _corr(r, q),
        "sin_position": _corr(r, np.sin(q)),
        "cos_position": _corr(r, np.cos(q)),
        "time": _corr(r, t),
        "torque_rate": _corr(r, np.gradient(c.tau, c.t)[m]),   # on the times: a logger's gaps join segments
        "sgn_v_times_time": _corr(r, np.sign(v) * (t - t.mean())),
        "best_position_harmonic": _best_harmonic(q, r, span),
    }
    return out


def _best_harmonic(q, r, span) -> dict:
    from bench.effects.base import pitch_grid, position_periodogram
    idx = slice(None, None, max(1, len(q) // 4000))
    grid = pitch_grid(q[idx], 200)
    score = position_periodogram(q[idx], r[idx], grid)
    i = int(np.argmax(score))
    return {"pitch": float(grid[i]), "explained": float(score[i])}
