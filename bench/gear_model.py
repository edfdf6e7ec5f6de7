"""What a load beyond the gear adds to the model (backlash, joint flexibility: ``bench.effects``),
per unit load inertia and filtered like the measurement: the load run through the gear
(``bench.terms``, the virtual joint's own recursion) along the measured motor trajectory, with or
without a share of the friction on the load.  Seen from a load-side encoder it is the motor's
lead over the load instead (``bench.load_side``)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from bench import terms
from bench.lugre import interval_to_samples
from bench.model_trace import lugre_samples, ones, remember, segment_z0, filtered_lugre
from bench.signals import Conditioned
from bench.grid_math import second_difference

if TYPE_CHECKING:
    from bench.fitting import FitData

def gear_unit_term(data: FitData, lugre: dict, width: float, frequency: float, damping: float,
                   kappa: float = 0.0, motor: np.ndarray | None = None) -> np.ndarray:
    """What a gear adds to the model per unit load inertia, filtered: qdd_load - qdd_motor;
    with a share of the friction on the load (``kappa`` = share / M_load) the load moves
    against F(v_load), and eq. 5 sees (1 - share) F(v_m) + share F(v_l) + M_l (qdd_l - qdd_m)
    = F(v_m) + M_l [kappa (F(v_l) - F(v_m)) + qdd_l - qdd_m]: still linear in M_l.  ``motor``:
    the model's filtered F(v_m) (plain LuGre when not given)."""
    if kappa <= 0:
        return gear_term(data.c, width, frequency, damping)
    lugre = dict(lugre)
    lugre.setdefault("delta", 1.0)
    if motor is None:
        motor = filtered_lugre(data, lugre)
    rel, load_friction = gear_friction_terms(data, width, frequency, damping, kappa, lugre)
    return rel + kappa * (load_friction - motor)


def _per_record(cache: dict, c: Conditioned, key: tuple, make):
    """``make()`` remembered for the record ``c`` (its id alone could be a dead record's)."""
    hit = cache.get((id(c), *key))
    if hit is not None and hit[0] is c:
        return hit[1]
    out = make()
    if len(cache) > 8:
        cache.clear()
    cache[(id(c), *key)] = (c, out)
    return out


_GEAR_CACHE: dict = {}


def gear_term(c: Conditioned, width: float, frequency: float, damping: float) -> np.ndarray:
    """(qdd_load - qdd_motor) on the grid, per unit load inertia.  Cached: a fit varies
    LuGre far more often than the gear."""
    return _per_record(_GEAR_CACHE, c, (width, frequency, damping),
                       lambda: _gear_term(c, width, frequency, damping))


def _gear_term(c: Conditioned, width: float, frequency: float, damping: float) -> np.ndarray:
    ev = terms.empty()
    ev[terms.BACKLASH], ev[terms.FLEX_FREQ], ev[terms.FLEX_DAMP] = width, frequency, damping
    gap, w2, c2 = terms.coupling(ev)
    # the load's step resolves the locked-rotor mode (h w <= 0.25), as the joint's does
    n_sub = int(min(64, max(1, math.ceil(c.dt * math.sqrt(w2) / 0.25))))
    rel = np.empty_like(c.q_full)      # qdd_load - qdd_motor, segment by segment (a gap
    for (a, b), (ia, ib) in zip(c.segments, c.interval_segments):   # restarts the gear)
        q, qm = _motor_trajectory(c, a, b, ia, ib)
        ql = terms.load_trajectory(qm, c.dt, n_sub, gap, w2, c2, *load_start(c, ia, ib, gap))
        rel[a:b] = second_difference(ql - qm, c.dt) + second_difference(qm - q, c.dt)
    return c.lowpass(rel)


def load_start(c: Conditioned, ia: int, ib: int, gap: float) -> tuple[float, float]:
    """(how far the load lags the motor, its speed) where a segment starts: with the motor, on
    the driving flank, where it slides (a segment after a gap, a log cut from a longer one),
    else at rest in the gap's centre.  Started at rest in the middle of a motion, the load rang
    through the segment: a 5.3 Hz gear of damping 0.05 on j4, one gap from 0.8 % of a jittered
    logger's samples lost, fitted with its frequency right, explained -90 % of the held-out
    residual, 85 % without the gap (soak seed 30089)."""
    if ib - ia < 2:
        return 0.0, 0.0
    v0 = 1.5 * float(c.v_mid[ia]) - 0.5 * float(c.v_mid[ia + 1])   # at the first sample, not over
    # its interval: j4's two-tone test starting from rest read 0.015 rad/s there, and a load
    # started so rang by 13 N*m (held-out 0.13 -> 0.35 without noise)
    if abs(v0) < c.sliding_speed:
        return 0.0, 0.0
    return math.copysign(gap, v0), v0


def _motor_trajectory(c: Conditioned, a: int, b: int, ia: int, ib: int):
    """(the encoder's samples, the motor as the friction model sees it) on a segment.  The gear
    is driven by the lightly smoothed velocity, integrated: fed the raw encoder, the stiff
    contact turns quantisation steps into load jitter that parts the flanks and biases the
    width (+10 % on j3 and the rotary motor, tuning seeds); the motor's own qdd stays the
    measured one, as in eq. 5."""
    q = c.q_full[a:b]
    qm = np.empty_like(q)
    qm[0] = q[0]
    qm[1:] = q[0] + np.cumsum(c.v_mid[ia:ib]) * c.dt
    return q, qm


def gear_friction_terms(data: FitData, width: float, frequency: float, damping: float,
                        kappa: float, lugre: dict) -> tuple[np.ndarray, np.ndarray]:
    """(qdd_load - qdd_motor, F(v_load)) filtered, for a load that carries friction: the load
    runs through the gear against the joint's LuGre law (``lugre``) on its own velocity
    (``bench.terms.load_trajectory_friction``), ``kappa`` = share / M_load.  It depends on the
    LuGre values, so it is kept per value like the motor's trace.

    Within a fit's Jacobian (``freeze_load`` in the cache) a LuGre step keeps the load's path
    of the point it steps from and changes only the friction along it: F(v_load) moves with
    Fc as F(v_motor) does (with all the friction on the load their changes cancel in eq. 5),
    while the path itself moves little."""
    c = data.c
    p = _kernel_order(lugre)
    gear = (width, frequency, damping, kappa, float(data.z0))
    last = data.cache.setdefault("gear_friction_last", {})
    if data.cache.get("freeze_load") and gear in last:   # a Jacobian's LuGre step (fit)
        base = last[gear]
        return base.rel, base.friction + c.lowpass(base.along(data, lugre) - base.along(data, base.lugre))
    key = (gear, tuple(p))

    def make():
        ev = terms.empty()
        ev[terms.BACKLASH], ev[terms.FLEX_FREQ], ev[terms.FLEX_DAMP] = width, frequency, damping
        gap, w2, c2 = terms.coupling(ev)
        # the locked-rotor mode as above, and the load's own presliding as the motor's, up to
        # what the samples see (``terms.SEEN_SUBSTEPS``)
        mode = min(64, math.ceil(c.dt * math.sqrt(w2) / 0.25))
        n_sub = max(1, mode, terms.substeps_for(c.dt, 1.0 / kappa, p[4], p[5], p[6], terms.SEEN_SUBSTEPS))
        rel = np.empty_like(c.q_full)
        friction = np.empty_like(c.q_full)
        path = np.empty_like(c.q_full)
        for k, ((a, b), (ia, ib), (g, _)) in enumerate(zip(c.segments, c.interval_segments, c.grid_segments)):
            q, qm = _motor_trajectory(c, a, b, ia, ib)
            ql, Fi = terms.load_trajectory_friction(qm, c.dt, n_sub, gap, w2, c2, p, kappa,
                                                    segment_z0(data, lugre, k, g), *load_start(c, ia, ib, gap))
            rel[a:b] = second_difference(ql - qm, c.dt) + second_difference(qm - q, c.dt)
            friction[a:b] = interval_to_samples(Fi) if b - a > 1 else 0.0
            path[a:b] = ql
        return _LoadPath(c.lowpass(rel), c.lowpass(friction), path, dict(lugre))
    out = remember(data.cache.setdefault("gear_friction", {}), key, make, 4)
    last[gear] = out
    while len(last) > 4:
        last.pop(next(iter(last)))
    return out.rel, out.friction


def _kernel_order(lugre: dict) -> np.ndarray:
    return np.array([lugre[k] for k in ("Fc", "Fs", "alpha", "delta", "sigma0", "sigma1", "sigma2")])


@dataclass
class _LoadPath:
    """A load's simulated path through the gear, and what the fit compares of it."""
    rel: np.ndarray           # filtered qdd_load - qdd_motor
    friction: np.ndarray      # filtered F(v_load)
    q: np.ndarray             # the load's position at the samples
    lugre: dict               # the LuGre values it was simulated with
    _along: dict = field(default_factory=dict)

    def along(self, data: FitData, lugre: dict) -> np.ndarray:
        """F(v_load) at the samples for ``lugre``, the load held on this path (its velocity
        held over each sample interval, as the motor's trace)."""
        key = tuple(_kernel_order(lugre))
        if key not in self._along:
            c = data.c
            v = np.empty(len(c.v_mid))
            for (a, b), (ia, ib) in zip(c.segments, c.interval_segments):
                v[ia:ib] = np.diff(self.q[a:b]) / c.dt
            F = lugre_samples(data, dict(lugre), ones(len(v)), ones(len(v)), v=v)
            if len(self._along) > 8:
                self._along.clear()
            self._along[key] = F
        return self._along[key]
