"""The travel-halves test of a position series (``CrossValidation.explained_across_halves``):
a function of position carries from one half of the travel to the other; a structure locked to
the speed of a repeated sine is mirrored about the travel's middle and does not."""
from types import SimpleNamespace

import numpy as np
import pytest

from bench.screening import HALVES_SHARE, CrossValidation


def _cv_and_columns(pitch, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 20.0, 1e-3)
    f, amp = 0.5, 0.4
    q = amp * np.sin(2 * np.pi * f * t) + 0.1
    v = 2 * np.pi * f * amp * np.cos(2 * np.pi * f * t)
    c = SimpleNamespace(t=t, q=q, v=v, cutoff=50.0, dt_grid=1e-3, periodic=True, frequency=f)
    cv = CrossValidation(SimpleNamespace(c=c, mask=np.ones_like(t, dtype=bool)))
    qi, vi = q[cv.idx], v[cv.idx]
    # LuGre's own re-adjustment, roughly: a level per direction and a viscous slope
    J = np.column_stack([np.sign(vi), vi])
    X = np.column_stack([np.sin(2 * np.pi * qi / pitch), np.cos(2 * np.pi * qi / pitch)])
    noise = 0.05 * rng.standard_normal(len(qi))
    return cv, qi, vi, J, X, noise


def _sse(A, y):
    return float(np.sum((y - A @ np.linalg.lstsq(A, y, rcond=None)[0]) ** 2))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_function_of_position_carries_across_the_halves(seed):
    cv, qi, vi, J, X, noise = _cv_and_columns(0.037, seed)
    r = 0.3 * np.sign(vi) + 0.2 * np.sin(2 * np.pi * qi / 0.037 + 1.1) + noise
    assert cv.explained_across_halves(J, X, r) > 0.95


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_structure_locked_to_the_speed_does_not(seed):
    # under one sine |v| is a function of the distance from the travel's middle, so a residual
    # that depends on the speed (a dip's shape, creep) is a function of that distance: here one
    # periodic in it, which the series fits on either half but mirrored
    cv, qi, vi, J, X, noise = _cv_and_columns(0.037, seed)
    middle = 0.5 * (qi.min() + qi.max())
    r = 0.3 * np.sign(vi) + 0.2 * np.sin(2 * np.pi * np.abs(qi - middle) / 0.037) + noise
    both = np.column_stack([J, X])
    for half in (qi < middle, qi > middle):
        own = 1 - _sse(both[half], r[half]) / _sse(J[half], r[half])
        assert own > 0.5, "the series must fit it on each half, or the test tests nothing"
    assert cv.explained_across_halves(J, X, r) < HALVES_SHARE
