"""A caller stops a long analysis at its next fit evaluation (bench.checkpoint): a run
cancelled while its joints are parked for the fit ends then, not when the fit would have."""
from __future__ import annotations

import itertools

import pytest

from bench.analysis import analyze_record
from bench.checkpoint import Stopped, stoppable
from procedures.events import Cancel, Cancelled
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import simulate_scenario


@pytest.fixture(scope="module")
def gear_record():
    # a geared joint with a hidden spring: the analysis runs identification, the diagnosis's
    # rounds and refits (fresh seed)
    sim, _ = simulate_scenario(PRESETS["j2"], ["joint_flexibility"], 5641, duration=10.0)
    return sim.record


def test_a_stop_late_in_the_analysis_is_not_taken_for_a_failed_refit(gear_record):
    asked = itertools.count(1)
    with stoppable(lambda: next(asked) < 0):         # never stops: count the evaluations
        full = analyze_record(gear_record).report()
    total = next(asked) - 1
    assert total > 100, total
    # stopped near the start and near the end (inside the diagnosis's refits, whose numerical
    # failures the analysis takes for candidates that did not fit): the stop goes through
    for at in (1, int(0.9 * total)):
        asked = itertools.count(1)
        with pytest.raises(Stopped), stoppable(lambda: next(asked) >= at):
            analyze_record(gear_record)
        assert next(asked) == at + 1, at                # it stopped at the first evaluation asked
    # and outside the block nothing stops it
    assert analyze_record(gear_record).report()["parameters"] == full["parameters"]


def test_a_cancel_during_the_fit_is_raised_as_cancelled_with_its_reason(gear_record):
    cancel = Cancel()
    cancel.set("cancelled by the technician")
    with pytest.raises(Cancelled, match="by the technician"), cancel.during_fit():
        analyze_record(gear_record)
    with Cancel().during_fit():                          # a token never set stops nothing
        assert analyze_record(gear_record).report()["parameters"]
