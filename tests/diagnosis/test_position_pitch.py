"""A position ripple of few pitches to the travel under one sine (another simulator's
position-dependent friction, three pitches to the travel) is screened at its pitch when the
pitch is refined beside LuGre's own sensitivities (``bench.effects.base.lugre_directions``).
From the bare residual it was screened 7-11 % long, where the LuGre fit had bent its levels
towards it, and failed the halves test: j1 and j2 left it "unexplained" with Fs 15-17 % high,
j3 credited a 2.3 Hz joint_flexibility at damping 0.009 (tuning seeds 1937, 1981, 1986; fresh
9779-9783).  Fresh seeds 9785-9787 here."""
from bench.analysis import analyze_record
from tests.diagnosis.tracked_logs import library_physics
from tests.independent_joint import independent_record
from tests.record_pool import map_records
from virtual_drives.presets import PRESETS


def _ripple(joint: str, seed: int) -> dict:
    spec = PRESETS[joint]
    physics = library_physics(spec, "position_dependent_friction")
    rec, _ = independent_record(spec, duration=20.0, seed=seed, dt=1e-3, physics=physics)
    doc = analyze_record(rec).report()
    f = spec.friction
    return {"joint": joint, "seed": seed,
            "credited": [d["effect"] for d in doc["diagnosis"] if d["significant"]],
            "structured": doc["unexplained"]["structured"],
            "pitch": doc["final"]["parameters"].get("pf_pitch", 0.0) / physics["ripple_pitch"] - 1,
            "off": {k: doc["parameters"][k] / getattr(f, k) - 1 for k in ("Fc", "Fs", "sigma2")
                    if doc["identifiable"][k]}}


def test_a_coarse_position_ripple_under_one_sine_is_named_at_its_pitch():
    got = map_records(_ripple, [("j1", 9785), ("j2", 9786), ("j3", 9787)])
    for g in got:
        assert g["credited"] == ["position_dependent_friction"] and not g["structured"], g
        assert abs(g["pitch"]) < 0.02, g
        assert g["off"] and max(map(abs, g["off"].values())) < 0.05, g


def _ours(joint: str, seed: int) -> dict:
    from virtual_drives.scenarios import simulate_scenario
    sim, texts = simulate_scenario(PRESETS[joint], ["position_dependent_friction"], seed)
    doc = analyze_record(sim.record).report()
    pitch = float(texts[0].split("pitch=")[1].split(",")[0])
    return {"joint": joint, "seed": seed, "injected": texts,
            "credited": [d["effect"] for d in doc["diagnosis"] if d["significant"]],
            "evidence": doc["diagnosis"][0]["evidence"],
            "structured": doc["unexplained"]["structured"],
            "pitch": doc["final"]["parameters"].get("pf_pitch", 0.0) / pitch - 1}


def test_a_ripple_of_two_pitches_to_the_travel_is_seen_to_repeat_and_named():
    """Under three pitches to the travel a ripple must repeat one pitch on (a local friction
    bump fitted as one lobe does not: ``repeats``).  Our scenarios' position-dependent
    friction drawn at 2.0-2.2 pitches to the travel, the edge of what they draw; fresh seeds."""
    got = map_records(_ours, [("j1", 9796), ("j3", 9802), ("linear", 9848), ("j4", 9860)])
    for g in got:
        assert g["credited"] == ["position_dependent_friction"] and not g["structured"], g
        assert abs(g["pitch"]) < 0.02, g
        # the evidence says what the repeat test saw, not that it could not be seen
        assert "the level repeats one pitch further on, score" in g["evidence"], g
