"""Structure left widens the values' uncertainty (``bench.structure_spread``).  The friction
levels jump 12 % at 11 s of a 20 s record (physics outside the library, another simulator's):
the verdict is "unexplained", and both levels the joint had lie within two of the reported
standard errors of Fc and Fs, or the value is reported not determined.  Tuning seed 1927
(linear stage): Fc +5.4 % ± 3.7 % and Fs +5.7 % ± 1.5 % from the noise alone, ± 6.1 % and
± 5.3 % widened.  Fresh seeds 9768-9776 (9772 clean): the noise's errors alone were honest on
3 of 8, widened on 7 of 8."""
import math

import numpy as np

from bench.analysis import analyze_record
from bench.structure_spread import parts
from tests.diagnosis.tracked_logs import library_physics
from tests.independent_joint import independent_record
from tests.record_pool import map_records
from virtual_drives.presets import PRESETS

JUMP, JUMP_T, DURATION = 0.12, 11.0, 20.0


def _jumped(joint: str, excitation: str, seed: int) -> dict:
    spec = PRESETS[joint]
    kw = {}
    if excitation == "pid":
        r0, _ = independent_record(spec, duration=4.0, seed=1)
        kw["pd"] = (6.0, 0.5 * float(r0.q.max() - r0.q.min()), 1.5)
    elif excitation == "two":
        A, fr = spec.excitation
        t = np.arange(int(DURATION / 1e-3)) * 1e-3
        kw["torque"] = A * (0.7 * np.sin(2 * np.pi * fr * t) + 0.45 * np.sin(2 * np.pi * 2.7 * fr * t + 1.0))
    rec, _ = independent_record(spec, duration=DURATION, seed=seed, dt=1e-3,
                                physics={"jump": JUMP, "jump_t": JUMP_T}, **kw)
    doc = analyze_record(rec).report()
    f = spec.friction
    out = {"joint": joint, "seed": seed, "structured": doc["unexplained"]["structured"],
           "spread": doc.get("structure_spread"),
           "warned": [w for w in doc["warnings"] if "fitted on halves of the record" in w]}
    for k in ("Fc", "Fs"):
        p, se, ok = doc["parameters"][k], doc["uncertainty"][k], doc["identifiable"][k]
        true, off = getattr(f, k), (out["spread"] or {}).get(k, 0.0)
        far = max(abs(p - true), abs(p - true * (1 + JUMP)))
        # honest: not claimed, or both levels the joint had within two standard errors
        out[k] = (round(p / true - 1, 3), None if se is None else round(se / true, 3), ok,
                  not ok or (se is not None and far <= 2 * se))
        # the same with the noise's standard error alone (reported, not asserted)
        out[k + "_noise_only"] = se is not None and far <= 2 * math.sqrt(max(se ** 2 - off ** 2, 0.0))
    return out


def test_a_level_jump_left_unexplained_widens_fc_and_fs_to_cover_both_levels():
    jobs = [("linear", "pid", 9768), ("j4", "two", 9769), ("j1", "two", 9770), ("j2", "pid", 9771),
            ("rotary", "pid", 9773), ("j3", "two", 9774), ("linear", "sine", 9775), ("j4", "pid", 9776)]
    got = map_records(_jumped, jobs)
    for g in got:
        assert g["structured"], g
        assert g["spread"] is not None and max(g["spread"]["Fc"], g["spread"]["Fs"]) > 0.0, g
    # j3 under two tones (9774) lost its Stribeck dip to the jump (Fs ~ 0, Fc +15 % above both
    # levels, spread 6 %): a fit gone to a corner, which no spread between halves mends
    dishonest = [g for g in got if not (g["Fc"][3] and g["Fs"][3])]
    assert len(dishonest) <= 1, dishonest
    # the noise's standard errors alone covered both levels in 3 of these 8; where the halves
    # moved more than the noise does, a warning says so (4 of 8 when written)
    warned = [g for g in got if g["warned"]]
    assert len(warned) >= 3, got
    assert all(" Fc ± " in g["warned"][0] or " Fs ± " in g["warned"][0] for g in warned), warned


def _position_locked(joint: str, seed: int) -> dict:
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, duration=DURATION, seed=seed, dt=1e-3,
                                physics=library_physics(spec, "position_dependent_friction"))
    doc = analyze_record(rec).report()
    f = spec.friction
    rel = {k: abs(doc["parameters"][k] / getattr(f, k) - 1) for k in ("Fc", "Fs", "sigma2")}
    honest = {k: not doc["identifiable"][k] or rel[k] <= 2 * doc["uncertainty"][k] / getattr(f, k) for k in rel}
    return {"joint": joint, "seed": seed, "structured": doc["unexplained"]["structured"], "rel": rel,
            "honest": honest, "credited": [d["effect"] for d in doc["diagnosis"] if d["significant"]],
            "stories": {s["effect"]: {k: abs(s["parameters"][k] / getattr(f, k) - 1) for k in rel}
                        for s in doc.get("structure_stories", [])}}


def test_a_position_locked_term_not_credited_under_one_sine_is_another_story_for_the_values():
    """Position-dependent friction under one sine on j1 and j2 is not credited (a cycle-locked
    mismatch looks the same) and the verdict is "unexplained"; LuGre alone puts Fs 16-17 % high
    with a standard error of 2-3 % from the noise.  Fitted in, the term brings Fc, Fs and sigma2
    within 5 % (within 0.1 % when written), and the values' uncertainty covers the move."""
    got = map_records(_position_locked, [("j1", 9779), ("j1", 9780), ("j2", 9781)])
    for g in got:
        assert not g["credited"] and g["structured"], g
        assert all(g["honest"].values()), g
        assert max(g["stories"]["position_dependent_friction"].values()) < 0.05, g


def test_a_clean_record_keeps_its_standard_errors_and_halves_split_it_evenly():
    spec = PRESETS["j2"]
    rec, _ = independent_record(spec, duration=8.0, seed=9772, dt=1e-3)
    a = analyze_record(rec)
    doc = a.report()
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert "structure_spread" not in doc
    data = a.ident.data
    halves = parts(data)
    assert set(halves) == {"time", "travel", "direction"}
    for name, first in halves.items():
        assert first.shape == (int(data.mask.sum()),)
        assert 0.3 < first.mean() < 0.7, (name, first.mean())
