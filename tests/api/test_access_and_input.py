"""Keys and roles (401/403), bad input (422 naming the field, 404), and POST /analyze."""
from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

import api
from virtual_drives.joint import simulate_record
from virtual_drives.presets import preset

READS = ["/joints", "/joints/j1", "/runs", "/estop", "/runs/nope"]


@pytest.mark.parametrize("path", READS)
def test_no_key_is_401(live, path):
    with live.client() as c:
        r = c.get(path)
    assert r.status_code == 401 and "API key" in r.json()["detail"]
    assert r.headers["www-authenticate"] == "Bearer"


def test_wrong_key_is_401_and_health_is_open(live):
    with live.client("not-a-key") as c:
        assert c.get("/joints").status_code == 401
        assert c.post("/estop").status_code == 401          # not even an e-stop from a stranger
        assert c.get("/health").status_code == 200


def test_page_is_open_but_holds_no_data_and_whoami_needs_a_key(live, observer, admin):
    with live.client() as c:
        page = c.get("/")
        assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
        assert 'id="estop"' in page.text
        js = c.get("/static/api.js")
        assert js.status_code == 200 and "javascript" in js.headers["content-type"]
        # everything is served from here: no file of the page names another host (no CDN)
        static = Path(api.__file__).with_name("static")
        assert {f.name for f in static.iterdir()} >= {"index.html", "api.js", "app.js", "plot.js", "style.css"}
        for f in static.iterdir():
            text = c.get(f"/static/{f.name}").text
            assert "://" not in text, f.name
        assert c.get("/static/../auth.py").status_code == 404        # only the static folder is served
        assert c.get("/static/nope.js").status_code == 404
        assert c.get("/whoami").status_code == 401
    assert observer.get("/whoami").json()["role"] == "observer"
    assert admin.get("/whoami").json()["role"] == "admin"


def test_roles(live, observer, operator, admin):
    assert observer.get("/joints/j1").status_code == 200
    for method, path, body in [("post", "/runs", {"procedure": "identify", "joints": ["j1"]}),
                               ("put", "/joints/j1/compensation", {"enabled": False}),
                               ("post", "/runs/x/cancel", None), ("post", "/keys", {"role": "observer"})]:
        r = getattr(observer, method)(path, **({"json": body} if body is not None else {}))
        assert r.status_code == 403, r.text
        assert "operator" in r.json()["detail"] or "admin" in r.json()["detail"]
    assert operator.post("/keys", json={"role": "admin"}).status_code == 403
    assert operator.get("/keys").status_code == 403
    assert operator.post("/estop/reset").status_code == 403
    assert operator.put("/joints/j4/compensation", json={"enabled": False}).status_code == 200
    keys = admin.get("/keys").json()["keys"]
    assert {"admin", "operator", "observer"} <= {k["role"] for k in keys}
    assert all("sha256" not in k and "key" not in k for k in keys)


def test_keys_are_stored_hashed_in_private_files(live):
    data = live.svc.data_dir
    for name in ("api_keys.json", "admin.key"):
        assert stat.S_IMODE(os.stat(data / name).st_mode) == 0o600
    stored = (data / "api_keys.json").read_text()
    assert live.operator not in stored and live.admin not in stored


def test_revoked_key_is_refused(live, admin):
    made = admin.post("/keys", json={"role": "observer", "name": "temp"}).json()
    with live.client(made["key"]) as c:
        assert c.get("/joints").status_code == 200
        assert admin.delete(f"/keys/{made['id']}").status_code == 204
        assert c.get("/joints").status_code == 401


@pytest.mark.parametrize("body, field", [
    ({"procedure": "dance", "joints": ["j1"]}, "body.procedure"),
    ({"joints": ["j1"]}, "body.procedure"),
    ({"procedure": "identify", "joints": "j1"}, "body.joints"),
    ({"procedure": "identify", "joints": ["j1"], "options": {"search_max_trials": 0}}, "body.options.search_max_trials"),
    ({"procedure": "identify", "joints": ["j1"], "options": {"warp": 9}}, "body.options.warp"),
    ({"procedure": "identify", "joints": []}, "joints"),
    ({"procedure": "identify", "joints": ["j1", "j1"]}, "joints"),
])
def test_bad_run_bodies_are_422_naming_the_field(operator, body, field):
    r = operator.post("/runs", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith(field) and "\n" not in r.json()["detail"]


def test_not_json_is_422(operator):
    r = operator.post("/runs", content=b"{nope", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["detail"].startswith("body")


def test_unknown_joint_run_or_model_is_404(operator):
    assert operator.get("/joints/j9").status_code == 404
    r = operator.post("/runs", json={"procedure": "identify", "joints": ["j9"]})
    assert r.status_code == 404 and "j9" in r.json()["detail"]
    for path in ("/runs/nope", "/runs/nope/trace.csv", "/runs/nope/report", "/runs/nope/events"):
        assert operator.get(path).status_code == 404, path
    assert operator.post("/runs/nope/cancel").status_code == 404
    assert operator.put("/joints/j1/compensation", json={"enabled": True, "model": "m-x"}).status_code == 404


def test_tracking_without_model_is_refused_before_starting(operator):
    r = operator.post("/runs", json={"procedure": "tracking", "joints": ["j4"], "options": {"compensation": "on"}})
    assert r.status_code == 422 and "no identified model" in r.json()["detail"]


def _record_csv() -> str:
    spec = preset("rotary")
    a, f = spec.excitation
    return simulate_record(spec, a, f, 6.0, dt=1e-3, seed=4).record.to_csv()


def test_analyze_csv_body_and_multipart(operator):
    text = _record_csv()
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=180)
    assert r.status_code == 200, r.text
    assert set(r.json()["parameters"]) >= {"Fc", "Fs", "sigma0"}
    r = operator.post("/analyze", files={"file": ("rec.csv", text, "text/csv")}, params={"diagnose": "false"},
                      timeout=180)
    assert r.status_code == 200, r.text
    doc = r.json()
    # the same rows without their times (a scope's export), at the rate the query gives
    lines = text.splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    rows = [ln.split(",", 1)[1] for ln in lines if not ln.startswith("#")]
    untimed = "\n".join(head + rows)
    r = operator.post("/analyze", content=untimed, headers={"content-type": "text/csv"},
                      params={"diagnose": "false", "sample_rate": 1000}, timeout=180)
    assert r.status_code == 200 and r.json()["input"]["columns"]["t"] == "row number / 1000 Hz", r.text
    assert r.json()["parameters"] == pytest.approx(doc["parameters"], rel=1e-6)
    r = operator.post("/analyze", content=untimed, headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=60)
    assert r.status_code == 422 and "?sample_rate=HZ" in r.json()["detail"], r.text


def test_analyze_an_upload_whose_inertia_is_to_be_estimated(operator):
    """A CSV saying ``# inertia: estimate``, and one whose declared inertia the query's
    ``inertia=estimate`` overrides (README, bench.inertia_estimate)."""
    import re
    declared = _record_csv()
    asked = re.sub(r"# inertia: [^\n]*", "# inertia: estimate", declared)
    assert asked != declared
    for text, params in ((asked, {}), (declared, {"inertia": "estimate"})):
        r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"},
                          params={"diagnose": "false", **params}, timeout=180)
        assert r.status_code == 200, r.text
        info = r.json()["fit"]["inertia_estimate"]
        assert abs(info["inertia"] / preset("rotary").inertia - 1) < 0.05, info


def test_analyze_names_a_hidden_effect_and_answers_strict_json(operator):
    """An upload whose diagnosis names an effect: the report carries its steps (each with its
    candidates' scores), and the answer is strict JSON (a NaN score once answered 500 here)."""
    import json

    from virtual_drives.conditions import make_record
    rec, _ = make_record(preset("rotary"), "clean", seed=5730, duration=8.0,
                         effects=("cogging:amplitude=0.02,pitch=0.3",))
    r = operator.post("/analyze", content=rec.to_csv(), headers={"content-type": "text/csv"}, timeout=180)
    assert r.status_code == 200, r.text

    def refuse(name):
        raise AssertionError(f"not strict JSON: {name}")
    doc = json.loads(r.text, parse_constant=refuse)
    assert doc["final"]["effects"] == ["cogging"], doc["final"]["effects"]
    assert doc["steps"][0]["effect"] == "cogging" and doc["steps"][0]["candidates"]
    assert doc["unexplained"]["structured"] is False


def _slow_record_csv() -> str:
    """A j1 record whose full analysis took 135 s in the worker here (2026-11-28): the motor's
    torque constant falls at high current, physics the library lacks, so the diagnosis refits
    every gear candidate (fresh seed)."""
    import numpy as np

    from bench.records import Record
    from virtual_drives.joint import sine_torque
    spec = preset("j1")
    amp, freq = spec.excitation
    t = np.arange(20000) * 1e-3
    cmd = sine_torque(amp, freq, t)
    felt = cmd * (1.0 - 0.05 * (cmd / amp) ** 2)
    rec = simulate_record(spec, amp, freq, 20.0, seed=5651, tau=felt).record
    return Record(t=rec.t, tau=cmd + (rec.tau - felt), q=rec.q, meta=rec.meta).to_csv()


def test_an_analysis_its_client_gave_up_on_frees_the_worker(live, operator):
    """The analysis process takes one upload at a time: one whose client timed out is stopped
    (api.analysis_worker), so the next upload does not wait the two minutes it had left."""
    import time

    import httpx
    with pytest.raises(httpx.ReadTimeout):
        operator.post("/analyze", content=_slow_record_csv(), headers={"content-type": "text/csv"}, timeout=5)
    gave_up = time.monotonic()
    r = operator.post("/analyze", content=_record_csv(), headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=180)
    assert r.status_code == 200, r.text
    # the quick record: 0.3-3 s; behind the slow one (before): 138 s
    assert time.monotonic() - gave_up < 40, time.monotonic() - gave_up


def test_analyze_parquet_and_mat_bodies_with_a_column_mapping(operator, tmp_path):
    """A logger's file with its own column names and units, as Parquet (by content type) and
    as MATLAB .mat (application/octet-stream: told by its magic bytes), whose signals may
    bring times of their own."""
    import io

    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq
    from scipy.io import savemat
    spec = preset("rotary")
    rec = simulate_record(spec, *spec.excitation, 6.0, dt=1e-3, seed=5401).record
    cols = {"time": rec.t, "motor_torque_mNm": rec.tau * 1e3, "angle_deg": np.degrees(rec.q)}
    params = {"columns": "t=time,tau=motor_torque_mNm,q=angle_deg", "torque_unit": "mN*m",
              "position_unit": "deg", "inertia": spec.inertia, "diagnose": "false"}
    buf = io.BytesIO()
    pq.write_table(pa.table(cols), buf)
    r = operator.post("/analyze", content=buf.getvalue(), params=params,
                      headers={"content-type": "application/vnd.apache.parquet"}, timeout=180)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["units"]["conversions"]["torque"]["factor"] == 1e-3 and doc["input"]["format"] == "parquet"
    assert abs(doc["parameters"]["Fc"] / spec.friction.Fc - 1) < 0.05
    buf = io.BytesIO()
    savemat(buf, {"log": cols})
    r = operator.post("/analyze", content=buf.getvalue(), params=params,
                      headers={"content-type": "application/octet-stream"}, timeout=180)
    assert r.status_code == 200 and r.json()["parameters"] == doc["parameters"], r.text
    import gzip             # the same .mat as a logger keeps it, gzipped (bench.containers)
    r = operator.post("/analyze", content=gzip.compress(buf.getvalue()), params=params,
                      headers={"content-type": "application/gzip"}, timeout=180)
    assert r.status_code == 200 and r.json()["parameters"] == doc["parameters"], r.text
    assert r.json()["input"]["container"] == "gzip" and r.json()["input"]["format"] == "mat", r.json()["input"]
    buf = io.BytesIO()      # a logger counting milliseconds: the same record
    pq.write_table(pa.table(dict(cols, time=np.round(rec.t * 1e3, 6))), buf)
    r = operator.post("/analyze", content=buf.getvalue(), params=dict(params, time_unit="ms"),
                      headers={"content-type": "application/vnd.apache.parquet"}, timeout=180)
    assert r.status_code == 200 and r.json()["units"]["conversions"]["time"]["from"] == "ms", r.text
    assert r.json()["parameters"] == pytest.approx(doc["parameters"], rel=1e-6)
    for bad, expect in (({"columns": "t=time,tau=nope,q=angle_deg"}, "no column 'nope'"),
                        ({"columns": "t=time,tau=motor_torque_mNm"}, "missing: q"),
                        ({"inertia": -1}, "inertia"), ({"inertia": "heavy"}, "or 'estimate', got 'heavy'"),
                        ({"time_unit": "min"}, "time_unit"),
                        ({"window": "9:1"}, "window '9:1' is not START:END")):
        r = operator.post("/analyze", content=buf.getvalue(), params=dict(params, **bad),
                          headers={"content-type": "application/octet-stream"}, timeout=60)
        assert r.status_code == 422 and expect in r.json()["detail"] and "\n" not in r.json()["detail"], r.text
    # MATLAB signals with times of their own (bench.own_times): joined on them; without, 422
    sws = lambda t, v: {"time": t, "signals": {"values": v.reshape(-1, 1), "dimensions": 1}}
    buf = io.BytesIO()
    savemat(buf, {"trq": sws(rec.t, cols["motor_torque_mNm"]), "ang": sws(rec.t[::2], cols["angle_deg"][::2])})
    own = dict(params, columns="t=trq.time,tau=trq,q=ang")
    r = operator.post("/analyze", content=buf.getvalue(), params=own,
                      headers={"content-type": "application/x-matlab-data"}, timeout=180)
    assert r.status_code == 200 and r.json()["input"]["own_times"] == {"q": "ang.time"}, r.text
    assert abs(r.json()["parameters"]["Fc"] / spec.friction.Fc - 1) < 0.05, r.json()["parameters"]
    buf = io.BytesIO()
    savemat(buf, {"time": rec.t, "trq": cols["motor_torque_mNm"], "ang": cols["angle_deg"][::2]})
    r = operator.post("/analyze", content=buf.getvalue(), params=dict(params, columns="t=time,tau=trq,q=ang"),
                      headers={"content-type": "application/x-matlab-data"}, timeout=60)
    assert r.status_code == 422 and "differ in length" in r.json()["detail"], r.text


def test_analyze_a_logger_file_stating_its_units_with_a_wrapping_counter_and_angle(operator):
    """A logger's CSV as it comes (units in the header, a 16-bit millisecond counter, an angle
    in [-180, 180) degrees) through the server: the same parameters as the SI record, and the
    report says what was read and unwrapped; the same with no mapping and its own names."""
    import numpy as np
    spec = preset("rotary")
    rec = simulate_record(spec, *spec.excitation, 8.0, dt=1e-3, seed=5402).record
    si = operator.post("/analyze", content=rec.to_csv(), headers={"content-type": "text/csv"},
                       params={"diagnose": "false"}, timeout=180)
    assert si.status_code == 200, si.text
    ms = (np.round(rec.t * 1e3).astype(np.int64) + 62000) % 65536
    angle = np.mod(np.degrees(rec.q + 2.0) + 180.0, 360.0) - 180.0
    text = f"# inertia: {spec.inertia}\nt [ms],tau [Nm],q [deg]\n" + "\n".join(
        f"{a},{b:.9g},{c:.12g}" for a, b, c in zip(ms, rec.tau, angle))
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=180)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["units"]["from_header"] == {"t": "ms", "tau": "N*m", "q": "deg"}
    assert doc["input"]["time_counter"] == {"bits": 16, "wraps": 1} and doc["input"]["turns_unwrapped"] >= 1
    assert doc["parameters"] == pytest.approx(si.json()["parameters"], rel=1e-5)
    # the same with a lab script's names, units after an underscore (bench.column_names)
    named = text.replace("t [ms],tau [Nm],q [deg]", "time_ms,effort_Nm,angle_deg", 1)
    r = operator.post("/analyze", content=named, headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=180)
    assert r.status_code == 200, r.text
    assert r.json()["parameters"] == pytest.approx(si.json()["parameters"], rel=1e-5)
    assert any("'angle_deg' as position" in w for w in r.json()["warnings"]), r.json()["warnings"]
    # a log of two joints: the one asked for (bench.joint_columns); without it, told to choose
    several = f"# inertia: {spec.inertia}\nt [ms],tau1 [Nm],tau2 [Nm],q1 [deg],q2 [deg]\n" + "\n".join(
        f"{a},0.5,{b:.9g},12.5,{c:.12g}" for a, b, c in zip(ms, rec.tau, angle))
    got = {joint: operator.post("/analyze", content=several, headers={"content-type": "text/csv"},
                                params={"diagnose": "false", **({"joint": joint} if joint else {})}, timeout=180)
           for joint in ("2", None, "a b")}
    assert [r.status_code for r in got.values()] == [200, 422, 422], [r.text for r in got.values()]
    assert "a log of several joints (1, 2): choose one with ?joint=N" in got[None].json()["detail"]
    assert all("\n" not in got[j].text for j in (None, "a b"))
    r = got["2"]
    assert r.json()["parameters"] == pytest.approx(si.json()["parameters"], rel=1e-5)
    assert r.json()["input"]["joint"] == "2"


@pytest.mark.parametrize("content, ctype, status", [
    (b"t,tau\n0,1\n", "text/csv", 422),
    (b"\xff\xfe\x00garbage", "text/csv", 422),
    (b"", "text/csv", 422),
    (b"<xml/>", "application/xml", 415),
])
def test_analyze_bad_records(operator, content, ctype, status):
    r = operator.post("/analyze", content=content, headers={"content-type": ctype}, timeout=60)
    assert r.status_code == status, r.text
    assert "\n" not in r.json()["detail"]


def test_serve_refuses_a_bad_rt_priority_before_touching_anything(tmp_path):
    """One line, exit 2, no data directory created (the server never starts)."""
    import subprocess
    import sys

    from api.server import free_port
    data = tmp_path / "d"
    # a free port: on 8000 another server (a technician's own `bench serve`) would be refused first
    r = subprocess.run([sys.executable, "-m", "bench.cli", "serve", "--rt-priority", "99", "--data", str(data),
                        "--port", str(free_port())], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.strip() == "error: rt_priority must be 0 (off) to 98, got 99", r.stderr
    assert "Traceback" not in r.stderr and not data.exists()


def test_analyze_a_friction_velocity_map(operator):
    """A table of speed and friction (no time, no position) is analysed as a map; an effect
    that needs the record in time is a one-line 422."""
    import numpy as np

    from bench.lugre import LuGreParams
    rng = np.random.default_rng(10271)
    p = LuGreParams(3.0, 4.2, 8.0, 0.0, 0.0, 1.5)
    speeds = np.geomspace(0.02, 3.0, 10)
    v = np.concatenate([speeds, -speeds])
    F = p.steady_state(v) + 0.4 + rng.normal(0.0, 0.005, len(v))      # a 0.4 N*m offset
    text = "speed [rpm],torque [N*m]\n" + "\n".join(f"{a * 30 / np.pi:.6g},{b:.6g}" for a, b in zip(v, F))
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"}, timeout=60)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["record"] == "friction_map" and doc["units"]["conversions"]["velocity"]["from"] == "rpm"
    assert [d["effect"] for d in doc["diagnosis"] if d["significant"]] == ["torque_offset"], doc["diagnosis"]
    assert doc["parameters"]["Fc"] == pytest.approx(3.0, rel=0.03)
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"}, params={"add": "cogging"},
                      timeout=60)
    assert r.status_code == 422 and "friction-velocity map" in r.json()["detail"], r.text


def test_analyze_with_plots_and_the_effect_library(operator, observer, live):
    """``plots=true`` adds the report's PNGs as data: URIs (the technician's page shows them),
    for a record in time and for a friction-velocity map; ``GET /effects`` lists what ``add``
    takes, and which of it a map can show."""
    import base64

    import httpx
    import numpy as np

    from bench.effects import EFFECTS
    from bench.lugre import LuGreParams

    def pngs(doc):
        assert doc["plots"], doc.get("plots")
        for name, uri in doc["plots"].items():
            head, _, data = uri.partition(",")
            assert head == "data:image/png;base64", (name, head)
            raw = base64.b64decode(data, validate=True)
            assert raw[:8] == b"\x89PNG\r\n\x1a\n" and len(raw) > 5_000, name
        return set(doc["plots"])

    text = _record_csv()
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"},
                      params={"plots": "true", "add": "torque_offset"}, timeout=180)
    assert r.status_code == 200, r.text
    assert pngs(r.json()) >= {"map", "presliding", "residual_baseline", "error_fall"}
    r = operator.post("/analyze", content=text, headers={"content-type": "text/csv"},
                      params={"diagnose": "false"}, timeout=180)
    assert r.status_code == 200 and "plots" not in r.json()      # only when asked: 25-210 kB each
    rng = np.random.default_rng(10342)
    speeds = np.geomspace(0.02, 3.0, 10)
    v = np.concatenate([speeds, -speeds])
    F = LuGreParams(3.0, 4.2, 8.0, 0.0, 0.0, 1.5).steady_state(v) + rng.normal(0.0, 0.005, len(v))
    table = "velocity,torque\n" + "\n".join(f"{a:.6g},{b:.6g}" for a, b in zip(v, F))
    r = operator.post("/analyze", content=table, headers={"content-type": "text/csv"},
                      params={"plots": "true", "add": "torque_offset"}, timeout=60)
    assert r.status_code == 200 and r.json()["record"] == "friction_map", r.text
    assert pngs(r.json()) == {"friction_map"}
    assert [(d["effect"], d["added"]) for d in r.json()["diagnosis"]] == [("torque_offset", True)]
    listed = observer.get("/effects").json()["effects"]
    assert [e["name"] for e in listed] == list(EFFECTS)
    assert {e["name"] for e in listed if e["on_maps"]} == {"torque_offset", "direction_asymmetry", "stribeck_shape"}
    assert all(e["summary"] for e in listed)
    assert httpx.get(live.url + "/effects").status_code == 401
    r = operator.post("/analyze", content=table, headers={"content-type": "text/csv"}, params={"encoder": "side"})
    assert r.status_code == 422 and "encoder" in r.text, r.text


def test_analyze_returns_the_residuals_at_the_files_own_timestamps(operator, tmp_path):
    """``residuals=true`` adds ``bench analyze --residuals``'s CSV as text: for a robot-shaped
    log (its own column names, a friction column, a jittered logger with lost samples, time
    in ms) the very rows the command line writes, one per row of the upload, at its own times;
    a map's are one per point.  Only when asked."""
    import csv
    import io

    import numpy as np

    from bench.analysis import analyze_record
    from bench.readers import read_record
    from independent_joint import independent_record

    spec = preset("j2")
    rec, _ = independent_record(spec, duration=8.0, seed=10366, jitter=0.3, drop=0.01,
                                disturbance=0.01 * spec.friction.Fc)
    friction = rec.tau - spec.inertia * np.gradient(np.gradient(rec.q, rec.t), rec.t)
    body = "time_ms,joint_pos,tau_fric\n" + "".join(
        f"{t * 1e3:.3f},{q:.9g},{f:.9g}\n" for t, q, f in zip(rec.t, rec.q, friction))
    params = {"columns": "t=time_ms,q=joint_pos,tau=tau_fric", "inertia": "0", "time_unit": "ms"}
    r = operator.post("/analyze", files={"file": ("log.csv", body, "text/csv")},
                      params={**params, "residuals": "true"}, timeout=180)
    assert r.status_code == 200, r.text
    text = r.json()["residuals_csv"]
    rows = list(csv.DictReader(io.StringIO(text)))
    assert list(rows[0]) == ["t", "measured", "baseline", "final", "held_out"]
    assert len(rows) == len(rec.t)
    assert np.allclose([float(row["t"]) for row in rows], rec.t * 1e3, atol=5e-4)
    assert {row["held_out"] for row in rows} == {"0", "1"}
    measured = np.array([float(row["measured"]) for row in rows])
    assert np.isfinite(measured).mean() > 0.9
    # the command line's file, from the same bytes and options
    path = tmp_path / "log.csv"
    path.write_text(body)
    local = analyze_record(read_record(path, columns=params["columns"], inertia=0.0, time_unit="ms"),
                           inertia=0.0)
    local.write_residuals(tmp_path / "res.csv")
    assert text == (tmp_path / "res.csv").read_text()
    r = operator.post("/analyze", files={"file": ("log.csv", body, "text/csv")},
                      params={**params, "diagnose": "false"}, timeout=180)
    assert r.status_code == 200 and "residuals_csv" not in r.json()
    # a map: a row per point, by velocity
    speeds = np.geomspace(0.02, 3.0, 8)
    table = "velocity,torque\n" + "".join(f"{v:.6g},{np.sign(v) * (3 + 1.5 * abs(v)):.6g}\n"
                                          for v in np.concatenate([speeds, -speeds]))
    r = operator.post("/analyze", content=table, headers={"content-type": "text/csv"},
                      params={"residuals": "true", "diagnose": "false"}, timeout=60)
    assert r.status_code == 200, r.text
    lines = r.json()["residuals_csv"].splitlines()
    assert lines[0] == "velocity,measured,baseline,final,held_out" and len(lines) == 17
