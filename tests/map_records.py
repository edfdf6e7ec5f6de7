"""Friction-velocity maps as a lab makes them: the independent simulator's joint swept at a
series of constant speeds under a PID loop (``independent_joint.velocity_steps``), each
constant-speed pass averaged into one point (its mean velocity from the displacement, its mean
torque), the loop's settling left out.  Not this project's model: the joint, its loop and its
noise are the independent simulator's."""
from __future__ import annotations

import numpy as np

from independent_joint import independent_record, velocity_steps
from tests.diagnosis.test_independent_records import _travel

SETTLE = 0.5      # s of each constant-speed stretch left to the loop before averaging
STEADY = 0.02     # a stretch whose speed still changes by this share is no steady point: dropped
HOLD = 4.0        # s: each speed's pass is at least this long (a lab sweeps the joint's range)


def swept_map(spec, seed: int, levels: int = 12, physics: dict | None = None, felt: bool = True,
              sweeps: int = 1, low: float = 0.15, high: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """(velocity, friction) points of ``spec``'s joint: ``levels`` speeds from ``low``/alpha
    to ``high``/alpha, both directions, ``sweeps`` times over (repeated speeds);
    ``felt``: a disturbance of 1 % of Fc the record does not hold, else 2 % reading noise."""
    f = spec.friction
    travel = _travel(spec)
    speeds = np.geomspace(low / f.alpha, high / f.alpha, levels)
    while np.sum(2.0 * travel / speeds) > 80.0:        # a sweep of a minute or so
        speeds = np.geomspace(1.15 * speeds[0], speeds[-1], levels)
    # each speed back and forth from one pose, over the travel or HOLD s, whichever is longer
    one = [velocity_steps(max(travel, HOLD * s), [s]) for s in speeds]
    ref = np.concatenate([seg - seg[0] for seg in one] * sweeps)
    noise = dict(disturbance=0.01 * f.Fc) if felt else dict(torque_noise=0.02 * f.Fc)
    rec, _ = independent_record(spec, duration=len(ref) * 1e-3, seed=seed, pd=(6.0, 0.0, 1.5),
                                reference=ref, physics=physics, **noise)
    speed = np.gradient(ref, 1e-3)
    v_out, F_out = [], []
    moving = np.abs(speed) > 0
    edges = np.flatnonzero(np.diff(moving.astype(int)))
    for a, b in zip(edges[::2] + 1, edges[1::2] + 1):          # each pass
        top = np.abs(speed[a:b]).max()
        flat = a + np.flatnonzero(np.abs(np.abs(speed[a:b]) - top) <= 1e-6 * top)
        lo, hi = flat[0] + int(SETTLE / 1e-3), flat[-1]
        if hi - lo < 200:
            continue
        k = (rec.t >= rec.t[0] + lo * 1e-3) & (rec.t <= rec.t[0] + hi * 1e-3)
        t, q, tau = rec.t[k], rec.q[k], rec.tau[k]
        tenth = max(len(t) // 10, 2)
        first = (q[tenth] - q[0]) / (t[tenth] - t[0])
        last = (q[-1] - q[-tenth]) / (t[-1] - t[-tenth])
        v = (q[-1] - q[0]) / (t[-1] - t[0])
        if abs(last - first) > STEADY * abs(v):
            continue
        v_out.append(v)
        F_out.append(float(np.mean(tau)))
    return np.array(v_out), np.array(F_out)


def write_map(path, v, F, header=("velocity [rad/s]", "torque [N*m]")) -> None:
    np.savetxt(path, np.column_stack([v, F]), delimiter=",", header=",".join(header), comments="")
