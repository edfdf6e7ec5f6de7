"""The shared LuGre kernel: exact bristle step, stability at high stiffness, steady state."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bench.lugre import LuGreParams, bristle_step, friction_trace, model_friction, stribeck_level


def test_exact_step_matches_closed_form():
    # sigma0 = 100, Fc = 0.5, Fs = 0.7, Stribeck exp(-(v/10)^2), z0 = 0.002, v = 0.5, h = 1 ms
    s = stribeck_level(0.5, 0.5, 0.7, 0.1, 2.0)
    z1, _ = bristle_step(0.002, 0.5, 1e-3, s, 100.0)
    assert abs(z1 - 0.00234457899) < 1e-10


def test_step_is_exact_over_any_split():
    # exactness: one step of 2h equals two steps of h when the velocity is held
    s = stribeck_level(0.3, 1.0, 1.5, 2.0, 1.0)
    one, _ = bristle_step(-0.001, 0.3, 2e-3, s, 1e4)
    half, _ = bristle_step(-0.001, 0.3, 1e-3, s, 1e4)
    two, _ = bristle_step(half, 0.3, 1e-3, s, 1e4)
    assert abs(one - two) < 1e-15


def test_mean_over_step_matches_quadrature():
    s = stribeck_level(0.2, 1.0, 1.4, 3.0, 1.0)
    z0, v, h, s0 = 1e-4, 0.2, 1e-3, 1e4
    _, zbar = bristle_step(z0, v, h, s, s0)
    ts = np.linspace(0, h, 20001)
    k = s0 * abs(v) / s
    zss = v / k
    z = zss + (z0 - zss) * np.exp(-k * ts)
    assert abs(zbar - np.trapezoid(z, ts) / h) < 1e-12


@settings(max_examples=200, deadline=None)
@given(v=st.lists(st.floats(-5, 5), min_size=5, max_size=60),
       sigma0=st.sampled_from([1.0, 1e2, 1e4, 1e6]),
       h=st.sampled_from([1e-4, 1e-3, 1e-2, 0.1]))
def test_bristle_state_stays_bounded_at_any_stiffness_and_step(v, sigma0, h):
    """|z| never exceeds max(|z0|, Fs/sigma0): the exact step cannot overshoot."""
    Fc, Fs = 1.0, 1.5
    zmax = Fs / sigma0
    z = 0.0
    for vi in v:
        s = stribeck_level(vi, Fc, Fs, 0.5, 1.0)
        z, zbar = bristle_step(z, vi, h, s, sigma0)
        assert abs(z) <= zmax * (1 + 1e-12)
        assert abs(zbar) <= zmax * (1 + 1e-12)


def test_steady_state_map_and_trace_agree_at_constant_velocity():
    p = LuGreParams(Fc=1500, Fs=1614, alpha=18, sigma0=1e6, sigma1=8900, sigma2=11262)
    for v in (-0.3, -0.05, 0.01, 0.2):
        q = v * np.arange(6000) * 1e-3
        F, _ = model_friction(p, q, 1e-3)
        assert F[-1] == pytest.approx(float(p.steady_state(v)), rel=1e-9 if abs(v) > 0.02 else 1e-7)


def test_high_stiffness_trace_is_finite_at_1khz():
    v = np.sin(np.linspace(0, 20, 20000)) * 0.4
    ones = np.ones_like(v)
    F, z = friction_trace(v, 1e-3, 0.0, 1500.0, 1614.0, 18.0, 1.0, 1e6, 8900.0, 11262.0, ones, ones, ones)
    assert np.all(np.isfinite(F)) and np.max(np.abs(z)) <= 1614.0 / 1e6 * (1 + 1e-12)


def test_passivity_warning():
    # Table I linear motor: Fs/Fc = 2.04 > 1 + sigma2/sigma1 = 1.02 -> not passive
    assert LuGreParams(2.4, 4.9, 6.7, 1e4, 500, 11.1).passivity_warning()
    # Table II joint 1 is passive
    assert LuGreParams(1500, 1614, 18, 1e6, 8900, 11262).passivity_warning() is None


def test_stribeck_exponent():
    p = LuGreParams(1.0, 2.0, 1.0, 1e3, 1.0, 0.0, delta=2.0)
    assert math.isclose(float(p.stribeck(0.5)), 1.0 + math.exp(-0.25), rel_tol=1e-12)
