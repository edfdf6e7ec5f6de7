"""LuGre as its own paper writes it (Canudas de Wit et al. 1995): the Stribeck dip
exp(-(v/vs)^2), where the paper we follow (Kermani eq. 3) writes exp(-alpha|v|).  A simulator
written from the original makes every record so.  On the Table II joints the difference leaves
a residual below what the diagnosis names by its size, yet it moved the levels 3.6-24 % with
"nothing left" (j3's Fc -24 %); and beside an inertia error or a lag it decided for gravity.

Records of the independent simulator, seeds 5700-5711 fresh (the rules were set on tuning seeds
1580-1594 and our generator's 1600-1847; ``bench.diagnosis.MATERIAL_SHARE``,
``bench.rounds.SHAPE_TERMS``)."""
import dataclasses

import pytest

from bench.analysis import analyze_record
from independent_joint import independent_record
from virtual_drives.presets import PRESETS

from tests.record_pool import map_records

GAUSSIAN = {"stribeck_delta": 2.0}


def _report(joint, seed, kind):
    spec, physics = PRESETS[joint], dict(GAUSSIAN)
    if kind == "inertia_error":
        spec = dataclasses.replace(spec, inertia=1.2 * spec.inertia)
    elif kind == "torque_lag":
        physics["lag"] = 0.004
    elif kind == "gravity":
        physics["mgl"] = 0.15 * spec.friction.Fc
    rec, _ = independent_record(spec, seed=seed, physics=physics)
    rec.meta["inertia"] = PRESETS[joint].inertia
    return analyze_record(rec).report()


def _levels_ok(doc, joint, rel):
    f, p = PRESETS[joint].friction, doc["final"]["parameters"]
    return all(p[k] == pytest.approx(getattr(f, k), rel=rel) for k in ("Fc", "Fs", "sigma2"))


def test_a_gaussian_dip_is_named_and_the_levels_come_right():
    cases = [("j1", 5700), ("j2", 5701), ("j3", 5702), ("j4", 5703), ("linear", 5704), ("rotary", 5705)]
    docs = map_records(_report, [(j, s, "clean") for j, s in cases])
    named = []
    for (joint, _), doc in zip(cases, docs):
        assert doc["final"]["effects"] in ([], ["stribeck_shape"]), (joint, doc["final"]["effects"])
        assert not doc["unexplained"]["structured"], (joint, doc["unexplained"]["evidence"])
        if doc["final"]["effects"]:
            named.append(joint)
            assert doc["final"]["parameters"]["delta"] == pytest.approx(2.0, abs=0.2), joint
            assert _levels_ok(doc, joint, 0.02), (joint, doc["final"]["parameters"])
    # measured: 5 of 6 (j4 5703's exponent was named, then not credited: position explained
    # 1.1 % of what it left, the spring rule's bar 0.8 %; README known limits)
    assert len(named) >= 5, named
    # where the exponent alone leaves less than the diagnosis names by size, the step says why
    small = [d for doc in docs for d in doc["diagnosis"] if "a level compensation uses" in d["evidence"]]
    assert small, "no exponent was named for the levels it moves: the test no longer tests that rule"


@pytest.mark.parametrize("kind, seeds", [("inertia_error", (5706, 5707)), ("torque_lag", (5708, 5709)),
                                         ("gravity", (5710, 5711))])
def test_beside_a_gaussian_dip_an_inertia_error_a_lag_and_gravity_are_told_apart(kind, seeds):
    jobs = [(j, s, kind) for s, pair in zip(seeds, (("j1", "j2"), ("j3", "j4"))) for j in pair]
    docs = map_records(_report, jobs)
    for (joint, _, _), doc in zip(jobs, docs):
        assert doc["final"]["effects"][:1] == [kind], (joint, doc["final"]["effects"])
        assert "stribeck_shape" in doc["final"]["effects"], (joint, doc["final"]["effects"])
        assert _levels_ok(doc, joint, 0.06), (joint, doc["final"]["parameters"])
        assert not doc["unexplained"]["structured"], (joint, doc["unexplained"]["evidence"])
