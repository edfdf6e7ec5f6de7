"""The held-out correction's trust region (``CrossValidation.sse``, ``MIN_TRAIN_SHARE``): a
sensitivity the training folds barely see is not extrapolated into the held-out fold where it
lives (the motor's inertia behind a load-side backlash under PD tracking: one motion segment),
while one they do see still corrects it."""
from types import SimpleNamespace

import numpy as np
import pytest

from bench.screening import MIN_TRAIN_SHARE, CrossValidation


def _cv():
    t = np.arange(0.0, 12.0, 1e-3)
    f, amp = 0.5, 0.4
    q = amp * np.sin(2 * np.pi * f * t)
    v = 2 * np.pi * f * amp * np.cos(2 * np.pi * f * t)
    c = SimpleNamespace(t=t, q=q, v=v, cutoff=50.0, dt_grid=1e-3, periodic=True, frequency=f)
    return CrossValidation(SimpleNamespace(c=c, mask=np.ones_like(t, dtype=bool)))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_column_living_in_one_segment_is_not_extrapolated_into_it(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    cv = _cv()
    n, last = len(cv.idx), cv.block == cv.n_blocks - 1
    seen = rng.standard_normal(n)                     # a sensitivity every segment has
    lone = np.where(last, 50.0 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n))
    share = float(np.sum(lone[~last] ** 2) / np.sum(lone ** 2))
    assert share < MIN_TRAIN_SHARE                    # what the training folds see of it
    r = 0.7 * seen + 0.3 * rng.standard_normal(n) + np.where(last, 1.0, 0.0)
    with_seen = cv.sse(seen[:, None], r)
    with_both = cv.sse(np.column_stack([seen, lone]), r)
    assert with_both.sum() == pytest.approx(with_seen.sum(), rel=0.01)
    assert with_seen.sum() < 0.5 * cv.sse(np.zeros((n, 1)), r).sum()   # the seen one still corrects
    # without the trust region the lone column's correction is fitted on what the training
    # folds see of it (noise) and blown up in the last segment
    monkeypatch.setattr("bench.screening.MIN_TRAIN_SHARE", 0.0)
    assert cv.sse(np.column_stack([seen, lone]), r).sum() > 10 * with_seen.sum()


def test_a_column_the_training_folds_see_is_fitted_there():
    rng = np.random.default_rng(3)
    cv = _cv()
    n = len(cv.idx)
    x = rng.standard_normal(n) * np.where(cv.block < 4, 1.0, 0.2)   # uneven, but seen everywhere
    r = 0.8 * x + 0.1 * rng.standard_normal(n)
    assert cv.sse(x[:, None], r).sum() < 0.1 * float(r @ r)
