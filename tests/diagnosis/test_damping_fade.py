"""A bristle damping that fades with speed (LuGre's sigma1 exp(-(v/vd)^2) variant), on records
of the independent simulator: asked for (``--add damping_fade``), it is fitted with LuGre's
values and the error falls to what the same joint leaves without it.  The diagnosis does not
screen it on its own (``DampingFade.auto``; README known limits); it fits it beside the
contenders one sine hardly tells apart, to decide between them (``bench.rounds``), and in
place of a Stribeck exponent that won a round (``bench.diagnosis.FADE_OVER_SHAPE``).

Seeds 5680-5691 are fresh (the fade was probed on tuning seeds 1530-1557, where it came out
with its gain at 0.96, v_d within 2 % and every LuGre value within 2 %)."""
import dataclasses

import pytest

from bench.analysis import analyze_record
from bench.effects.inject import parse_injection
from independent_joint import independent_record
from virtual_drives.conditions import make_record
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects

from tests.record_pool import map_records


def _analyse(rec, add):
    return analyze_record(rec, add=add).report()


@pytest.mark.parametrize("joint, vd, seed, jitter", [
    ("j3", 0.05, 5680, 0.0),
    ("j1", 0.015, 5681, 0.0),
    ("j4", 0.03, 5682, 0.3),     # a PC logger's jittered timestamps
])
def test_an_asked_for_fade_is_fitted_and_the_error_falls_to_the_joints_own(joint, vd, seed, jitter):
    spec = PRESETS[joint]
    faded, _ = independent_record(spec, seed=seed, jitter=jitter, physics=dict(sigma1_vd=vd))
    plain, _ = independent_record(spec, seed=seed, jitter=jitter)
    auto, asked, own = map_records(_analyse, [(faded, None), (faded, ["damping_fade"]), (plain, None)])
    # not screened on its own, but named in place of a Stribeck exponent that won a round when
    # it leaves clearly less (FADE_OVER_SHAPE; 5681 since 2026-12-06, while 5680's exponent
    # fails its own position check, so nothing is named there): never a sharper dip
    assert auto["final"]["effects"] in ([], ["damping_fade"]), auto["diagnosis"][:2]
    step = asked["diagnosis"][0]
    assert step["effect"] == "damping_fade" and step["rms_after"] < step["rms_before"]
    p = asked["final"]["parameters"]
    assert p["damp_gain"] >= 0.8, p
    assert p["damp_vd"] == pytest.approx(vd, rel=0.15), p
    f = spec.friction
    for k in ("Fc", "Fs", "sigma2"):
        assert p[k] == pytest.approx(getattr(f, k), rel=0.03), (k, p)
    assert asked["final"]["rms_error"] <= 1.3 * own["final"]["rms_error"], (asked["final"], own["final"])
    assert not asked["unexplained"]["structured"], asked["unexplained"]["evidence"]


def _story(joint, seed, vd, kind, pd=False):
    spec = PRESETS[joint]
    nominal = spec.inertia
    physics = dict(sigma1_vd=vd)
    if kind == "inertia_error":
        spec = dataclasses.replace(spec, inertia=1.2 * nominal)
    else:
        physics["lag"] = 0.004
    track = None
    if pd:   # the sine test's travel, tracked by a 4 Hz PD loop
        sine, _ = independent_record(PRESETS[joint], duration=4.0, seed=1)
        track = (4.0, 0.5 * float(sine.q.max() - sine.q.min()))
    rec, _ = independent_record(spec, seed=seed, physics=physics, pd=track)
    rec.meta["inertia"] = nominal
    return analyze_record(rec).report()


# vd a third to a fifth of the Stribeck velocity 1/alpha, where the fade decided between the
# contenders one sine hardly tells apart (tuning seeds 1551-1556: 5 wrong stories of 6)
STORIES = [("j1", 5683, 0.015, "inertia_error"), ("j2", 5684, 0.025, "inertia_error"),
           ("j3", 5685, 0.05, "torque_lag"), ("j4", 5686, 0.03, "torque_lag"),
           ("j2", 5687, 0.03, "torque_lag"), ("j4", 5688, 0.025, "inertia_error")]


def test_beside_a_fading_damping_an_inertia_error_or_a_lag_is_not_told_as_another():
    """An independent record's joint 20 % heavier than declared, or feeling its torque 4 ms
    late, with LuGre's fading sigma1: the story is the true effect (at most one miss in six),
    never gravity, and where the fade decided the round the step says so."""
    docs = map_records(_story, STORIES)
    wrong = [(s, d["final"]["effects"]) for s, d in zip(STORIES, docs) if d["final"]["effects"][:1] != [s[3]]]
    assert len(wrong) <= 1, wrong
    assert not any("gravity" in d["final"]["effects"] for d in docs), [d["final"]["effects"] for d in docs]
    decided = [d for d in docs if any("decided with a bristle damping" in e["evidence"] for e in d["diagnosis"])]
    assert decided, "the fade decided no round"


def test_under_pd_tracking_a_fade_is_not_told_as_play_in_a_gear():
    """The same under a 4 Hz PD loop (fresh seeds 5689-5691): the true effect first (at most one
    miss in three) and no gear.  On tuning seeds 1560-1561 the fade's transitions were named
    2 mrad of backlash carrying 5 % of the inertia, after the true effect; a gear that light is
    now held against the fade (``bench.rounds.LIGHT_GEAR``)."""
    cases = [("j1", 5689, 0.015, "inertia_error", True), ("j2", 5690, 0.025, "torque_lag", True),
             ("j3", 5691, 0.05, "inertia_error", True)]
    docs = map_records(_story, cases)
    finals = [d["final"]["effects"] for d in docs]
    assert sum(f[:1] != [c[3]] for f, c in zip(finals, cases)) <= 1, finals
    assert not any({"backlash", "joint_flexibility"} & set(f) for f in finals), finals


def _fade_on_a_logger(joint, seed):
    spec = PRESETS[joint]
    texts = random_effects(spec, ["damping_fade"], seed)
    rec, _ = make_record(spec, "jittered timestamps with dropped samples", seed, effects=texts)
    doc = analyze_record(rec).report()
    doc["true_vd"] = float(parse_injection(texts[0])[1]["vd"])
    return doc


# Our generator's fade through a PC logger (tuning 1713-1717): j1-j3 were told "the Stribeck
# dip is sharper, exponent 2.5-3.1" with nothing left, the exponent below the size named but
# moving a level; the fade fitted instead left 0.51-0.70x its error (``FADE_OVER_SHAPE``).
# Fresh seeds (10205-10208 measured the rule's first form, which was withdrawn): 2 of 4 named
# (v_d within 2.4 %), 2 nothing.
FADES = [("j1", 10209), ("j2", 10210), ("j3", 10211), ("j4", 10212)]


def test_on_a_pc_logger_a_fade_is_not_told_as_a_sharper_stribeck_dip():
    docs = map_records(_fade_on_a_logger, FADES)
    finals = [d["final"]["effects"] for d in docs]
    assert all(f in ([], ["damping_fade"]) for f in finals), finals
    assert sum(f == ["damping_fade"] for f in finals) >= 2, finals
    for d in docs:
        if d["final"]["effects"]:
            step = d["diagnosis"][0]
            assert step["effect"] == "damping_fade" and "chosen over a sharper Stribeck dip" in step["evidence"]
            assert d["final"]["parameters"]["damp_vd"] == pytest.approx(d["true_vd"], rel=0.1)
