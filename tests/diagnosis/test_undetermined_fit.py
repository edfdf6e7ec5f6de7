"""A fit the record does not determine is not told as missing physics (bench.undetermined_fit).
The rotary stage (M q'' ~25x its friction) on a 124 Hz PC logger with jitter and lost samples:
its fit runs off (Fs thousands of times the truth), and the verdict and a warning now say so
first, with what to record instead; on a 1 kHz logger the same joint's fit holds and nothing is
said.  Independent simulator, fresh seed 10243 (found on seed 1970 and 10243 alone: the rule's
threshold was measured on seeds 1980-1985)."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.undetermined_fit import runaway, told
from independent_joint import independent_record
from virtual_drives.presets import PRESETS

ROTARY = PRESETS["rotary"]


def _doc(dt):
    rec, _ = independent_record(ROTARY, duration=30.0, seed=10243, dt=dt, jitter=0.6, drop=0.02,
                                disturbance=0.01 * ROTARY.friction.Fc)
    return analyze_record(rec, name="rotary").report()


@pytest.mark.parametrize("dt", [8e-3, 1e-3])
def test_a_fit_run_off_on_a_coarse_logger_is_said_first(dt):
    doc = _doc(dt)
    left = doc["unexplained"]
    if dt > 2e-3:
        assert left["fit_undetermined"] and left["structured"]
        assert left["look_for"][0].startswith("a record that determines the model first: a finer logger "
                                              "(this one samples at 124 Hz"), left["look_for"]
        assert left["evidence"].startswith("the record does not determine the LuGre model (Fs = "), left["evidence"]
        assert any(w.startswith("the fit ran off: Fs = ") for w in doc["warnings"]), doc["warnings"]
    else:       # the fit holds: nothing is said, whatever the verdict
        p = doc.get("final", {}).get("parameters") or doc["parameters"]
        assert abs(p["Fs"] / ROTARY.friction.Fs - 1) < 0.05, p
        assert not left["fit_undetermined"] and not any("ran off" in w for w in doc["warnings"])
        assert not left["look_for"] or not left["look_for"][0].startswith("a record that determines")


def test_the_rule_on_its_own():
    friction = np.concatenate([np.full(50, 0.3), np.full(50, -0.3)])
    assert runaway({"Fc": 0.2, "Fs": 0.85}, friction) is None          # within 3x of 0.3
    assert runaway({"Fc": 0.2, "Fs": 0.95}, friction).startswith("Fs = 0.95 lies beyond 3x")
    ok = {"parameters": {"Fc": 0.2, "Fs": 0.25}, "identifiable": {"Fc": True, "Fs": False, "sigma2": False},
          "unexplained": {"structured": True, "look_for": ["x"], "evidence": "e"}}
    assert not told(ok, friction, 1000.0, 50.0) and ok["unexplained"]["look_for"] == ["x"]
    none = dict(ok, identifiable={"Fc": False, "Fs": False, "sigma2": False},
                unexplained={"structured": False, "look_for": [], "evidence": "noise"})
    assert told(none, friction, 1000.0, 50.0)
    assert none["unexplained"] == {"structured": False, "look_for": [], "evidence": "noise", "fit_undetermined": True}


def test_a_fit_run_off_is_said_without_the_diagnosis_too():
    """`bench analyze --no-diagnosis`: no verdict to head, but a warning says it (here the
    LuGre-only fit is not determined rather than run off: Fc 4.7x the truth, all three values
    not identifiable)."""
    rec, _ = independent_record(ROTARY, duration=30.0, seed=10243, dt=8e-3, jitter=0.6, drop=0.02,
                                disturbance=0.01 * ROTARY.friction.Fc)
    doc = analyze_record(rec, diagnose_effects=False, name="rotary").report()
    assert "unexplained" not in doc
    assert any(w.startswith(("the fit ran off: F", "the record does not determine the LuGre model ("))
               and "a finer logger (this one samples at 124 Hz" in w for w in doc["warnings"]), doc["warnings"]
