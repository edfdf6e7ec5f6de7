"""Friction as Simscape-style blocks write it: a static map s(v) tanh(v/eps) + sigma2 v with a
Gaussian Stribeck dip, no bristles.  The joint creeps in stick; no library effect describes
that.  Under one repeated sine, what the LuGre fit leaves at one speed is mirrored about the
travel's middle, and a fine-pitch position-dependent friction fitted it across cycles and
across directions: it was credited beside the "unexplained" flag on j2 (and on j1 of tuning
seed 1595).  A function of position must also carry from one half of the travel to the other
(``bench.screening.HALVES_SHARE``, set on tuning seeds 1595-1596 and 1913-1914).

Independent simulator, fresh seeds 5712-5726."""
import json

from bench.analysis import analyze_record
from independent_joint import independent_record
from virtual_drives.conditions import make_record
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects

from tests.record_pool import map_records


def _report(joint, seed, eps, logger):
    kw = {"jitter": 0.5, "drop": 0.02} if logger else {}
    rec, _ = independent_record(PRESETS[joint], seed=seed, physics={"static_eps": eps, "stribeck_delta": 2.0}, **kw)
    return analyze_record(rec).report()


# j2 5713 and 5719 credited the series before the rule (the same records with HALVES_SHARE
# off, 2026-11-29); j3 5714, j4 5715 and j2 5717 behaved as these do and are left out for time
CASES = [("j1", 5712, 1e-3, False), ("j2", 5713, 1e-3, False), ("j2", 5719, 3e-3, True)]


def test_no_library_effect_is_credited_for_a_static_map_and_the_residual_is_flagged():
    docs = map_records(_report, CASES)
    for case, doc in zip(CASES, docs):
        assert doc["final"]["effects"] == [], (case, doc["final"]["effects"])
        assert doc["unexplained"]["structured"], (case, doc["unexplained"]["evidence"])


def test_a_true_position_dependent_friction_carries_across_the_halves():
    """The same rule keeps a true series on the same joint (j2): seed fresh, our own generator."""
    texts = random_effects(PRESETS["j2"], ["position_dependent_friction"], 5726, 20.0)
    rec, _ = make_record(PRESETS["j2"], "clean", seed=5726, effects=tuple(texts))
    doc = analyze_record(rec).report()
    assert doc["final"]["effects"] == ["position_dependent_friction"], doc["final"]["effects"]
    step = doc["steps"][0]
    top = next(c for c in step["candidates"] if c["effect"] == "position_dependent_friction")
    assert top["explained_halves"] >= 0.8, top
    # candidates that are not position series were not tested: null, and the report stays
    # strict JSON (POST /analyze answers with allow_nan=False)
    assert any(c["explained_halves"] is None for c in step["candidates"]), step["candidates"]
    json.dumps(doc, allow_nan=False)


def _simscape(joint, seed):
    """Simscape's Rotational Friction block itself: Fc at rest (a tanh), a breakaway peak Fs at
    v_brk, the Stribeck part decaying as exp(-(v/v_St)^2); v_brk at the joint's 1/alpha/sqrt(2)."""
    import math
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, jitter=0.3, drop=0.005, torque_noise=0.01 * spec.friction.Fc,
                                physics={"simscape": 1.0,
                                         "static_eps": 1.0 / (10.0 * math.sqrt(2.0) * spec.friction.alpha)})
    doc = analyze_record(rec).report()
    u = doc["unexplained"]
    return [d["effect"] for d in doc["diagnosis"] if d["significant"]], u["structured"], u["evidence"]


def test_simscape_friction_is_unexplained_and_a_static_friction_gone_is_told_as_a_bent_map():
    """LuGre bends to such a map, mostly by losing its static friction (Fs -> 0; tuning seeds
    1940-1995: 28 of 48 records, all flagged).  That was read as a degenerate fit and said
    nothing; beside a structured residual it now tells the map that builds up from rest.
    Fresh seeds 5750-5755: 6 of 6 flagged with nothing credited, j1 and j3 told as bent (j2 and
    j4 fitted Fs -> 0 without a standard error; the linear stage and the rotary motor lost Fc)."""
    joints = ("j1", "j2", "j3", "j4", "linear", "rotary")
    out = map_records(_simscape, [(j, 5750 + i) for i, j in enumerate(joints)])
    assert all(not credited and structured for credited, structured, _ in out), [o[:2] for o in out]
    bent = [j for j, (_, _, ev) in zip(joints, out) if "starts far below its Coulomb level at rest" in ev]
    assert len(bent) >= 2, bent
