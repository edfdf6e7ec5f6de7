"""The diagnosis's second start (bench.measured_start): a friction level the LuGre fit left on
the edge of its search is no estimate, and Section III's map-read values stand in for it."""
import math

import numpy as np

from bench.fitting import LUGRE_KEYS, FitResult, Param
from bench.measured_start import levels_on_bound, measured_start

START = {"Fc": 560.0, "Fs": 620.0, "alpha": 48.0, "sigma0": 5e4, "sigma1": 5e3, "sigma2": 3400.0}


def _fit(**moved) -> FitResult:
    """A fit searched e^9 around START (bench.identify._fit_lugre), ended at START * moved."""
    params = [Param(k, v, True, math.log(v) - 9, math.log(v) + 9) for k, v in START.items()]
    values = {k: v * moved.get(k, 1.0) for k, v in START.items()}
    return FitResult(values=values, stderr={k: None for k in values}, residual=np.zeros(3), rms=1.0,
                     nrmse=0.1, cost=1.0, n_eff_fraction=1.0, success=True, params=params)


def test_a_level_on_the_edge_of_the_search_is_found_and_the_map_read_values_take_its_place():
    res = _fit(Fs=math.exp(8.99))
    assert levels_on_bound(res) == ["Fs"]
    start, note = measured_start(res, dict(START, v_max=0.3))
    assert {k: start.values[k] for k in LUGRE_KEYS} == START
    assert "ran Fs to the edge of its search" in note and "Section III" in note
    assert res.values["Fs"] == START["Fs"] * math.exp(8.99)      # the fit itself is untouched


def test_a_level_far_inside_the_search_or_not_a_level_starts_nowhere_else():
    # 320x the start (j4 tuning seed 1502's Fs) is still a fit; alpha may run where the record
    # never traverses the Stribeck decay (the report says so) and is not a level
    for res in (_fit(Fs=320.0), _fit(alpha=math.exp(-8.99)), _fit()):
        start, note = measured_start(res, dict(START))
        assert start is res and note is None
    assert levels_on_bound(_fit(sigma2=math.exp(-8.99))) == ["sigma2"]


def test_without_every_section_iii_value_the_fit_stands():
    res = _fit(Fs=math.exp(8.99))
    for missing in ({"sigma0": None}, {"sigma1": float("nan")}, {"alpha": -3.0}):
        start, note = measured_start(res, dict(START, **missing))
        assert start is res and note is None
