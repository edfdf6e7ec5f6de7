"""Robot joint logs with the joint at rest before and after its motion (holding its pose, the
PD loop on, process noise dithering it): the standstills are left out like gaps and the
segments that start at rest wait for the joint to slide (``bench.standstill``).  Before, on
tuning seeds 1310-1315, a 12 s rest either side took Fs to 0-0.64x the truth on j1-j4, the
rotary motor's Fc 21 % low, and credited a torque lag on j4.  Fresh seeds here."""
import pytest

from bench.analysis import analyze_record
from tests.diagnosis.test_conditions import _within
from virtual_drives.conditions import make_record, recording_for
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects

REST, DURATION = 12.0, 44.0
JOINTS = ("j1", "j2", "j3", "j4", "linear", "rotary", "j1", "j2")


def _resting_log(joint, seed, condition="robot joint log", effects=(), rest=REST, pause=0.0,
                 duration=DURATION):
    spec = PRESETS[joint]
    rec, _ = make_record(spec, recording_for(spec, condition, seed).with_(rest=rest, pause=pause), seed,
                         duration=duration, effects=effects)
    return spec, analyze_record(rec).report()


def test_clean_joints_at_rest_before_and_after_nothing_to_explain():
    misses = []
    for i, joint in enumerate(JOINTS):
        spec, doc = _resting_log(joint, 5450 + i)
        assert doc["resampling"]["standstills_cut"] and "stood still" in doc["warnings"][0]
        credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        if credited or doc["unexplained"]["structured"] or not _within(doc, spec):
            misses.append((joint, 5450 + i, credited, {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")}))
    assert len(misses) <= 1, misses


@pytest.mark.parametrize("joint, seed", [("j1", 5460), ("j2", 5461), ("j3", 5462), ("j4", 5463),
                                         ("j1", 5474), ("j2", 5475), ("j3", 5476), ("j4", 5477)])
def test_an_offset_at_rest_is_named_and_does_not_bend_the_friction(joint, seed):
    """An offset in the friction column is read at rest too: a segment that starts there must
    not take it for the bristles' deflection.  Over this travel an offset and gravity are one
    (README known limits), so either name is right.  5463 failed (a direction asymmetry) while
    only segments starting inside a standstill counted as starting at rest: its motion began
    just after a logger's gap; 5474-5477 were added after that change."""
    spec, doc = _resting_log(joint, seed, "robot joint log with offset")
    top = doc["diagnosis"][0]
    assert top["effect"] in ("torque_offset", "gravity") and top["significant"], doc["diagnosis"][:2]
    assert len(doc["final"]["effects"]) == 1, doc["final"]
    assert _within(doc, spec), doc["parameters"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]


@pytest.mark.parametrize("effect, joint, seed", [("direction_asymmetry", "j3", 5478), ("cogging", "j4", 5465),
                                                 ("thermal_drift", "j2", 5466)])
def test_a_library_effect_is_named_first_in_a_log_with_rests(effect, joint, seed):
    """(An inertia error was tried first, 5464: on a friction column it is one measurement with
    a lag of the reading, and the lag was named, as the README's known limits say.)"""
    spec = PRESETS[joint]
    texts = random_effects(spec, [effect], seed)
    _, doc = _resting_log(joint, seed, effects=texts)
    assert doc["diagnosis"][0]["effect"] == effect and doc["diagnosis"][0]["significant"], (texts, doc["diagnosis"][:2])
    assert doc["final"]["effects"] == [effect], (texts, doc["final"])
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"], texts
    assert not doc["unexplained"]["structured"], (texts, doc["unexplained"]["evidence"])


def test_a_pause_between_two_moves_is_cut_too():
    """The robot returns to its pose and holds it 10 s between two moves (rests of 6 s at the
    ends): the pause is cut like the rests, and the second move starts at rest.  (Tuning seed
    1350, j2: Fc +0.8 %; before the cut Fs 0.58x, alpha 150x and "unexplained".)"""
    misses = []
    for joint, seed in (("j1", 5480), ("j3", 5481), ("j4", 5482), ("linear", 5483)):
        duration = 22.0 + 12.0 / PRESETS[joint].excitation[1]    # three motion periods a move
        spec, doc = _resting_log(joint, seed, rest=6.0, pause=10.0, duration=duration)
        cuts = doc["resampling"]["standstills_cut"]
        # the pause (a logger's gap may split it): most of its inside cut
        inside = sum(max(0.0, min(c["t_end"], duration / 2 + 5) - max(c["t_start"], duration / 2 - 5)) for c in cuts)
        assert inside > 4.0, (joint, seed, cuts)
        credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        if credited or doc["unexplained"]["structured"] or not _within(doc, spec):
            misses.append((joint, seed, credited, {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")}))
    assert len(misses) <= 1, misses


def test_a_robot_joint_log_at_100_to_125_hz_with_rests_names_nothing():
    """The same arm published at 100-125 Hz (ROS joint_states, a UR's RTDE stream), at rest
    12 s either side of its motion, the logger stalling now and then — inside the rests too,
    where a stall once split a standstill into pieces too short to cut (tuning seed 1407:
    Fs 0.0001x on j1).  Nothing named and nothing left; the parameters within 5 % or honestly
    uncertain, but for the rotary motor (its slow-log gap, README known limits).  When written
    (2026-11-27): 8 of 8, j3's Fc -13.2 % within its reported errors, the rotary motor's -12.4 %;
    without the stall merge too, j1 on 5523 then -5.0 % (now -1.4 %)."""
    misses = []
    for i, joint in enumerate(JOINTS):
        spec, doc = _resting_log(joint, 5523 + i, "robot joint log at 100-125 Hz")
        credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        if credited or doc["unexplained"]["structured"] or (joint != "rotary" and not _within(doc, spec)):
            misses.append((joint, 5523 + i, credited, {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")}))
    assert len(misses) <= 1, misses
