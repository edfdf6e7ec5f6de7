"""A calibration killed with SIGKILL mid-run: interrupted, partial trace readable, resumable.
Default transport: the emulated drives through the real serial stack (j3, j4: ODrive ASCII)."""
import json
import os
import signal
import subprocess
import sys
import time

import typer
from typer.testing import CliRunner

from bench.store import Store
from bench.traces import read_trace
from procedures.cli import register


def _resume(data, out) -> dict:
    """``bench calibrate --bench macro4 --resume``; its JSON report."""
    app = typer.Typer()
    register(app)
    app.command("noop")(lambda: None)
    r = CliRunner().invoke(app, ["calibrate", "--bench", "macro4", "--resume", "--data", str(data),
                                 "--json", str(out), "--no-plots"])
    assert r.exit_code == 0, r.output
    return json.loads(out.read_text())


def test_sigkill_then_resume(tmp_path):
    data = tmp_path / "data"
    cmd = [sys.executable, "-m", "procedures.cli", "calibrate", "--bench", "macro4", "--joints", "j3,j4",
           "--data", str(data), "--no-plots", "--seed", "23"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    victim = None
    try:
        deadline = time.time() + 120
        while time.time() < deadline and victim is None:
            time.sleep(0.2)
            if not (data / "runs.sqlite").exists():
                continue
            for r in Store(data).list_runs(kind="excitation", state="running"):
                if r["joint_id"] == "j4" and any(Store(data).run_dir(r["id"]).glob("chunk-*.parquet")):
                    victim = r["id"]
        assert victim is not None, "calibration never reached j4's search"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    store = Store(data)
    store.recover()
    cal = store.list_runs(kind="calibration")[0]
    assert cal["state"] == "interrupted"
    assert store.get_run(victim)["state"] == "interrupted"
    partial = read_trace(store.run_dir(victim))
    assert partial.num_rows > 500 and "q_j4" in partial.column_names
    plan = {(p["joint"], p["stage"]): p["status"] for p in cal["result"]["plan"]}
    assert plan[("j3", "validate")] == "done" and plan[("j4", "search")] == "running"

    report = _resume(data, tmp_path / "r.json")
    assert report["run_id"] == cal["id"]
    assert report["transport"] == "virtual" and report["drivers"]["j4"] == "OdriveAsciiDrive"
    assert {j: v["status"] for j, v in report["joints"].items()} == {"j3": "succeeded", "j4": "succeeded"}
    assert store.get_run(cal["id"])["state"] == "succeeded"
    # j3's finished stages were kept, not redone
    assert len(store.list_runs(kind="excitation", joint_id="j3")) == 1
    assert len(store.list_runs(kind="excitation", joint_id="j4")) == 2


def test_a_calibration_cancelled_while_fitting_resumes_at_the_fit(tmp_path):
    """A cancel while the joints are parked for the fit stops the fit (bench.checkpoint): the
    identify stage goes back to pending with no model, and a resume fits the search's saved
    record without moving the joint again."""
    from procedures.calibration import CalibrationSettings, calibrate, start_calibration
    from procedures.events import Cancel

    store = Store(tmp_path)
    run_id = start_calibration(store, "macro4", ["j3"], seed=31)
    cancel = Cancel()

    def on_event(ev):
        d = ev["data"]
        if ev["name"] == "stage" and d.get("stage") == "identify" and d.get("status") == "running":
            cancel.set("cancelled while fitting")

    report = calibrate(store, run_id, on_event=on_event, cancel=cancel, settings=CalibrationSettings(plots=False))
    run = store.get_run(run_id)
    assert cancel.is_set() and run["state"] == "cancelled", run["state"]
    plan = {p["stage"]: p["status"] for p in run["result"]["plan"]}
    assert plan == {"search": "done", "identify": "pending", "validate": "pending"}, plan
    assert report["joints"]["j3"]["status"] != "succeeded"
    assert store.list_models("j3") == []

    report = calibrate(store, run_id, settings=CalibrationSettings(plots=False))
    assert report["joints"]["j3"]["status"] == "succeeded", report["joints"]["j3"]
    assert len(store.list_models("j3")) == 1
    assert len(store.list_runs(kind="excitation", joint_id="j3")) == 1      # not searched again


def test_ctrl_c_cancels_the_calibration_and_resume_goes_on(tmp_path):
    """The first Ctrl-C (SIGINT) on `bench calibrate` is a cancel: the joints brake under
    control, the run ends 'cancelled' (before: KeyboardInterrupt wherever it landed, the run
    left 'running' until the next start), exit 130 with the command that goes on; --resume
    finishes it without searching the finished joint again."""
    data = tmp_path / "data"
    # started as from a terminal: SIGINT deliverable and at its default.  A child inherits its
    # parent's blocked signals and ignored ones; in two fresh clones' full suites (2026-11-29)
    # the first SIGINT never reached the calibration (it ran to the end, exit 0) though it does
    # run alone and in the solo block: the worker's state, not the command, so it is reset here
    reset = ("import os, signal, sys; signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT]); "
             "signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.executable, [sys.executable] + sys.argv[1:])")
    cmd = [sys.executable, "-c", reset, "-m", "procedures.cli", "calibrate", "--bench", "macro4", "--joints", "j3,j4",
           "--data", str(data), "--no-plots", "--seed", "29"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        moving = None
        while time.time() < deadline and moving is None and proc.poll() is None:
            time.sleep(0.2)
            if (data / "runs.sqlite").exists():
                moving = next((r for r in Store(data).list_runs(kind="excitation", state="running")
                               if r["joint_id"] == "j4"), None)
        assert moving is not None, "calibration never reached j4's search"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (out, err)
    assert "Traceback" not in err and "--resume" in err, err
    store = Store(data)
    cal = store.list_runs(kind="calibration")[0]
    assert cal["state"] == "cancelled"
    assert store.get_run(moving["id"])["state"] == "cancelled"
    plan = {(p["joint"], p["stage"]): p["status"] for p in cal["result"]["plan"]}
    assert plan[("j3", "validate")] == "done" and plan[("j4", "search")] == "pending", plan

    report = _resume(data, tmp_path / "r.json")
    assert report["run_id"] == cal["id"]
    assert {j: v["status"] for j, v in report["joints"].items()} == {"j3": "succeeded", "j4": "succeeded"}
    assert len(store.list_runs(kind="excitation", joint_id="j3")) == 1
