"""A noisy reading's steps, as the perfect-model replay reads its twin through them
(``bench.perfect_model``): the expected reading under Gaussian dither, and the dither that
makes a twin as rough as a record.  Numbers only: fast."""
import numpy as np
import pytest

from bench.perfect_model import dither, expected_reading


@pytest.mark.parametrize("sigma", [0.0, 0.05, 0.2, 0.45])
def test_the_expected_reading_is_the_mean_of_many_noisy_readings(sigma):
    rng = np.random.default_rng(5519)
    x = np.linspace(-3.0, 3.0, 1201)
    step = 0.7
    draws = 4000
    mean = np.mean([np.round((x + sigma * rng.standard_normal(len(x))) / step) * step
                    for _ in range(draws)], axis=0)
    got = expected_reading(x, step, sigma)
    # the Monte-Carlo mean's standard error: a reading spreads by the noise and half a step
    se = np.hypot(sigma, 0.5 * step) / np.sqrt(draws)
    assert np.max(np.abs(got - mean)) < 5.0 * se      # 5 standard errors over 1201 points
    if sigma >= 0.2 * step:    # dithered: much closer to x than the plain steps are
        plain = np.round(x / step) * step
        assert np.mean(np.abs(got - x)) < 0.5 * np.mean(np.abs(plain - x))


@pytest.mark.parametrize("sigma", [0.0, 0.08, 0.25, 0.5])
def test_the_dither_is_read_back_from_a_records_roughness(sigma):
    """A smooth torque (a slow sine and a faster tone) read with noise through steps of 1: the
    twin is the same smooth torque, so the noise is recovered."""
    rng = np.random.default_rng(5520)
    t = np.arange(30000) * 1e-3
    smooth = 12.0 * np.sin(2 * np.pi * 0.4 * t) + 3.0 * np.sin(2 * np.pi * 2.3 * t)
    record = np.round(smooth + sigma * rng.standard_normal(len(t)))
    pieces = [slice(0, 11000), slice(11000, 30000)]      # a gap between two pieces
    got = dither([record[p] for p in pieces], [smooth[p] for p in pieces], 1.0)
    assert got == pytest.approx(sigma, abs=0.02)
