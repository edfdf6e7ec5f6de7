"""The model's friction along a record, filtered like the measurement: the LuGre trace
(``bench.lugre.friction_trace`` along the measured velocity, segment by segment) with the terms'
level, viscous and damping multipliers, and the additive terms' filtered columns.  The fit
(``bench.fitting.predict``) asks for these tens of thousands of times per record, so each is
remembered for the last few values it depends on."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from bench import terms
from bench.lugre import PARAMETER_NAMES, friction_trace, interval_to_samples
from bench.signals import Conditioned

if TYPE_CHECKING:
    from bench.fitting import FitData

_ONES: dict[int, np.ndarray] = {}


def ones(n: int) -> np.ndarray:
    if n not in _ONES:
        _ONES.clear()
        _ONES[n] = np.ones(n)
    return _ONES[n]


def remember(cache: dict, key, make, size: int):
    """``cache[key]``, made by ``make()`` when missing; the oldest entries go beyond ``size``."""
    hit = cache.get(key)
    if hit is None:
        hit = cache[key] = make()
        while len(cache) > size:
            cache.pop(next(iter(cache)))
    return hit


def filtered_lugre(data: FitData, lugre: dict) -> np.ndarray:
    """The plain LuGre friction of ``lugre`` (with "delta"), filtered like the measurement."""
    return filtered_terms_lugre(data, lugre, terms.empty())


def filtered_terms_lugre(data: FitData, lugre: dict, ev: np.ndarray,
                         along: tuple | None = None) -> np.ndarray:
    """The LuGre friction with the terms' level and viscous multipliers, filtered.  Remembered
    for the last few values: a finite-difference Jacobian steps one value at a time, and every
    step of a non-LuGre value reuses the trace of the point it steps from.  ``along``: (key,
    velocity over each interval) to run it along another velocity than the measured one."""
    c = data.c
    level_key = tuple(float(ev[i]) for i in terms.LEVEL_SLOTS)
    add0 = rest_start_additive(c, ev)
    # the bristle start z0 is set on the data by identification, so it is part of the key
    key = (tuple(float(lugre[k]) for k in (*PARAMETER_NAMES, "delta")), level_key, float(data.z0),
           None if along is None else along[0], tuple(add0.items()))

    def make():
        if any(level_key):
            level, visc, damp = remember(data.cache.setdefault("level", {}), level_key,
                                          lambda: multipliers(c, ev), 4)
        else:
            level = visc = damp = ones(len(c.v_mid))
        return c.lowpass(lugre_samples(data, lugre, level, visc, v=None if along is None else along[1],
                                       add0=add0, damp=damp))
    return remember(data.cache.setdefault("lugre", {}), key, make, 6)


def rest_start_additive(c: Conditioned, ev: np.ndarray) -> dict:
    """{segment: the additive terms (offset, gravity, cogging) at its first sample} for the
    segments that start at rest beside a long standstill (``bench.standstill``), the record's
    first among them.  Their bristle start is read from the friction there, and the model's
    own additive torque is not the bristles' deflection: an offset read as one was counted
    twice (j4's robot joint log with an offset of Fc/4 and 12 s of rest either side, tuning
    seed 1321: 175 N·m, the offset and more, left where the motion began, and a direction
    asymmetry named instead of the offset)."""
    if not c.rest_starts or not ev[list(terms.ADDITIVE_SLOTS)].any():
        return {}
    out = {}
    for k, (g, _) in enumerate(c.grid_segments):
        if k in c.rest_starts:
            add, _, _ = terms.effect_terms(c.q[g:g + 1], c.v[g:g + 1], c.t[g:g + 1], ev)
            out[k] = float(add[0])
    return out


def multipliers(c: Conditioned, ev: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(level, viscous, damping) multipliers over each sample interval."""
    _, level, visc = terms.effect_terms(c.q_mid, c.v_mid, c.t_mid, ev)
    return (np.ascontiguousarray(np.maximum(level, 1e-6)), np.ascontiguousarray(visc),
            np.ascontiguousarray(terms.damping(c.v_mid, ev)))


def filtered_columns(c: Conditioned, key, columns) -> np.ndarray:
    """``columns(q)`` at the samples, each filtered: the offset and gravity columns, and those
    of the last few cogging pitches."""
    cache = c.__dict__.setdefault("_additive_columns", {})
    return remember(cache, key, lambda: np.array([c.lowpass(col) for col in columns(c.q_full)]), 4)


def lugre_samples(data: FitData, p: dict, level: np.ndarray, visc: np.ndarray,
                   v: np.ndarray | None = None, add0: dict | None = None,
                   damp: np.ndarray | None = None) -> np.ndarray:
    """LuGre friction at the full-rate samples, simulated segment by segment: the bristle
    state restarts at each segment (a gap hides what it did), from the friction estimate at
    the segment's start as for the first (``data.z0``).  Along the motor's velocity, or ``v``
    (held over each interval, as ``c.v_mid``).  ``add0``: the additive torque at the start of
    segments whose bristle start leaves it out (``rest_start_additive``)."""
    c = data.c
    v = c.v_mid if v is None else v
    args = (p["Fc"], p["Fs"], p["alpha"], p["delta"], p["sigma0"], p["sigma1"], p["sigma2"])
    damp = ones(len(v)) if damp is None else damp
    if len(c.segments) == 1 and not add0:
        F, _ = friction_trace(v, c.dt, data.z0, *args, level, visc, damp)
        return interval_to_samples(F)
    parts = []
    for k, ((a, b), (g, _)) in enumerate(zip(c.interval_segments, c.grid_segments)):
        z0 = segment_z0(data, p, k, g)
        if add0 and k in add0:
            lim = p["Fs"] / p["sigma0"]
            z0 = float(np.clip(z0 - add0[k] / p["sigma0"], -lim, lim))
        F, _ = friction_trace(v[a:b], c.dt, z0, *args, level[a:b], visc[a:b], damp[a:b])
        parts.append(interval_to_samples(F) if b > a else np.zeros(1))
    return np.concatenate(parts)


def segment_z0(data: FitData, p: dict, k: int, g: int) -> float:
    """The bristle state a segment starts from: the first from identification's ``z0``, the
    others from the friction estimate at their start (grid index ``g``)."""
    if k == 0:
        return data.z0
    lim = p["Fs"] / p["sigma0"]
    return float(np.clip(data.friction[min(g, len(data.friction) - 1)] / p["sigma0"], -lim, lim))
