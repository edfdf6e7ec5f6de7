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
from bench.effects import get
from bench.fitting import LUGRE_KEYS, Param
from bench.refit import evaluate
from bench.screening import CrossValidation, Model, screen
from bench.residual_stats import effective_sample_fraction
from bench.structure_spread import STORY_SHARE, parts, stories, widened
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


def test_a_term_not_credited_that_explains_what_is_left_is_another_story_for_the_values():
    """Position-dependent friction under one sine on j1 (another simulator's), screened beside
    LuGre alone as the diagnosis's last round would leave it: LuGre alone puts Fs about 15 %
    high with a noise-only error of 2-3 %; the story fitted in brings Fc, Fs and sigma2 within
    5 %, and the widened uncertainty covers the move (fresh seed 9779)."""
    spec = PRESETS["j1"]
    rec, _ = independent_record(spec, duration=DURATION, seed=9779, dt=1e-3,
                                physics=library_physics(spec, "position_dependent_friction"))
    ident = analyze_record(rec, diagnose_effects=False).ident
    data = ident.data
    model = Model(values={k: ident.result.values[k] for k in LUGRE_KEYS},
                  params=[Param(k, ident.result.values[k]) for k in LUGRE_KEYS], result=ident.result)
    cv = CrossValidation(data)
    cur = evaluate(data, model, cv, dict(rec.meta, torque_hold=ident.fit["torque_hold"]), ident.inertia)
    n_eff = len(cur.r) * effective_sample_fraction(cur.r)
    sc = screen(get("position_dependent_friction"), cur.ctx, model, cur.J, cv, cur.sse,
                cv.sse_across_directions(cur.J, cur.r), n_eff)
    assert sc.explained > STORY_SHARE, sc.explained
    told = stories(data, model, cur.ctx.model, [sc])
    f = spec.friction
    assert [s.effect for s in told] == ["position_dependent_friction"]
    story = {k: told[0].values[k] / getattr(f, k) - 1 for k in ("Fc", "Fs", "sigma2")}
    assert max(map(abs, story.values())) < 0.05, story
    doc = ident.report()
    before = {k: abs(doc["parameters"][k] / getattr(f, k) - 1) for k in ("Fs", "sigma2")}
    noise = {k: doc["uncertainty"][k] / getattr(f, k) for k in ("Fs", "sigma2")}
    assert before["Fs"] > 0.1 and before["Fs"] > 3 * noise["Fs"], (before, noise)    # dishonest alone
    widened(doc, {k: 0.0 for k in LUGRE_KEYS}, told)
    for k in ("Fs", "sigma2"):
        assert before[k] <= 2 * doc["uncertainty"][k] / getattr(f, k), (k, before, doc["uncertainty"])
    assert doc["structure_stories"][0]["effect"] == "position_dependent_friction"
    assert any("with position_dependent_friction fitted in" in w for w in doc["warnings"]), doc["warnings"]


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
