"""A torque read in steps, as a drive reports it (CiA 402's 0x6077 counts per mille of the rated
torque): the steps are a measurement's, not physics.  With the reading noise too small to
dither them, steps of 10-20 % of Fc left a structure the learner predicts on tuning seeds
(1361, 1370-1375: "unexplained" on j1, j2, j4 and the rotary motor, `position_dependent_friction`
credited on j4).  Now an effect must explain more of the record than of a perfect model read
through the same steps, the verdict counts what that model leaves
(``bench.perfect_model.torque_step``), and the report warns that the levels are only known to
half a step.  Fresh seeds here."""
import pytest

from bench.analysis import analyze_record
from bench.resample import reading_resolution
from tests.diagnosis.test_conditions import _within
from virtual_drives.conditions import make_record, recording_for
from virtual_drives.joint import quantise
from virtual_drives.outside_physics import outside_record
from virtual_drives.presets import PRESETS

JOINTS = ("j1", "j2", "j3", "j4", "linear", "rotary")
COARSE = 0.1     # of Fc: twice the warning's threshold


def _credited(doc):
    return [d["effect"] for d in doc["diagnosis"] if d["significant"]]


def _coarse(joint, seed, effects=(), step=COARSE):
    spec = PRESETS[joint]
    rec = recording_for(spec, "torque-reading noise only", seed).with_(torque_resolution=step * spec.friction.Fc)
    record, _ = make_record(spec, rec, seed, effects=effects)
    return spec, analyze_record(record).report()


def test_clean_joints_read_in_coarse_torque_steps_leave_nothing_and_are_warned():
    misses = []
    for i, joint in enumerate(JOINTS):
        spec, doc = _coarse(joint, 5484 + i)
        assert any(w.startswith(f"the torque column sits on steps of {COARSE * spec.friction.Fc:.3g} ")
                   for w in doc["warnings"]), doc["warnings"]
        if _credited(doc) or doc["unexplained"]["structured"] or not _within(doc, spec):
            misses.append((joint, 5484 + i, _credited(doc), doc["unexplained"]["evidence"][:120],
                           {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")}))
    assert len(misses) <= 1, misses


def test_clean_joints_read_in_steps_of_15_percent_get_no_library_story():
    """Coarser still, the levels are only known to half a step (the warning), so only the story
    is held.  Found on seeds 5501-5506 (then used to develop the fix, so not tested here):
    `position_dependent_friction` credited on j1 and j4, `cogging` on the linear stage, j3
    "unexplained", until the effects were judged against the replay read through the steps.
    On these seeds, A/B once when the test was written: before, j1 and j3 "unexplained" and
    `position_dependent_friction` on j4; now none."""
    wrong = []
    for i, joint in enumerate(JOINTS):
        spec, doc = _coarse(joint, 5510 + i, step=0.15)
        if _credited(doc) or doc["final"]["effects"] or doc["unexplained"]["structured"]:
            wrong.append((joint, 5510 + i, _credited(doc), doc["unexplained"]["evidence"][:120]))
    assert not wrong, wrong


def test_the_per_mille_condition_fine_steps_nothing_named_and_no_warning():
    misses = []
    for i, joint in enumerate(JOINTS):
        spec = PRESETS[joint]
        record, _ = make_record(spec, "drive torque in per-mille", 5490 + i)
        doc = analyze_record(record).report()
        step = reading_resolution(record.tau) / spec.friction.Fc
        assert 0.01 <= step <= 0.1 + 1e-9      # the condition's range, found in the record
        if step < 0.05:
            assert not any("sits on steps of" in w for w in doc["warnings"])
        if _credited(doc) or doc["unexplained"]["structured"] or not _within(doc, spec):
            misses.append((joint, 5490 + i, step, _credited(doc), {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")}))
    assert len(misses) <= 1, misses


@pytest.mark.parametrize("joint, seed", [("j1", 5496), ("j2", 5497), ("j4", 5498), ("linear", 5499)])
def test_physics_outside_the_library_read_in_coarse_steps_gets_no_library_story(joint, seed):
    """The steps' floor must not let library effects that absorb a saturating torque constant
    stand as the story (on tuning seeds 1382 and 1384 it did, before the effects were judged
    against the exact twin)."""
    spec = PRESETS[joint]
    rec, text = outside_record(spec, "saturating_torque_constant", seed)
    rec.tau = quantise(rec.tau, COARSE * spec.friction.Fc)
    doc = analyze_record(rec).report()
    assert not _credited(doc) and not doc["final"]["effects"], (text, _credited(doc))


def test_a_library_effect_read_in_coarse_steps_is_still_named():
    spec, doc = _coarse("j1", 5500, effects=["cogging:amplitude=60,pitch=0.02"])
    assert _credited(doc)[:1] == ["cogging"] and not doc["unexplained"]["structured"], \
        (_credited(doc), doc["unexplained"]["evidence"][:160])
