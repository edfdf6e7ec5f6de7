"""``--inertia estimate``: a log without a declared inertia (bench.inertia_estimate).

Measured on tuning seeds 1600-1605 (our generator, six joints, five conditions): the regression
alone 0.956-1.039 of the true inertia (the linear stage 0.969 on every condition: LuGre's
bristles lag the Stribeck map while it accelerates), refined beside LuGre 0.968-1.030, the
worst under coloured process noise, where the reported standard error was 5.6-8.3 %.  Fresh
seeds here."""
import json

import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.records import Record
from independent_joint import independent_record, point_to_point
from tests.core.test_cli import run
from tests.diagnosis.test_independent_records import _travel
from tests.record_pool import map_records
from virtual_drives.conditions import make_record, recording_for
from virtual_drives.presets import PRESETS


def _undeclared(rec: Record) -> Record:
    rec = rec[0] if isinstance(rec, tuple) else rec
    return Record(t=rec.t, tau=rec.tau, q=rec.q, qd=rec.qd,
                  meta={k: v for k, v in rec.meta.items() if k != "inertia"}, reading=rec.reading)


def _ours(joint, seed, condition):
    spec = PRESETS[joint]
    rec = _undeclared(make_record(spec, recording_for(spec, condition, seed), seed))
    doc = analyze_record(rec, inertia="estimate").report()
    return joint, condition, doc["fit"]["inertia_estimate"], spec.inertia, doc


def test_the_inertia_is_read_off_our_records_within_its_standard_error():
    conditions = ("white process noise", "coloured process noise", "torque-reading noise only",
                  "coarse encoder", "white process noise", "torque-reading noise only")
    rows = map_records(_ours, [(j, 5811 + i, c) for i, (j, c) in enumerate(zip(PRESETS, conditions))])
    for joint, condition, info, true, doc in rows:
        error = info["inertia"] / true - 1
        assert abs(error) < max(0.02, 3 * info["standard_error"] / true), (joint, condition, info, true)
        assert doc["inertia"] == pytest.approx(info["inertia"])
        assert any("no inertia was declared" in w for w in doc["warnings"]), doc["warnings"]
        named = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        assert not named and not doc["unexplained"]["structured"], (joint, condition, named)
        # under a torque sine q ~ -qdd: inertia and gravity are one measurement (the linear
        # stage has no gravity term; the rotary motor, 4.1x on tuning, sits near the bound)
        if joint in ("j1", "j2", "j3", "j4"):
            assert "gravity_confounded" in info, (joint, info)
            assert any("one measurement" in w for w in doc["warnings"])
        elif joint == "linear":
            assert "gravity_confounded" not in info, info


def test_gravity_left_in_a_sine_tests_torque_is_said_to_be_inside_the_estimate():
    """0.1 Fc of gravity on j1 under its torque sine: M comes out ~17 % low (tuning seeds
    1630-1631) with nothing named, and only the warning can say why."""
    spec = PRESETS["j1"]
    rec = _undeclared(make_record(spec, recording_for(spec, "white process noise", 5824), 5824,
                                  effects=["gravity:amplitude=150"]))
    doc = analyze_record(rec, inertia="estimate").report()
    info = doc["fit"]["inertia_estimate"]
    assert info["inertia"] < 0.9 * spec.inertia and "gravity_confounded" in info, info
    assert any("gravity left in the torque are one measurement" in w for w in doc["warnings"])


def _p2p(joint, seed, cogging):
    spec = PRESETS[joint]
    Fc, tr = spec.friction.Fc, _travel(spec)
    ref = point_to_point(tr, 0.5 / spec.excitation[1], 30.0, np.random.default_rng([seed, 9]))
    physics = dict(detent=0.06 * Fc, detent_pitch=tr / 7, detent_h2=0.4) if cogging else None
    rec, _ = independent_record(spec, duration=30.0, seed=seed, pd=(6.0, 0.0, 1.5), reference=ref,
                                jitter=0.3, drop=0.005, disturbance=0.01 * Fc, physics=physics)
    doc = analyze_record(_undeclared(rec), inertia="estimate").report()
    return joint, doc["fit"]["inertia_estimate"], spec.inertia, [d["effect"] for d in doc["diagnosis"] if d["significant"]]


def test_the_inertia_is_read_off_another_simulators_robot_logs_and_the_diagnosis_runs_on_it():
    """PID-tracked point-to-point moves with cogging, the independent simulator.  Tuning seeds
    1620-1627 (j1-j4, the linear stage): the regression 0.88-1.21 of the true inertia, refitted
    beside LuGre and the named cogging 0.974-1.079 (within 1.2 of its standard errors); cogging
    named first on 8 of 8 (a Stribeck shape beside it on j2, as with the inertia declared)."""
    # (seeds 5817-5823 showed the regression's own widening flag 2 of 6 such logs, 5830-5835 a
    # refusal of a wide first value; both were changed, and these seeds had seen neither)
    rows = map_records(_p2p, [("j1", 5840, True), ("j3", 5841, True), ("j4", 5842, True),
                              ("linear", 5843, True), ("j2", 5844, True), ("j1", 5845, False)])
    for joint, info, true, named in rows:
        # within its reported uncertainty (cogging left out of a fit widens it to ~10 %)
        assert abs(info["inertia"] / true - 1) < max(0.03, 3 * info["standard_error"] / true), (joint, info, true)
        assert "inertia_error" not in named
    assert sum(named[:1] != ["cogging"] for *_, named in rows[:5]) <= 1, rows
    # dwells at many poses separate inertia from gravity
    assert not [info for _, info, _, _ in rows if "gravity_confounded" in info], rows
    assert rows[5][3] == [] and rows[5][1]["beside"] == [], rows[5]


def test_the_cli_estimates_on_request_and_says_what_it_wants_otherwise(tmp_path):
    spec = PRESETS["j2"]
    rec = _undeclared(make_record(spec, recording_for(spec, "white process noise", 5821), 5821))
    csv = tmp_path / "arm.csv"
    csv.write_text(rec.to_csv())
    r = run("analyze", csv)
    assert r.returncode == 2 and "no inertia" in r.stderr and "Traceback" not in r.stderr
    r = run("analyze", csv, "--inertia", "heavy")
    assert r.returncode == 2 and "'estimate'" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = run("analyze", csv, "--inertia", "estimate", "--json", tmp_path / "a.json")
    assert r.returncode == 0, r.stderr
    info = json.loads((tmp_path / "a.json").read_text())["fit"]["inertia_estimate"]
    assert abs(info["inertia"] / spec.inertia - 1) < max(0.03, 3 * info["standard_error"] / spec.inertia), info
    csv.write_text("# inertia: estimate\n" + rec.to_csv())
    r = run("analyze", csv, "--json", tmp_path / "b.json")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "b.json").read_text())["fit"]["inertia_estimate"] == info
    r = run("analyze", csv, "--add", "inertia_error")
    assert r.returncode == 2 and "estimated from itself" in r.stderr
