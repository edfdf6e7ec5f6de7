"""The breakaway-after-rest statistic (``bench.rest_memory``) on motions built by hand: moves
between rests of known length, a residual whose breakaway level is set per move."""
from types import SimpleNamespace

import numpy as np

from bench.rest_memory import at_rest, grows, rest_before, rest_memory

DT = 0.01


def _moves(rests, level_of_rest, seed=0, noise=0.01):
    """Rests of the given lengths, each followed by a 0.6 s move (a half sine in velocity,
    directions alternating); the residual is noise plus, over each move's first 0.15 s, the
    level ``level_of_rest(rest)`` against the motion."""
    rng = np.random.default_rng(seed)
    v, r = [], []
    for k, rest in enumerate(rests):
        n_rest, n_move = int(round(rest / DT)), int(round(0.6 / DT))
        d = 1.0 if k % 2 == 0 else -1.0
        v += [0.0] * n_rest + list(d * np.sin(np.pi * (np.arange(n_move) + 0.5) / n_move))
        bump = np.zeros(n_move)
        bump[: int(0.15 / DT)] = level_of_rest(rest)
        r += [0.0] * n_rest + list(d * bump)
    v, r = np.array(v), np.array(r) + noise * rng.standard_normal(len(v))
    t = np.arange(len(v)) * DT
    c = SimpleNamespace(t=t, v=v, q=np.cumsum(v) * DT)
    return c, r, np.ones(len(t), dtype=bool)


def test_rest_before_counts_the_last_rest():
    t = np.arange(12) * 0.1
    v = np.array([0, 0, 1, 1, 1, 0, 0, 0, 2, 2, 0, 3.0])
    np.testing.assert_allclose(rest_before(t, at_rest(v)), [0, .1, .1, .1, .1, 0, .1, .2, .2, .2, 0, 0], atol=1e-12)


def test_a_rest_is_not_counted_across_a_gap_nor_before_the_record_opens():
    t = np.r_[np.arange(6), np.arange(10, 16)] * 0.1            # a gap of 0.4 s after the 6th sample
    v = np.array([1, 0, 0, 0, 0, 0, 0, 0, 1, 1, 0, 1.0])
    first = np.zeros(12, dtype=bool)
    first[[0, 6]] = True
    np.testing.assert_allclose(rest_before(t, at_rest(v), first), [0, 0, .1, .2, .3, .4, 0, .1, .1, .1, 0, 0],
                               atol=1e-12)
    # the same motion as one record and as two segments split inside the third rest: the
    # starts whose rest opened the record or a segment are left out, and the rest is one fewer
    rests = np.random.default_rng(4).uniform(0.2, 2.0, 30)
    c, r, mask = _moves(rests, lambda s: 0.05 * s)
    whole = rest_memory(c, r, mask)["starts"]
    cut = int(np.searchsorted(c.t, rests[0] + 0.6 + rests[1] + 0.6 + 0.5 * rests[2]))
    c.grid_segments = [(0, cut), (cut, len(c.t))]
    assert rest_memory(c, r, mask)["starts"] == whole - 1 == 28


def test_a_breakaway_that_grows_with_the_rest_is_found_and_one_that_does_not_is_not():
    rests = np.random.default_rng(1).uniform(0.2, 2.0, 30)
    c, r, mask = _moves(rests, lambda s: 0.05 * s)
    p = rest_memory(c, r, mask)
    assert p["starts"] >= 25 and p["slope"] > 0 and p["t"] > 10, p
    assert abs(p["slope"] / 0.05 - 1) < 0.2, p
    assert grows(p, friction_level=1.0, min_size=0.01, min_predicted=0.1, t_crit=3.0)
    # the same levels drawn apart from the rests: no trend
    levels = iter(np.random.default_rng(2).permutation(0.05 * rests))
    c, r, mask = _moves(rests, lambda s: next(levels))
    p = rest_memory(c, r, mask)
    assert not grows(p, friction_level=1.0, min_size=0.01, min_predicted=0.1, t_crit=3.0), p
    # a breakaway that weakens with the rest is not static friction rising with dwell
    c, r, mask = _moves(rests, lambda s: -0.05 * s)
    p = rest_memory(c, r, mask)
    assert p["t"] < -10 and not grows(p, friction_level=1.0, min_size=0.01, min_predicted=0.1, t_crit=3.0), p


def test_alike_rests_and_too_few_starts_are_not_tested():
    c, r, mask = _moves(np.full(30, 0.5), lambda s: 0.05 * s)
    assert rest_memory(c, r, mask)["t"] == 0.0          # one repeated motion: nothing varies
    c, r, mask = _moves(np.linspace(0.2, 2.0, 6), lambda s: 0.05 * s)
    p = rest_memory(c, r, mask)
    assert p["starts"] == 5 and p["t"] == 0.0           # the rest opening the record is not one
    # a direction's own level is not taken for the rest's when the rests differ by direction
    rests = np.where(np.arange(30) % 2 == 0, 1.5, 0.3) + np.random.default_rng(3).uniform(0, 0.1, 30)
    k = iter(range(30))
    c, r, mask = _moves(rests, lambda s: 0.1 if next(k) % 2 == 0 else 0.0)
    assert not grows(rest_memory(c, r, mask), friction_level=1.0, min_size=0.01, min_predicted=0.1, t_crit=3.0)
