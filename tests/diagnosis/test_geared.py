"""Geared joints: backlash and joint flexibility hidden in virtual joints (encoder on the
motor), on the paper's geared Table II joints and on direct drives.

Seeds here (5800+) were never used while tuning (tools/tune_diagnosis.py: 1000-1999)."""
import json

import pytest
from typer.testing import CliRunner

from bench.analysis import analyze_record
from bench.cli import app as cli_app
from bench.effects.backlash import MOTOR_SHARE
from bench.effects.inject import parse_injection, parse_injections
from bench.readers import read_record
from virtual_drives.conditions import make_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects, simulate_scenario

from tests.record_pool import map_records

HYPER = {"backlash": ("bl_width", "width"), "joint_flexibility": ("flex_frequency", "frequency")}


def injected(texts, key):
    return float(parse_injection(texts[0])[1][key])


@pytest.mark.parametrize("effect,joint,seed", [
    ("backlash", "j1", 5811), ("backlash", "j4", 5812), ("backlash", "linear", 5813),
    ("joint_flexibility", "j2", 5821), ("joint_flexibility", "j3", 5822),
    ("joint_flexibility", "rotary", 5823),
])
def test_gear_effect_is_named_first_measured_and_cuts_the_error(effect, joint, seed):
    sim, texts = simulate_scenario(PRESETS[joint], [effect], seed)
    doc = analyze_record(sim.record).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == effect and top["significant"], (texts, doc["diagnosis"][:3])
    assert doc["final"]["effects"] == [effect], texts
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"], texts
    param, key = HYPER[effect]
    true = injected(texts, key)
    assert abs(doc["final"]["parameters"][param] / true - 1) < 0.10, (texts, doc["final"]["parameters"])


def test_the_command_line_hides_backlash_and_the_report_names_its_width(tmp_path):
    """bench simulate --effect backlash:width=... then bench analyze: the evidence gives the
    width a technician can check at the gear, in mrad."""
    csv, js = tmp_path / "j3.csv", tmp_path / "j3.json"
    r = CliRunner().invoke(cli_app, ["simulate", "--joint", "j3", "--seed", "5831", "--effect",
                                     "backlash:width=0.0035", "-o", str(csv)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli_app, ["analyze", str(csv), "--json", str(js)])
    assert r.exit_code == 0, r.output
    doc = json.loads(js.read_text())
    top = doc["diagnosis"][0]
    assert top["effect"] == "backlash" and top["significant"], doc["diagnosis"][:3]
    width = doc["final"]["parameters"]["bl_width"]
    assert abs(width / 0.0035 - 1) < 0.10
    assert f"backlash of {1e3 * width:.3g} mrad" in top["evidence"]
    assert "before the load follows" in top["evidence"]


@pytest.mark.parametrize("args,message", [
    (["--effect", "backlash:width=0"], "width must be positive"),
    (["--effect", "joint_flexibility:frequency=12,damping=3"], "damping ratio"),
    (["--effect", "joint_flexibility:freq=12"], "unknown parameter 'freq'"),
    (["--encoder", "side", "--effect", "backlash:width=0.003"], "--encoder must be one of motor, load"),
    (["--encoder", "load"], "--encoder load needs a geared joint"),
])
def test_bad_gear_injections_are_one_line_errors(args, message, tmp_path):
    r = CliRunner().invoke(cli_app, ["simulate", "--joint", "j1", "-o", str(tmp_path / "x.csv"), *args])
    assert r.exit_code == 2 and message in r.output and "Traceback" not in r.output, r.output


def _load_side_record(joint, effect, seed):
    spec = PRESETS[joint]
    texts = random_effects(spec, [effect], seed, 20.0)
    ev, _, _, _ = parse_injections(texts, spec)
    return simulate_record(spec, *spec.excitation, duration=20.0, seed=seed, extra=ev, encoder="load").record, texts


@pytest.mark.parametrize("joint,seed", [("j1", 5871), ("j2", 5841), ("j3", 5872), ("j4", 5843)])
def test_backlash_seen_from_the_load_is_named_measured_and_cuts_the_error(joint, seed):
    """From a load-side encoder (``encoder: load``) the load coasts in the gap while the motor
    crosses it (bench.load_side.gap_slip): on the geared presets backlash is named first and
    alone, its width within 10 %, the held-out error down by 30 % or more, nothing left."""
    rec, texts = _load_side_record(joint, "backlash", seed)
    assert rec.meta["encoder"] == "load"
    doc = analyze_record(rec).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == "backlash" and top["significant"], (texts, doc["diagnosis"][:3])
    assert doc["final"]["effects"] == ["backlash"], texts
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"], texts
    assert abs(doc["final"]["parameters"]["bl_width"] / injected(texts, "width") - 1) < 0.10, texts
    assert "seen from the load's encoder" in top["evidence"] and "trade off" not in top["evidence"]
    assert not doc["unexplained"]["structured"], (texts, doc["unexplained"]["evidence"])


@pytest.mark.parametrize("joint,seed", [("rotary", 5873), ("linear", 5874)])
def test_backlash_seen_from_a_direct_drives_load_says_play_and_inertia_trade_off(joint, seed):
    """A light direct drive's motor crosses the gap in a time set by play x its inertia: seen
    from the load the two cannot be told apart, and the evidence says so and what to record
    rather than reporting the width as measured."""
    rec, texts = _load_side_record(joint, "backlash", seed)
    doc = analyze_record(rec).report()
    named = [d for d in doc["diagnosis"] if d["effect"] == "backlash" and d["significant"]]
    assert doc["final"]["effects"] in ([], ["backlash"]), (texts, doc["final"]["effects"])
    for d in named:
        assert "trade off" in d["evidence"] and "record the motor's encoder" in d["evidence"], d["evidence"]


@pytest.mark.parametrize("joint,seed", [("j1", 5851), ("j3", 5852), ("j4", 5853), ("linear", 5854)])
def test_a_gear_spring_seen_from_the_load_is_named_measured_and_cuts_the_error(joint, seed):
    """From a load-side encoder the motor's slip through the spring follows from the load's
    acceleration (bench.load_side.spring_slip): the spring is named first, its frequency
    within 10 %, and the inertia beyond it from the encoder (the motor's) within 10 %."""
    rec, texts = _load_side_record(joint, "joint_flexibility", seed)
    doc = analyze_record(rec).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == "joint_flexibility" and top["significant"], (texts, doc["diagnosis"][:3])
    assert doc["final"]["effects"] == ["joint_flexibility"], texts
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"], texts
    p = doc["final"]["parameters"]
    assert abs(p["flex_frequency"] / injected(texts, "frequency") - 1) < 0.10, (texts, p)
    spec = PRESETS[joint]
    assert abs(p["flex_load"] / ((1 - spec.load_fraction) * spec.inertia) - 1) < 0.10, (texts, p)
    assert "motor side" in top["evidence"]


def _cli_report(tmp_path, joint, seed, effect, *options):
    """``bench simulate`` (with ``options``) then ``bench analyze``, through the command line:
    (the CSV's text, the JSON report)."""
    csv, js = tmp_path / f"{joint}.csv", tmp_path / f"{joint}.json"
    r = CliRunner().invoke(cli_app, ["simulate", "--joint", joint, "--seed", str(seed),
                                     *options, "--effect", effect, "-o", str(csv)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli_app, ["analyze", str(csv), "--json", str(js)])
    assert r.exit_code == 0, r.output
    return csv.read_text(), json.loads(js.read_text())


def _load_side_report(tmp_path, joint, seed, effect, *condition):
    """``bench simulate --encoder load`` then ``bench analyze`` (``_cli_report``)."""
    return _cli_report(tmp_path, joint, seed, effect, "--encoder", "load", *condition)


LOGGER = ("--condition", "jittered timestamps with dropped samples")


def test_the_command_line_records_a_spring_from_the_load_and_the_report_names_it(tmp_path):
    """bench simulate --encoder load writes ``encoder: load``; bench analyze fits the spring
    from the load's motion and says the inertia beyond it is the motor's."""
    text, doc = _load_side_report(tmp_path, "j3", 5861, "joint_flexibility:frequency=4.5")
    assert "# encoder: load" in text
    top = doc["diagnosis"][0]
    assert top["effect"] == "joint_flexibility" and top["significant"], doc["diagnosis"][:3]
    assert abs(doc["final"]["parameters"]["flex_frequency"] / 4.5 - 1) < 0.10
    assert "motor side" in top["evidence"]


def test_a_spring_seen_from_the_load_through_a_pc_logger(tmp_path):
    """A load-side record from a PC logger (jittered steps, lost samples, stalls: the record is
    analysed in segments between its gaps) still has its spring named and measured."""
    _, doc = _load_side_report(tmp_path, "j1", 5862, "joint_flexibility:frequency=4.2,damping=0.06", *LOGGER)
    assert doc["diagnosis"][0]["effect"] == "joint_flexibility" and doc["diagnosis"][0]["significant"], doc["diagnosis"][:3]
    assert abs(doc["final"]["parameters"]["flex_frequency"] / 4.2 - 1) < 0.10


def test_backlash_seen_from_the_load_through_a_pc_logger(tmp_path):
    """A load-side record of a geared joint with backlash from a PC logger (jittered steps,
    lost samples, stalls): named and measured, and the motor's inertia, which such a record
    does not pin down, is not reported as measured when it sits at a bound of its share."""
    _, doc = _load_side_report(tmp_path, "j2", 5881, "backlash:width=0.003", *LOGGER)
    top = doc["diagnosis"][0]
    assert top["effect"] == "backlash" and top["significant"], doc["diagnosis"][:3]
    assert abs(doc["final"]["parameters"]["bl_width"] / 0.003 - 1) < 0.10, doc["final"]["parameters"]
    share = doc["final"]["parameters"]["bl_motor"] / PRESETS["j2"].inertia
    at_bound = share < 1.05 * MOTOR_SHARE[0] or share > 0.95 * MOTOR_SHARE[1]
    assert ("not resolved" in top["evidence"]) == at_bound, (share, top["evidence"])


@pytest.mark.parametrize("seed,hz,damping", [(5531, 14.5, 0.09), (5532, 15.0, 0.1), (5533, 14.2, 0.085)])
def test_a_spring_that_bends_the_lugre_fit_is_found_from_another_start(seed, hz, damping):
    """A 14-15 Hz spring on the linear stage bends the LuGre fit (sigma0 and Fs far off), and
    against that fit a slow start screens best, whose refit is no credible spring; the refit
    from every screened start finds it (Effect.restarts).  Fresh seeds: before, 0 of these 3
    named (1 of 4 at 14.2-15.5 Hz), the verdict "unexplained"."""
    spec = PRESETS["linear"]
    ev, *_ = parse_injections([f"joint_flexibility:frequency={hz},damping={damping}"], spec)
    doc = analyze_record(simulate_record(spec, *spec.excitation, duration=20.0, seed=seed, extra=ev).record).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == "joint_flexibility" and top["significant"], doc["diagnosis"][:3]
    assert doc["final"]["effects"] == ["joint_flexibility"]
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    values = doc["final"]["parameters"]
    assert abs(values["flex_frequency"] / hz - 1) < 0.10, values
    assert abs(values["flex_load"] / (spec.load_fraction * spec.inertia) - 1) < 0.10, values
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]


# PD tracking of a geared joint: the drive closes the loop on the motor's encoder, the record
# holds the motor's or the load's (``--condition "PD closed-loop tracking" --encoder load``).
# Tuning seeds 1500-1505, 1520-1525, 1540-1545, 1560-1565 (2026-12-06): from the motor
# backlash named 12 of 12 (width within 1.5 %), a spring 10 of 12 (both misses j4's 5-6 Hz
# spring, whose 0.2 % of Fc is below the size the diagnosis names: nothing credited, nothing
# left); from the load backlash 10 of 12, a spring 12 of 12.  Fresh seeds here.
PD_GEARED = [(effect, joint, encoder, 10166 + 10 * i + k)
             for i, (effect, encoder, joints) in enumerate((
                 ("backlash", "motor", list(PRESETS)), ("joint_flexibility", "motor", list(PRESETS)),
                 ("backlash", "load", ["j1", "j2", "j3", "j4"]),
                 ("joint_flexibility", "load", ["j1", "j2", "j3", "j4"])))
             for k, joint in enumerate(joints)]


def _pd_geared(effect, joint, encoder, seed, via_csv=False):
    """One PD-tracked geared record analysed (``via_csv``: read back from the CSV it writes):
    (credited effects, named right, injection)."""
    spec = PRESETS[joint]
    texts = random_effects(spec, [effect], seed)
    rec, _ = make_record(spec, "PD closed-loop tracking", seed, effects=texts, encoder=encoder)
    if via_csv:   # the CSV's text, parsed as a file's (no need for one on disk)
        rec = read_record(rec.to_csv().encode(), name="record.csv")
    doc = analyze_record(rec).report()
    return doc["final"]["effects"], _named_right(doc, effect, injected(texts, HYPER[effect][1])), texts


def _named_right(doc, effect, true):
    """Named first and alone, its width or frequency within 10 % of ``true``, the held-out
    error down by 30 % or more, nothing left."""
    top = doc["diagnosis"][0]
    return (top["effect"] == effect and top["significant"] and doc["final"]["effects"] == [effect]
            and doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
            and abs(doc["final"]["parameters"][HYPER[effect][0]] / true - 1) < 0.10
            and not doc["unexplained"]["structured"])


def test_a_geared_joint_under_pd_tracking_gets_its_gear_effect_named_and_no_other():
    """Named first and alone, its width or frequency within 10 %, the held-out error down by
    30 % or more and nothing left, on all but one record of each effect and encoder side; and
    no record credits an effect it does not have."""
    results = map_records(_pd_geared, PD_GEARED)
    for (effect, joint, encoder, seed), (credited, _, texts) in zip(PD_GEARED, results):
        assert set(credited) <= {effect}, (joint, encoder, seed, texts, credited)
    for effect in HYPER:
        for encoder in ("motor", "load"):
            group = [(c, r) for c, r in zip(PD_GEARED, results) if c[0] == effect and c[2] == encoder]
            missed = [(c[1], c[3], r[2]) for c, r in group if not r[1]]
            assert len(missed) <= 1, (effect, encoder, missed)


# The same from the CSV users have: positions written to 1e-5 rad moved the motor's inertia
# behind j2's 3 mrad play (test seed 10200, below) enough that its sensitivity lived in one motion
# segment, and the held-out correction, extrapolating it there, scored the backlash model 2531
# N·m against 197 without it (MIN_TRAIN_SHARE since).  Tuning 1800-1809 read back from CSV:
# 8 of 10 named (j4 and the rotary motor's 1.4 mrad missed, flagged), 7 of 10 before.
PD_LOAD_CSV = [("backlash", joint, "load", 10201 + k, True) for k, joint in enumerate(("j1", "j2", "j3", "j4"))]


def test_backlash_seen_from_the_load_under_pd_is_named_from_its_csv():
    results = map_records(_pd_geared, PD_LOAD_CSV)
    for (_, joint, _, seed, _), (credited, _, texts) in zip(PD_LOAD_CSV, results):
        assert set(credited) <= {"backlash"}, (joint, seed, texts, credited)
    missed = [(c[1], c[3], r[2]) for c, r in zip(PD_LOAD_CSV, results) if not r[1]]
    assert len(missed) <= 1, missed


# j4 from the load under PD with 3-4.5 mrad of play: the LuGre fit runs Fs to the edge of its
# search, screened against it the backlash was never significant, and the diagnosis also run
# from Section III's estimates names it (bench.measured_start; tuning 1503, 1505, 1830-1837: 6
# of the 9 whose fit hit the edge, none before).  Fresh seeds and widths here.
EDGE_OF_SEARCH = [("j4", 10219 + i, w) for i, w in enumerate((0.003, 0.0033, 0.0036, 0.0039, 0.0042, 0.0045))]


def _edge_of_search(joint, seed, width):
    """(credited effects, named right with the levels within 5 %, started from Section III)."""
    spec = PRESETS[joint]
    rec, _ = make_record(spec, "PD closed-loop tracking", seed, effects=[f"backlash:width={width}"],
                         encoder="load")
    doc = analyze_record(rec).report()
    p = doc["final"]["parameters"]
    right = (_named_right(doc, "backlash", width)
             and all(abs(p[k] / getattr(spec.friction, k) - 1) < 0.05 for k in ("Fc", "Fs", "sigma2")))
    measured = any("edge of its search" in w for w in doc["warnings"])
    base = doc["baseline"]
    # the baseline the error fell from is the start's, and says so; the fit's values stay beside it
    assert (base["start"] == "section_iii") == measured, base
    if measured:
        fitted, started = base["lugre_fit_parameters"], base["parameters"]
        assert any(abs(started[k] / fitted[k] - 1) > 0.5 for k in ("Fc", "Fs", "sigma2")), base
    return doc["final"]["effects"], right, measured


def test_backlash_that_runs_the_lugre_fit_off_its_search_is_named_from_section_iii():
    results = map_records(_edge_of_search, EDGE_OF_SEARCH)
    for case, (credited, _, _) in zip(EDGE_OF_SEARCH, results):
        assert set(credited) <= {"backlash"}, (case, credited)
    named = [case for case, (_, right, measured) in zip(EDGE_OF_SEARCH, results) if right and measured]
    assert len(named) >= 4, (named, results)


def test_the_command_line_records_backlash_seen_from_the_load_under_pd(tmp_path):
    """The record that showed the held-out correction's blow-up (not an independent check)."""
    _, doc = _load_side_report(tmp_path, "j2", 10200, "backlash:width=0.003", "--condition", "PD closed-loop tracking")
    assert doc["final"]["effects"] == ["backlash"], doc["diagnosis"][:3]
    assert abs(doc["final"]["parameters"]["bl_width"] / 0.003 - 1) < 0.10
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]


def test_the_command_line_records_a_pd_tracked_geared_joint(tmp_path):
    """bench simulate writes a closed-loop record of a geared joint (it refused one until
    2026-12-06) and bench analyze names its backlash and measures it."""
    _, doc = _cli_report(tmp_path, "j2", 10200, "backlash:width=0.003", "--condition", "PD closed-loop tracking")
    assert doc["final"]["effects"] == ["backlash"], doc["diagnosis"][:3]
    assert abs(doc["final"]["parameters"]["bl_width"] / 0.003 - 1) < 0.10
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]


def test_a_load_side_encoder_stated_by_option_for_a_log_without_metadata(tmp_path):
    """A Parquet log has no '#' line to say its encoder reads the load: ``--encoder load``
    (``?encoder=load``) says it, and the backlash is seen from the load as with the line
    (fresh seed 10360); a side that is neither is one line, exit 2."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq
    rec, texts = _load_side_record("j3", "backlash", 10360)
    path = tmp_path / "log.parquet"
    pq.write_table(pa.table({"t": rec.t, "tau": rec.tau, "q": rec.q}), path)
    inertia = PRESETS["j3"].inertia
    assert read_record(path, inertia=inertia).meta.get("encoder", "motor") == "motor"
    got = read_record(path, inertia=inertia, encoder="load")
    assert got.meta["encoder"] == "load" and np.array_equal(got.q, rec.q) and np.array_equal(got.tau, rec.tau)
    doc = analyze_record(got).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == "backlash" and top["significant"], (texts, doc["diagnosis"][:3])
    assert "seen from the load's encoder" in top["evidence"], top["evidence"]
    r = CliRunner().invoke(cli_app, ["analyze", str(path), "--inertia", str(inertia), "--encoder", "side"])
    assert r.exit_code == 2 and "--encoder must be motor or load" in r.output and "Traceback" not in r.output, r.output
