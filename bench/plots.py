"""PNG figures in the paper's style: the friction-velocity map (Figs. 1/5), the presliding
force-displacement curve (Section III-B) and the effect of a wrong inertia (Fig. 2)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bench.fitting import FitData, predict  # noqa: E402
from bench.grid_math import zero_crossings  # noqa: E402


def _units(data_meta: dict) -> tuple[str, str]:
    prismatic = data_meta.get("joint_type") == "prismatic"
    return ("m/s", "N") if prismatic else ("rad/s", "N·m")


def _finish(fig, ax, path: Path, title: str, xlabel: str, ylabel: str, legend: dict | None = None) -> Path:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(**(legend or {"fontsize": 8}))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def friction_map(data: FitData, values: dict, path: Path, meta: dict | None = None,
                 appliers=(), title: str = "Friction-velocity map") -> Path:
    vu, tu = _units(meta or {})
    m = data.mask
    model = predict(data, values, appliers)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(data.c.v[m], data.friction[m], ".", ms=1.5, alpha=0.35, color="tab:blue", label="measured (eq. 5)")
    ax.plot(data.c.v[m], model[m], ".", ms=1.0, alpha=0.5, color="tab:red", label="model along the record")
    vv = np.linspace(data.c.v[m].min(), data.c.v[m].max(), 600)
    from bench.lugre import LuGreParams
    p = LuGreParams(**{k: values[k] for k in ("Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2")},
                    delta=values.get("delta", 1.0))
    ax.plot(vv, p.steady_state(vv), "k-", lw=1, label="steady state (6c)")
    return _finish(fig, ax, path, title, f"velocity [{vu}]", f"friction [{tu}]")


def presliding(data: FitData, values: dict, path: Path, meta: dict | None = None,
               appliers=()) -> Path:
    """Friction against displacement around each low-speed friction reversal."""
    vu, tu = _units(meta or {})
    pu = "m" if (meta or {}).get("joint_type") == "prismatic" else "rad"
    c, F = data.c, data.friction
    model = predict(data, values, appliers)
    vmax = np.percentile(np.abs(c.v), 99.5)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    shown = 0
    half = int(max(5, 0.05 / (c.frequency * c.dt_grid)))
    for i in zero_crossings(F):
        if abs(c.v[i]) > 0.1 * vmax or not data.mask[i] or i < half or i + half >= len(F):
            continue
        sl = slice(i - half, i + half)
        dq = c.q[sl] - c.q[i]
        ax.plot(dq, F[sl], "b-", lw=0.8, alpha=0.6, label="measured" if shown == 0 else None)
        ax.plot(dq, model[sl], "r--", lw=0.8, alpha=0.8, label="model" if shown == 0 else None)
        shown += 1
        if shown >= 6:
            break
    s0 = values["sigma0"]
    lim = values["Fs"] / s0
    xs = np.linspace(-lim, lim, 10)
    ax.plot(xs, s0 * xs, "k:", lw=1, label=f"slope sigma0 = {s0:.4g}")
    return _finish(fig, ax, path, "Presliding force-displacement",
                   f"displacement from reversal [{pu}]", f"friction [{tu}]")


def inertia_effect(data: FitData, inertia: float, path: Path, meta: dict | None = None,
                   factors=(0.5, 1.0, 1.5)) -> Path:
    """Fig. 2: the map recomputed with under- and over-estimated inertia."""
    vu, tu = _units(meta or {})
    c, m = data.c, data.mask
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for f, style in zip(factors, ("g-", "k-", "m-")):
        ax.plot(c.v[m], c.friction(f * inertia)[m], style, lw=0.6, alpha=0.7,
                label=f"M = {f:g} x {inertia:.4g}")
    return _finish(fig, ax, path, "Effect of the inertia on the friction-velocity map (Fig. 2)",
                   f"velocity [{vu}]", f"friction estimate [{tu}]")


def loop_area(v: np.ndarray, F: np.ndarray) -> float:
    """Signed area enclosed by the map on its v > 0 half (positive: followed
    counter-clockwise).  Fig. 2's 'direction in which the graph is followed'."""
    pos = v > 0
    vv, FF = v[pos], F[pos]
    # shoelace over consecutive samples of the positive-velocity excursions
    return float(0.5 * np.sum(vv[:-1] * FF[1:] - vv[1:] * FF[:-1]))


def residual_panels(data: FitData, residual: np.ndarray, alpha: float, path: Path,
                    meta: dict | None = None, title: str = "") -> Path:
    """Where the model fails: residual over time, against position (by direction), against
    velocity (by regime), its autocorrelation, and its correlation with physical signals."""
    from bench.residuals import REGIMES, breakdown, regimes
    vu, tu = _units(meta or {})
    m = data.mask
    c = data.c
    r = residual[m]
    bd = breakdown(data, residual, alpha)
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    ax = axes[0, 0]
    ax.plot(c.t[m], r, lw=0.5)
    ax.set_title("residual over time")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"[{tu}]")
    ax = axes[0, 1]
    pos = c.v[m] > 0
    ax.plot(c.q[m][pos], r[pos], ".", ms=1, alpha=0.4, label="v > 0")
    ax.plot(c.q[m][~pos], r[~pos], ".", ms=1, alpha=0.4, label="v < 0")
    ax.set_title("residual against position")
    ax.legend(fontsize=7, markerscale=6)
    ax = axes[0, 2]
    reg = regimes(data, alpha)[m]
    for i, name in enumerate(REGIMES):
        sel = reg == i
        ax.plot(c.v[m][sel], r[sel], ".", ms=1, alpha=0.4, label=name)
    ax.set_title("residual against velocity, by regime")
    ax.set_xlabel(f"v [{vu}]")
    ax.legend(fontsize=7, markerscale=6)
    ax = axes[1, 0]
    ac = bd["whiteness"]["autocorrelation"]
    ax.semilogx([a["lag_s"] for a in ac], [a["value"] for a in ac], "o-", ms=3)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_title(f"autocorrelation (corr. time {bd['whiteness']['correlation_time_ratio']:.1f}x filtered noise)")
    ax.set_xlabel("lag [s]")
    ax = axes[1, 1]
    names = [k for k, v in bd["cross_correlation"].items() if isinstance(v, float)]
    ax.barh(names, [bd["cross_correlation"][k] for k in names])
    ax.set_xlim(-1, 1)
    ax.set_title("correlation with physical signals")
    ax = axes[1, 2]
    rms = [bd["by_regime"][n]["rms"] or 0.0 for n in REGIMES]
    ax.bar(REGIMES, rms)
    ax.set_title("rms residual by regime")
    for a in axes.flat:
        a.grid(alpha=0.3)
        a.tick_params(labelsize=7)
    fig.suptitle(f"Where the model fails: {title}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def step_panels(data: FitData, before: np.ndarray, after: np.ndarray, path: Path,
                meta: dict | None = None, title: str = "") -> Path:
    """One diagnosis step side by side: map and residual before and after the effect."""
    vu, tu = _units(meta or {})
    m = data.mask
    c = data.c
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharey="col")
    for row, (label, model) in enumerate((("before", before), ("after", after))):
        r = (data.friction - model)[m]
        ax = axes[row, 0]
        ax.plot(c.v[m], data.friction[m], ".", ms=1, alpha=0.3, label="measured")
        ax.plot(c.v[m], model[m], ".", ms=1, alpha=0.4, color="tab:red", label="model")
        ax.set_title(f"map, {label}")
        ax.set_xlabel(f"v [{vu}]")
        ax.legend(fontsize=7, markerscale=6)
        ax = axes[row, 1]
        ax.plot(c.t[m], r, lw=0.5)
        ax.set_title(f"residual over time, {label} (rms {np.sqrt(np.mean(r * r)):.3g} {tu})")
        ax = axes[row, 2]
        pos = c.v[m] > 0
        ax.plot(c.q[m][pos], r[pos], ".", ms=1, alpha=0.4, label="v > 0")
        ax.plot(c.q[m][~pos], r[~pos], ".", ms=1, alpha=0.4, label="v < 0")
        ax.set_title(f"residual against position, {label}")
        ax.legend(fontsize=7, markerscale=6)
    for a in axes.flat:
        a.grid(alpha=0.3)
        a.tick_params(labelsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def error_fall(labels: list[str], rms: list[float], path: Path, meta: dict | None = None) -> Path:
    _, tu = _units(meta or {})
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.bar(range(len(rms)), rms, color=["tab:gray"] + ["tab:green"] * (len(rms) - 1))
    ax.set_xticks(range(len(rms)), labels, rotation=20, fontsize=8)
    ax.set_ylabel(f"held-out rms error [{tu}]")
    ax.set_title("Held-out error as effects are added")
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
