"""End-to-end: `calibrate` on both presets, unattended, with the default transport: the
presets' emulated drives (lock-step VirtualBench) reached through the real CANopen
(python-canopen) and serial (ODrive ASCII over a pty) stacks."""
import json

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from bench.lugre import LuGreParams
from bench.store import Store
from bench.traces import read_trace
from procedures.cli import register
from procedures.config import load_bench
from procedures.tracking import tracking_test

from proc_helpers import real_rig, tolerance_failures, truth

app = typer.Typer()
register(app)


@app.command("noop")
def _noop():  # a second command keeps typer in multi-command mode
    pass


def run_cli(*args):
    return CliRunner().invoke(app, ["calibrate", *args])


EXPECTED_DRIVERS = {"canopen": "Cia402Drive", "serial": "OdriveAsciiDrive"}


def check_limits(store: Store, cfg) -> int:
    """Every sample of every trace inside every joint's limits; returns the samples checked."""
    checked = 0
    for run in store.list_runs(limit=1000):
        d = store.run_dir(run["id"])
        if not any(d.glob("*.parquet")):
            continue
        tr = read_trace(d)
        for j in cfg.joints:
            q = tr.column(f"q_{j['id']}").to_numpy()
            lo, hi = j["position_limits"]
            assert np.all(np.isfinite(q)), f"{j['id']}: non-finite position in run {run['id']}"
            assert lo <= q.min() and q.max() <= hi, f"{j['id']} left its limits in run {run['id']}"
            checked += len(q)
    return checked


def check_real_stacks(report: dict, cfg) -> None:
    assert report["transport"] == "virtual" and report["clock"] == "lockstep"
    assert report["control_period"] == cfg.control_period
    assert report["drivers"] == {j["id"]: EXPECTED_DRIVERS[j["transport"]] for j in cfg.joints}


@pytest.fixture(scope="module")
def macro4(tmp_path_factory):
    data = tmp_path_factory.mktemp("macro4")
    out = data / "report.json"
    r = run_cli("--bench", "macro4", "--data", str(data), "--json", str(out), "--seed", "11", "--no-plots")
    assert r.exit_code == 0, r.output
    return data, json.loads(out.read_text())


@pytest.mark.parametrize("preset,seed", [("micro2", 23)])
def test_calibrate_micro2(tmp_path, preset, seed):
    out = tmp_path / "r.json"
    r = run_cli("--bench", preset, "--data", str(tmp_path), "--json", str(out), "--seed", str(seed))
    assert r.exit_code == 0, r.output
    report = json.loads(out.read_text())
    cfg = load_bench(preset)
    check_real_stacks(report, cfg)       # linear on CANopen, rotary on serial
    assert set(report["joints"]) == set(cfg.ids)
    for jid, j in report["joints"].items():
        assert j["status"] == "succeeded", j["reason"]
        ident = j["stages"]["identify"]["result"]
        assert tolerance_failures(ident["parameters"], truth(cfg, jid), ident["identifiable"]) == [], jid
        assert j["stages"]["validate"]["result"]["improvement"] > 1.0
        assert j["stages"]["validate"]["result"]["plot"].endswith("tracking.png")
    assert check_limits(Store(tmp_path), cfg) > 10000
    assert (tmp_path / "runs" / report["run_id"] / "report.html").exists()


def test_calibrate_macro4_parameters_and_limits(macro4):
    data, report = macro4
    cfg = load_bench("macro4")
    check_real_stacks(report, cfg)       # j1, j2 on CANopen, j3, j4 on serial
    assert set(report["joints"]) == {"j1", "j2", "j3", "j4"}
    for jid, j in report["joints"].items():
        assert j["status"] == "succeeded", j["reason"]
        ident = j["stages"]["identify"]["result"]
        assert tolerance_failures(ident["parameters"], truth(cfg, jid), ident["identifiable"]) == [], jid
        # the calibration's own validation, on the same stacks
        assert j["stages"]["validate"]["result"]["improvement"] >= 5.0, jid
    assert check_limits(Store(data), cfg) > 50000


def test_macro4_tracking_compensation(macro4):
    """With the identified model: RMS error <= 1/5 of uncompensated, <= 1.5x the true model's,
    on every joint, through the real CANopen / serial stacks (another seed than calibration)."""
    _, report = macro4
    cfg = load_bench("macro4")
    with real_rig(cfg, seed=23) as rig:
        assert {type(d).__name__ for d in rig.drives.values()} == {"Cia402Drive", "OdriveAsciiDrive"}
        for jid in cfg.ids:
            params = LuGreParams.from_dict(report["joints"][jid]["stages"]["identify"]["result"]["parameters"])
            res = tracking_test(rig, jid, {"none": None, "identified": params, "true": truth(cfg, jid)})
            assert res["identified"]["rms_error"] <= res["none"]["rms_error"] / 5, (jid, res)
            assert res["identified"]["rms_error"] <= 1.5 * res["true"]["rms_error"], (jid, res)
            assert all(lo <= s.position <= hi for s, (lo, hi) in
                       ((rig.samples[j], cfg.joint(j)["position_limits"]) for j in cfg.ids))


def test_unreachable_sliding_ends_with_reason(tmp_path):
    toml = tmp_path / "tight.toml"
    raw_text = "\n".join([
        'name = "tight"', "[[joints]]", 'id = "j3"', 'preset = "j3"', 'transport = "simulated"',
        "inertia = 30.0", "gravity = [0.0, 0.0]", "position_limits = [-0.01, 0.01]",
        "velocity_limit = 0.38", "torque_limit = 1500.0", "counts_per_unit = 394704.0", ""])
    toml.write_text(raw_text)
    out = tmp_path / "r.json"
    r = run_cli("--bench", str(toml), "--data", str(tmp_path / "d"), "--json", str(out), "--no-plots")
    assert r.exit_code == 1, r.output
    j3 = json.loads(out.read_text())["joints"]["j3"]
    assert j3["status"] == "failed" and "cannot reach sliding" in j3["reason"] and "workspace" in j3["reason"]
    assert j3["stages"]["identify"]["status"] == "skipped"


@pytest.mark.parametrize("args,message", [
    (["--bench", "nope"], "no such bench file"),
    (["--bench", "macro4", "--joints", "j9"], "no joint 'j9'"),
    (["--bench", "macro4", "--rt-priority", "99"], "--rt-priority must be 0 (off) to 98"),
    (["--bench", "macro4", "--excitation", "chirp"], "--excitation must be one of sine, two_level"),
])
def test_bad_input_exit_2(tmp_path, args, message):
    r = CliRunner().invoke(app, ["calibrate", *args, "--data", str(tmp_path)])
    assert r.exit_code == 2 and message in r.output and "Traceback" not in r.output


def test_virtual_transport_needs_presets(tmp_path):
    """A bench of real drives (no preset) cannot be emulated: one line, exit 2, no run left."""
    toml = tmp_path / "hw.toml"
    toml.write_text("\n".join([
        'name = "hw"', "[[joints]]", 'id = "a"', 'transport = "canopen"', 'interface = "socketcan"',
        'channel = "can0"', "inertia = 2.0", "position_limits = [-1.0, 1.0]", "velocity_limit = 1.0",
        "torque_limit = 10.0", "counts_per_unit = 10000.0", ""]))
    r = run_cli("--bench", str(toml), "--data", str(tmp_path / "d"), "--no-plots")
    assert r.exit_code == 2 and "has no preset" in r.output and "Traceback" not in r.output
    assert Store(tmp_path / "d").list_runs() == []
