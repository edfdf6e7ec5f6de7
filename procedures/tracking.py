"""Tracking test (Section IV): PD + gravity along a smooth trajectory, with and without
friction feed-forward, the same trajectory every time.

Trajectory: q_d = c - a cos(w t), starting at rest at c - a, inside the workspace; peak
speed a w stays under half the velocity limit.  Controller: tau = g(q) + Kp e + Kd de + F_hat,
gains from the declared inertia (M wn^2, 2 M wn), F_hat from ``bench.compensation``.
Metrics per variant: RMS and max tracking error (after the first quarter period), and the
control signal's smoothness as the RMS of d tau / dt.  Plots like Figs. 6 and 9.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from bench.compensation import compensator
from bench.lugre import LuGreParams
from procedures.events import Emitter
from procedures.rig import Rig


@dataclass
class TrackingSettings:
    period: float = 4.0            # s, of the reference sine
    cycles: float = 2.0
    speed_fraction: float = 0.5    # peak reference speed, of the velocity limit
    amplitude_fraction: float = 0.3  # largest amplitude, of the half range
    bandwidth: float = 15.0        # rad/s, PD natural frequency with the declared inertia
    damping: float = 1.0


def reference(jid: str, rig: Rig, st: TrackingSettings):
    j = rig.joints[jid]
    lo, hi = j["position_limits"]
    w = 2 * math.pi / st.period
    a = min(st.amplitude_fraction * 0.5 * (hi - lo), st.speed_fraction * j["velocity_limit"] / w)
    return 0.5 * (lo + hi), a, w


def run_variant(rig: Rig, jid: str, params: LuGreParams | None, st: TrackingSettings, label: str) -> dict:
    c, a, w = reference(jid, rig, st)
    rig.move_to(jid, c - a)
    M = rig.inertia(jid)
    kp, kd = M * st.bandwidth ** 2, 2 * st.damping * M * st.bandwidth
    comp = compensator(params, rig.dt)
    n = int(round(st.cycles * st.period / rig.dt))
    out = {k: np.empty(n) for k in ("t", "qd", "q", "tau", "ff")}
    rig.segment = f"{jid}:tracking {label}"
    try:
        for i in range(n):
            t = i * rig.dt
            s = rig.samples[jid]
            qd, vd = c - a * math.cos(w * t), a * w * math.sin(w * t)
            ff = comp.update(s.velocity)
            tau = rig.gravity(jid, s.position) + kp * (qd - s.position) + kd * (vd - s.velocity) + ff
            lim = rig.joints[jid]["torque_limit"]
            tau = min(lim, max(-lim, tau))
            rig.step({jid: tau})
            out["t"][i], out["qd"][i], out["q"][i], out["tau"][i], out["ff"][i] = t, qd, s.position, tau, ff
    finally:
        rig.segment = ""
    rig.settle()
    rig.move_to(jid, c)
    skip = int(round(0.25 * st.period / rig.dt))
    e = (out["qd"] - out["q"])[skip:]
    dtau = np.diff(out["tau"][skip:]) / rig.dt
    out["metrics"] = {"rms_error": float(np.sqrt(np.mean(e ** 2))), "max_error": float(np.max(np.abs(e))),
                      "torque_rate_rms": float(np.sqrt(np.mean(dtau ** 2))),
                      "torque_rms": float(np.sqrt(np.mean(out["tau"][skip:] ** 2)))}
    return out


def tracking_test(rig: Rig, jid: str, models: dict[str, LuGreParams | None],
                  settings: TrackingSettings | None = None, emit: Emitter | None = None,
                  plot: str | Path | None = None, before_plot: Callable[[], None] | None = None) -> dict:
    """Run the same trajectory once per entry of ``models`` (label -> params, None = no
    compensation).  Returns {label: metrics, "ratios": ...} and writes a PNG if ``plot``;
    ``before_plot`` is called first (e.g. to park the drives: plotting takes a while)."""
    st = settings or TrackingSettings()
    runs = {}
    for label, params in models.items():
        runs[label] = run_variant(rig, jid, params, st, label)
        if emit is not None:
            emit.event("tracking", joint=jid, variant=label, **runs[label]["metrics"])
    result = {label: r["metrics"] for label, r in runs.items()}
    if "none" in runs and "identified" in runs:
        result["improvement"] = result["none"]["rms_error"] / max(result["identified"]["rms_error"], 1e-300)
    if "true" in runs and "identified" in runs:
        result["vs_true"] = result["identified"]["rms_error"] / max(result["true"]["rms_error"], 1e-300)
    if plot is not None:
        if before_plot is not None:
            before_plot()
        result["plot"] = str(plot_tracking(runs, jid, plot))
    return result


def plot_tracking(runs: dict, jid: str, path: str | Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    first = next(iter(runs.values()))
    ax[0].plot(first["t"], first["qd"], "k--", lw=1, label="desired")
    for label, r in runs.items():
        ax[0].plot(r["t"], r["q"], lw=1, label=f"actual ({label})")
        ax[1].plot(r["t"], r["qd"] - r["q"], lw=1,
                   label=f"{label}: RMS {r['metrics']['rms_error']:.3g}")
        ax[2].plot(r["t"], r["tau"], lw=0.8, label=label)
    ax[0].set_ylabel("position")
    ax[1].set_ylabel("tracking error")
    ax[2].set_ylabel("control torque")
    ax[2].set_xlabel("time [s]")
    for a_ in ax:
        a_.legend(fontsize=8, loc="upper right")
        a_.grid(alpha=0.3)
    fig.suptitle(f"{jid}: tracking with and without friction compensation")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def plot_map(records: list, inertia: float, path: str | Path, model: LuGreParams | None = None) -> Path:
    """Friction-velocity maps (Figs. 5, 8): eq. 5 on each record, model steady state on top."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import signal
    fig, ax = plt.subplots(figsize=(7, 5))
    vmax = 0.0
    for label, rec in records:
        dt = rec.dt
        sos = signal.butter(2, min(20.0, 0.05 / dt), fs=1 / dt, output="sos")
        v = signal.sosfiltfilt(sos, np.gradient(rec.q, dt))
        F = signal.sosfiltfilt(sos, rec.tau) - inertia * np.gradient(v, dt)
        ax.plot(v, F, lw=0.6, label=label)
        vmax = max(vmax, float(np.max(np.abs(v))))
    if model is not None and vmax > 0:
        vv = np.linspace(-vmax, vmax, 801)
        ax.plot(vv, model.steady_state(vv), "k--", lw=1, label="model steady state")
    ax.set_xlabel("velocity")
    ax.set_ylabel("friction")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)
