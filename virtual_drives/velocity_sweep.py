"""The friction-velocity map experiment on a virtual joint (``bench simulate --excitation
sweep``): the joint tracks constant speeds back and forth across its workspace under the PD
loop of ``recording.make``, slowest speed first; each constant-speed stretch, once the loop
has settled, is one point of the map (eqs. 4-5 at constant speed: the friction is the mean
torque).  ``--map`` writes those points, as a lab publishes them, for ``bench analyze``.
"""
from __future__ import annotations

import math

import numpy as np

from bench.errors import InputError

LOW, HIGH = 0.15, 6.0    # the speeds span LOW/alpha (inside the Stribeck dip) to HIGH/alpha (viscous)
SPAN = 0.8               # share of the workspace the passes cover
HOLD = 3.0               # s of constant speed per direction and speed (short passes are repeated)
PASS_MAX = 8.0           # s: a slow pass covers at most this long, not the whole span
SETTLE = 0.2             # s left to the PD loop after each ramp (wn 60 rad/s, critically damped: ~0.08 s)
# ... and at least this many times the pass's catch-up time (Fs/kp + Fs/sigma0)/v: from a dwell
# the reference must run ahead by the loop's error Fs/kp and the bristles' presliding Fs/sigma0
# before the joint slides at its speed.  Averaged from 0.2 s, j2's slowest point (catch-up
# 0.18 s without the bristles) read 3 % slow and 45 N*m low; with 5x the loop's alone, j4's
# (soft bristles: sigma0 1e5) still read 2 % low, its dip fitted away.
CATCH_UP = 5.0
MIN_AVERAGED = 0.1       # s averaged at least per pass: faster speeds than allow this are left out
DWELL = 0.2              # s held at each end
MAX_LEVELS = 40
# the PD loop's reference "sines" for recording.pd_gains: none, so the default loop (wn 60 rad/s)
# unless --bandwidth; make() closes the loop with it and map_points() reads its kp
NO_SINES = ((1.0, 1.0),)


def speeds(spec, levels: int) -> np.ndarray:
    """``levels`` speeds, geometric from LOW/alpha to HIGH/alpha, the top kept within 90 % of
    the velocity limit and slow enough that a pass across the span holds its speed to average."""
    if not (isinstance(levels, int) and 4 <= levels <= MAX_LEVELS):
        raise InputError(f"--speeds must be a whole number from 4 to {MAX_LEVELS}, got {levels!r}")
    f = spec.friction
    lo, hi = spec.position_limits
    span = SPAN * (hi - lo)
    top = min(HIGH / f.alpha, 0.9 * spec.velocity_limit)
    while span / top - _ramp(spec, top) < SETTLE + MIN_AVERAGED:      # the pass too short to average
        top *= 0.9
    bottom = LOW / f.alpha
    if top <= 2 * bottom:
        raise InputError(f"joint {spec.name}: its workspace and velocity limit leave no range of speeds "
                         f"to sweep ({bottom:.3g} to {top:.3g})")
    return np.geomspace(bottom, top, levels)


def _ramp(spec, v: float) -> float:
    """s to reach speed v smoothly with at most half the torque limit beyond the friction."""
    a_max = max(0.5 * spec.torque_limit - spec.friction.Fs, 0.1 * spec.torque_limit) / spec.inertia
    return max(0.15, 0.5 * math.pi * v / a_max)


def reference(spec, levels: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The position reference (from the workspace's centre) and its speed, per ``dt``."""
    lo, hi = spec.position_limits
    centre, span = 0.5 * (lo + hi), SPAN * (hi - lo)

    def shape(x):       # a raised-cosine ramp from 0 to 1
        return 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))

    def move(pos, d, v, length):
        ramp = _ramp(spec, v)
        T = length / v + ramp
        s = np.arange(1, int(T / dt) + 1) * dt
        return pos + d * np.cumsum(v * np.minimum(shape(s / ramp), shape((T - s) / ramp))) * dt

    levels_ = speeds(spec, levels)
    approach = move(centre, -1.0, levels_[-1], 0.5 * span)    # to the lower end, fast: a pass of its own
    out = [np.full(int(DWELL / dt), centre), approach, np.full(int(DWELL / dt), approach[-1])]
    pos, d = approach[-1], 1.0
    for v in levels_:
        length = min(span, v * PASS_MAX)
        passes = max(1, math.ceil(HOLD / (length / v)))
        for _ in range(2 * passes):
            seg = move(pos, d, v, length)
            out += [seg, np.full(int(DWELL / dt), seg[-1])]
            pos, d = seg[-1], -d
    q_ref = np.concatenate(out)
    return q_ref, np.gradient(q_ref, dt)


def duration(spec, levels: int, rate: float) -> float:
    return len(reference(spec, levels, 1.0 / rate)[0]) / rate


def stretches(v_ref: np.ndarray, dt: float, catch_up: float = 0.0) -> list[tuple[int, int]]:
    """The constant-speed part of each pass, after the loop's settling: (first, end) indices.
    ``catch_up``: Fs/kp, the reference's lead at which the loop breaks the joint away."""
    moving = np.abs(v_ref) > 1e-12
    edges = np.flatnonzero(np.diff(moving.astype(np.int8))) + 1
    out = []
    for a, b in zip(edges[::2], edges[1::2]):
        top = np.abs(v_ref[a:b]).max()
        flat = a + np.flatnonzero(np.abs(v_ref[a:b]) >= (1 - 1e-6) * top)
        first = flat[0] + int(round(max(SETTLE, CATCH_UP * catch_up / top) / dt))
        if flat[-1] - first >= int(round(MIN_AVERAGED / dt)):
            out.append((first, flat[-1]))
    return out


def map_points(record, truth) -> tuple[np.ndarray, np.ndarray]:
    """One point a pass: its mean velocity (displacement over time, as a lab measures it from
    the encoder) and its mean recorded torque (or friction), from the record's own samples."""
    from virtual_drives.recording import pd_gains
    dt = truth.t[1] - truth.t[0]
    t0 = record.t[0] - truth.t[0]             # a logger's clock may start elsewhere
    kp, _ = pd_gains(truth.spec, truth.recording, NO_SINES)
    v_out, F_out = [], []
    f = truth.friction_params
    for a, b in stretches(np.gradient(truth.q_ref, dt), dt, f.Fs / kp + f.Fs / f.sigma0):
        k = (record.t - t0 >= truth.t[a]) & (record.t - t0 <= truth.t[b])
        if k.sum() < 3:
            continue
        t, q, tau = record.t[k], record.q[k], record.tau[k]
        v_out.append((q[-1] - q[0]) / (t[-1] - t[0]))
        F_out.append(float(np.mean(tau)))
    return np.array(v_out), np.array(F_out)


def write_map(path, v: np.ndarray, F: np.ndarray, record) -> None:
    """``velocity [unit/s], torque [unit]`` rows under the record's own ``#`` lines (joint,
    source, seed; no rate: the rows are points, not samples)."""
    meta = record.meta
    pu, tu = meta["position_unit"], meta["torque_unit"]
    name = "friction" if meta.get("torque_column") else ("force" if meta["joint_type"] == "prismatic" else "torque")
    keep = ("joint", "joint_type", "source", "excitation", "seed", "condition")
    head = "".join(f"# {k}: {meta[k]}\n" for k in keep if k in meta)
    rows = "".join(f"{a:.10g},{b:.10g}\n" for a, b in zip(v, F))
    with open(path, "w") as fh:
        fh.write(f"{head}velocity [{pu}/s],{name} [{tu}]\n{rows}")
