import numpy as np
import pytest

from bench.compensation import LuGreObserver
from bench.lugre import LuGreParams, friction_trace

P = LuGreParams(Fc=105.0, Fs=116.0, alpha=5.0, sigma0=1e5, sigma1=800.0, sigma2=1878.0)


def test_observer_matches_the_shared_model_along_a_trace():
    dt = 1e-3
    t = np.arange(4000) * dt
    v = 0.3 * np.sin(2 * np.pi * 0.5 * t)
    one = np.ones_like(v)
    F_ref, _ = friction_trace(v, dt, 0.0, P.Fc, P.Fs, P.alpha, P.delta, P.sigma0, P.sigma1, P.sigma2, one, one, one)
    obs = LuGreObserver(P, dt)
    F = np.array([obs.update(x) for x in v])
    # same kernel: steady sliding agrees to round-off, transitions to a fraction of Fs
    sliding = np.abs(v) > 0.1
    assert np.max(np.abs(F - F_ref)[sliding]) < 1e-3 * P.Fc
    assert np.max(np.abs(F - F_ref)) < 0.1 * P.Fs


def test_observer_steady_state_is_eq_6c():
    obs = LuGreObserver(P, 1e-3)
    for _ in range(3000):
        F = obs.update(0.2)
    assert F == pytest.approx(float(P.steady_state(0.2)), rel=1e-9)
