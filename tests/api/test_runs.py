"""End to end over HTTP: identify, tracking with compensation off/on, live events + cancel,
e-stop, busy joints.  Runs are shortened through their options; nothing here asserts timing
(latencies are measured by benchmarks/bench_api.py)."""
from __future__ import annotations

import threading

import pytest

from api_helpers import sse_events, wait_run

SHORT_SEARCH = {"search_max_trials": 8, "seed": 5}
SHORT_TRACKING = {"tracking_period": 2.0, "tracking_cycles": 1.0, "plots": False}


@pytest.fixture(scope="module")
def identified_j1(live):
    """identify j1 once (with plots: the report test reads them); shared by the tests below."""
    with live.client(live.operator) as c:
        r = c.post("/runs", json={"procedure": "identify", "joints": ["j1"], "options": SHORT_SEARCH})
        assert r.status_code == 202, r.text
        assert r.headers["location"] == f"/runs/{r.json()['id']}"
        return wait_run(c, r.json()["id"])


def test_identify_j1_succeeds_with_parameters(identified_j1, observer):
    run = identified_j1
    assert run["state"] == "succeeded", run["error"]
    assert run["progress"] == 1.0
    j1 = run["result"]["joints"]["j1"]
    assert set(j1["parameters"]) >= {"Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2"}
    assert all(v > 0 for v in j1["parameters"].values())
    assert isinstance(j1["diagnosis"], list) and j1["excitation"]["trials"] >= 1
    assert run["result"]["control"]["cycles"] > 0
    # the run process that owned it, as it ran (lock-step bench: normal priority)
    assert run["result"]["control"]["scheduling"]["policy"] == "normal"
    assert run["created"] <= run["started"] <= run["ended"], run
    joint = observer.get("/joints/j1").json()
    assert joint["state"] == "idle" and joint["model"]["id"] == j1["model_id"]
    assert joint["drive"]["state"] == "disabled" and joint["drive"]["open"] is False
    report = observer.get(f"/runs/{run['id']}/report")
    assert report.status_code == 200 and report.headers["content-type"].startswith("text/html")
    assert "data:image/png;base64" in report.text
    csv = observer.get(f"/runs/{run['id']}/trace.csv", params={"every": 50})
    assert csv.status_code == 200
    assert [ln for ln in csv.text.splitlines() if not ln.startswith("#")][0] == "t,tau,q,qd"
    assert run["id"] in [r["id"] for r in observer.get("/runs", params={"procedure": "identify"}).json()["runs"]]


def test_tracking_error_falls_with_compensation(identified_j1, operator):
    model = identified_j1["result"]["joints"]["j1"]["model_id"]
    rms = {}
    for enabled in (False, True):
        r = operator.put("/joints/j1/compensation", json={"enabled": enabled, "model": model})
        assert r.status_code == 200 and r.json()["enabled"] is enabled and r.json()["model_id"] == model
        r = operator.post("/runs", json={"procedure": "tracking", "joints": ["j1"], "options": SHORT_TRACKING})
        assert r.status_code == 202, r.text
        run = wait_run(operator, r.json()["id"])
        assert run["state"] == "succeeded", run["error"]
        res = run["result"]["joints"]["j1"]
        assert res["compensation"] == ("on" if enabled else "off")
        rms[enabled] = res["rms_error"]
    assert rms[True] < 0.5 * rms[False], rms
    operator.put("/joints/j1/compensation", json={"enabled": False})


def test_a_cancel_while_the_joint_is_fitted_stops_the_fit(live, operator, observer):
    """Cancelled once the search is done and the joints are parked for the fit: the run ends
    'cancelled' with no model (the fit stops at its next evaluation, bench.checkpoint), and the
    recorded motion is kept.  Before, the fit ran to its end and the run ended 'succeeded'."""
    before = observer.get("/joints/j2").json()["model"]
    r = operator.post("/runs", json={"procedure": "identify", "joints": ["j2"], "options": SHORT_SEARCH})
    assert r.status_code == 202, r.text
    run_id = r.json()["id"]
    cancelled = threading.Event()

    def on_event(ev):
        d = ev["data"].get("data") or {}
        if ev["event"] == "stage" and d.get("stage") == "identify" and d.get("status") == "running" \
                and not cancelled.is_set():
            cancelled.set()
            assert operator.post(f"/runs/{run_id}/cancel").status_code == 202

    events = sse_events(observer, f"/runs/{run_id}/events", on_event=on_event)
    assert cancelled.is_set(), [e["event"] for e in events]
    names = [e["event"] for e in events]
    assert "model" not in names, names
    assert [e for e in events if e["event"] == "stop"][-1]["data"]["name"] == "cancelled"
    run = wait_run(observer, run_id)
    assert run["state"] == "cancelled" and "cancel" in run["error"], run
    assert observer.get("/joints/j2").json()["model"] == before
    csv = observer.get(f"/runs/{run_id}/trace.csv", params={"joint": "j2"})
    assert csv.status_code == 200
    assert len([ln for ln in csv.text.splitlines() if ln and not ln.startswith("#")]) > 100


def test_live_events_then_cancel_keeps_partial_trace(live, operator, observer):
    r = operator.post("/runs", json={"procedure": "identify", "joints": ["j3"], "options": {"seed": 2}})
    assert r.status_code == 202, r.text
    run_id = r.json()["id"]
    # the joint is taken: a second run on it, or a calibration (every joint), is refused
    assert operator.post("/runs", json={"procedure": "tracking", "joints": ["j3"]}).status_code == 409
    busy = operator.post("/runs", json={"procedure": "calibrate"})
    assert busy.status_code == 409 and "j3" in busy.json()["detail"]
    seen: set[str] = set()
    cancelled = threading.Event()

    def on_event(ev):
        seen.add(ev["event"])
        # cancel once the search has decided a trial and live samples have arrived
        if {"trial", "sample"} <= seen and not cancelled.is_set():
            cancelled.set()
            assert operator.post(f"/runs/{run_id}/cancel").status_code == 202

    events = sse_events(observer, f"/runs/{run_id}/events", on_event=on_event, params={"sample_hz": 20})
    assert cancelled.is_set(), f"no trial+sample before the end: {seen}"
    names = [e["event"] for e in events]
    assert names[0] == "start" and "progress" in names and names[-1] == "end"
    stop = [e for e in events if e["event"] == "stop"]
    assert stop and stop[-1]["data"]["name"] == "cancelled"
    sample = next(e for e in events if e["event"] == "sample")["data"]["samples"]["j3"]
    assert set(sample) >= {"t", "position", "velocity", "torque"}

    run = wait_run(observer, run_id)
    assert run["state"] == "cancelled" and "cancel" in run["error"]
    assert 0 < run["progress"] < 1
    joint = observer.get("/joints/j3").json()
    assert joint["state"] == "idle" and joint["drive"]["state"] == "disabled" and joint["drive"]["torque"] == 0
    csv = observer.get(f"/runs/{run_id}/trace.csv", params={"joint": "j3"})
    assert csv.status_code == 200
    rows = [ln for ln in csv.text.splitlines() if ln and not ln.startswith("#")]
    assert rows[0] == "t,tau,q,qd" and len(rows) > 1000      # the partial trace was kept


def test_estop_during_run_turns_every_torque_off(live, operator, observer, admin):
    r = operator.post("/runs", json={"procedure": "tracking", "joints": ["j2", "j4"],
                                     "options": {"compensation": "off", "tracking_cycles": 4.0, "plots": False}})
    assert r.status_code == 202, r.text
    run_id = r.json()["id"]
    try:
        sse_events(observer, f"/runs/{run_id}/events", stop=lambda ev: ev["event"] == "sample")
        stop = observer.post("/estop")          # any valid key may stop the bench
        assert stop.status_code == 200, stop.text
        body = stop.json()
        assert body["active"] is True
        stopped = {d["joint"]: d for d in body["drives"]}
        assert {"j2", "j4"} <= set(stopped)
        assert all(d["torque_off"] is True for d in body["drives"]), body["drives"]
        assert observer.get("/joints/j2").json()["state"] == "estopped"
        again = operator.post("/runs", json={"procedure": "identify", "joints": ["j1"]})
        assert again.status_code == 409 and "e-stop" in again.json()["detail"]
        run = wait_run(observer, run_id)
        assert run["state"] == "failed" and "emergency stop" in run["error"]
        for jid in ("j2", "j4"):
            drive = observer.get(f"/joints/{jid}").json()["drive"]
            assert drive["open"] is False and drive["state"] in ("disabled", "quick_stop", "fault")
        assert operator.post("/estop/reset").status_code == 403
    finally:
        wait_run(admin, run_id)
        assert admin.post("/estop/reset").status_code == 200
    assert observer.get("/estop").json()["active"] is False


def test_estop_reaches_a_calibration_and_its_drives(live, operator, observer, admin):
    """A calibration opens its drives inside procedures.calibration (through the wrap_drives
    hook): the e-stop must reach all four of them, and the run must end failed."""
    r = operator.post("/runs", json={"procedure": "calibrate", "joints": ["j3"], "options": {"plots": False}})
    assert r.status_code == 202, r.text
    run_id = r.json()["id"]
    assert operator.post("/runs", json={"procedure": "identify", "joints": ["j1"]}).status_code == 409
    try:
        sse_events(observer, f"/runs/{run_id}/events", stop=lambda ev: ev["event"] == "sample")
        body = observer.post("/estop").json()
        assert {d["joint"] for d in body["drives"]} == {"j1", "j2", "j3", "j4"}
        assert all(d["torque_off"] is True for d in body["drives"]), body["drives"]
        run = wait_run(observer, run_id)
        assert run["state"] == "failed" and "emergency stop" in run["error"]
        assert run["result"]["joints"]["j3"]["status"] != "succeeded"
        assert run["options"]["plots"] is False        # the record keeps what was asked for
    finally:
        wait_run(admin, run_id)
        assert admin.post("/estop/reset").status_code == 200
