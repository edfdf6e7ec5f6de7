"""What survives a crash, and what a careless or hostile client cannot do, against
``bench serve`` in its own process on loopback (real uvicorn, SQLite, emulated drives behind
the real CANopen / serial stacks):

* the e-stop latch survives ``kill -9`` and a restart; a run moving at the crash ends
  ``interrupted`` with the progress it had and the time it was last heard of;
* ``kill -9`` of the server leaves none of its processes behind (run processes, the
  analysis worker, the forkserver, multiprocessing's resource tracker), even while a run fits;
* a 60 MB body without a key is refused before it is read (server RSS grows < 20 MB);
* the data directory is 0700 and the store files 0600 under umask 000, and a key file that
  others may write is not trusted.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import httpx
import pytest
from api_helpers import ServeProcess, sse_events, wait_run

from api.server import free_port

SHORT = {"plots": False, "search_cycles": 2.0}


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from /proc's children lists)."""
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/task/{p}/children") as f:
                kids = [int(x) for x in f.read().split()]
        except OSError:
            continue
        out.update(kids)
        todo.extend(kids)
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _rss_kb(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))


def _kill9(server: ServeProcess) -> None:
    server.proc.send_signal(signal.SIGKILL)
    server.proc.wait(10)
    server.log.close()


def test_latch_and_interrupted_runs_survive_kill9(tmp_path):
    data = tmp_path / "data"
    a = ServeProcess("macro4", data)
    try:
        with a.client() as c:
            run_id = c.post("/runs", json={"procedure": "identify", "joints": ["j3"], "options": SHORT}).json()["id"]
            sse_events(c, f"/runs/{run_id}/events", stop=lambda ev: ev["event"] == "sample")
            time.sleep(1.5)                 # far enough for progress to be recorded (1 s period)
            moving = c.get(f"/runs/{run_id}").json()
            assert moving["state"] == "running" and moving["progress"] > 0, (moving["error"], moving)
    finally:
        _kill9(a)
    killed_at = time.time()
    b = ServeProcess("macro4", data)
    try:
        with b.client() as c:
            run = wait_run(c, run_id, deadline=30)
            assert run["state"] == "interrupted", (run["error"], run)
            assert run["progress"] >= moving["progress"] > 0, (run, moving)
            assert run["ended"] <= killed_at + 5.0       # when it stopped, not when the server restarted
            assert c.get("/estop").json()["active"] is False
            stop = c.post("/estop").json()
            assert stop["active"] is True
    finally:
        _kill9(b)
    c2 = ServeProcess("macro4", data)
    try:
        with c2.client() as c:
            latch = c.get("/estop").json()
            assert latch["active"] is True and latch["reason"] == stop["reason"], latch
            assert latch["triggered_at"] == pytest.approx(stop["triggered_at"])
            refused = c.post("/runs", json={"procedure": "identify", "joints": ["j1"]})
            assert refused.status_code == 409 and "e-stop" in refused.json()["detail"]
            assert c.get("/health").json()["estop"] is True
            assert c.post("/estop/reset").status_code == 200          # only an admin reset clears it
            assert c.get("/estop").json()["active"] is False
    finally:
        c2.stop()
    d = ServeProcess("macro4", data)       # and a reset is state too
    try:
        with d.client() as c:
            assert c.get("/estop").json()["active"] is False
    finally:
        d.stop()


def _kill9_while_fitting(tmp_path, record, attempt):
    """Start an identify run of j4, kill -9 the server once the run says it fits: (the
    descendants still alive 60 s on, the wall time of the kill, j4's models, the run's state)."""
    data = tmp_path / f"data{attempt}"
    s = ServeProcess("macro4", data)
    try:
        with s.client() as c:
            run_id = c.post("/runs", json={"procedure": "identify", "joints": ["j4"], "options": SHORT}).json()["id"]
            sse_events(c, f"/runs/{run_id}/events", stop=lambda ev: ev["event"] == "sample")
            r = c.post("/analyze", params={"diagnose": "false"}, content=record.read_bytes(),
                       headers={"content-type": "text/csv"}, timeout=120)
            assert r.status_code == 200, r.text          # the analysis worker exists now
            children = _descendants(s.proc.pid)
            names = {open(f"/proc/{p}/cmdline").read().replace("\0", " ")[:80] for p in children if _alive(p)}
            assert len(children) >= 3, names              # forkserver, run process, analysis worker, tracker
            # the kill lands while the run fits j4 (its joints parked): the slow case
            sse_events(c, f"/runs/{run_id}/events", stop=lambda ev: ev["event"] == "stage"
                       and (ev["data"].get("data") or {}).get("stage") == "identify")
    finally:
        kill_wall = time.time()
        _kill9(s)
    # a run caught moving stops and exits within a second (0.6-1.2 s); one caught fitting (its
    # joints parked) stops at the fit's next evaluation or held-out learner (bench.checkpoint)
    # -- before, it finished the fit: 11-36 s here on a loaded 2-core machine (2026-11-28,
    # j4's diagnosis).  A learner took up to 5+ s beside the full suite (py-spy), and a CI
    # machine may be slower, hence the margin (the loop ends as soon as all are gone)
    killed = time.monotonic()
    while any(_alive(p) for p in children) and time.monotonic() < killed + 60.0:
        time.sleep(0.1)
    left = {p: open(f"/proc/{p}/cmdline").read().replace("\0", " ")[:100] for p in children if _alive(p)}
    from bench.store import Store
    store = Store(data)
    return left, kill_wall, store.list_models("j4"), store.get_run(run_id)


def test_kill9_leaves_no_process_behind(tmp_path):
    """No process outlives a kill -9 of the server, and a fit caught by it keeps no model.
    The kill follows the run's "identify" event as the event stream delivers it; on a loaded
    machine that can come after a short fit has ended (CI 2026-12-06, beside measurement
    scripts: j4's model stored before the kill), so a kill that landed after the fit is tried
    again -- a model stored after the kill fails at once."""
    from bench.cli import run as cli
    record = tmp_path / "j3.csv"
    assert cli(["simulate", "--joint", "j3", "--duration", "10", "--seed", "5021", "-o", str(record)]) == 0
    for attempt in range(3):
        left, kill_wall, models, run = _kill9_while_fitting(tmp_path, record, attempt)
        assert not left, f"still alive 60 s after kill -9 of the server: {left}"
        late = [m for m in models if m["created"] >= kill_wall]
        assert not late, f"the fit ran on after the kill and stored a model: {late}"
        if not models:      # the kill landed during the fit, and the fit stopped
            assert run["state"] == "interrupted", run
            return
    raise AssertionError("the kill landed after j4's fit in 3 of 3 attempts: the fit was never caught")


def test_60mb_body_without_key_is_refused_before_it_is_read(tmp_path):
    s = ServeProcess("micro2", tmp_path / "data")
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            c.get("/health")
            before = _rss_kb(s.proc.pid)
            big = b"x" * (60 * 1024 * 1024)
            for path in ("/runs", "/analyze"):
                try:
                    r = c.post(path, content=big, headers={"content-type": "application/json"})
                    assert r.status_code == 413, r.text
                except httpx.TransportError:
                    pass                      # refused and closed while we were still sending
                chunks = (big[i:i + 1 << 20] for i in range(0, len(big), 1 << 20))   # no Content-Length
                try:
                    r = c.post(path, content=chunks, headers={"content-type": "text/csv"})
                    assert r.status_code in (401, 413), r.text
                except httpx.TransportError:
                    pass
            grown = _rss_kb(s.proc.pid) - before
            assert c.get("/health").status_code == 200    # still serving
        assert grown < 20 * 1024, f"server RSS grew by {grown / 1024:.1f} MB"
    finally:
        s.stop()


def test_private_files_under_umask_000_and_untrusted_key_file(tmp_path):
    data = tmp_path / "data"
    code = ("import os; os.umask(0); from api.app import ServiceConfig, build_service; "
            f"build_service(ServiceConfig(bench='micro2', data_dir={str(data)!r}, api_key=''))")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
    assert os.stat(data).st_mode & 0o777 == 0o700
    for f in ("runs.sqlite", "api_keys.json", "admin.key"):
        assert os.stat(data / f).st_mode & 0o777 == 0o600, f
    os.chmod(data / "api_keys.json", 0o666)             # anyone could add an admin key now
    r = subprocess.run([sys.executable, "-m", "bench.cli", "serve", "--bench", "micro2", "--data", str(data),
                        "--port", str(free_port())], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "BENCH_API_KEY": ""})
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "not trusted" in r.stderr and "writable by group or others" in r.stderr


def test_failed_authentications_are_rate_bounded_and_keys_capped(tmp_path):
    from api.app import ServiceConfig, build_service, create_app
    from api.auth import MAX_KEYS
    from api.limits import AuthFailures
    from api.server import serve_in_thread
    conf = ServiceConfig(bench="micro2", data_dir=tmp_path / "data", transport="simulated", api_key="")
    svc, admin_file = build_service(conf)
    admin = admin_file.read_text().strip()
    with serve_in_thread(create_app(conf, svc)) as url, httpx.Client(base_url=url, timeout=10) as anon, \
            httpx.Client(base_url=url, headers={"Authorization": f"Bearer {admin}"}, timeout=10) as c:
        codes = []         # until refused (bounded: the bucket refills while we send)
        while (not codes or codes[-1] != 429) and len(codes) < 4000:
            codes.append(anon.get("/runs", headers={"Authorization": f"Bearer wrong-{len(codes)}"}).status_code)
        assert codes[-1] == 429, f"{len(codes)} failed authentications and never refused"
        assert set(codes[:-1]) == {401} and len(codes) > AuthFailures.BURST     # the burst first
        # the bucket refills 1 token in 1 / RATE s (20 ms), so a follow-up that waits that long
        # is a fresh 401 (how many depends on this machine's request time): the refusals go on,
        # interleaved with at most the refilled tokens' 401s
        follow = [anon.get("/runs") for _ in range(20)]
        refused = [r for r in follow if r.status_code == 429]
        assert refused and {r.status_code for r in follow} <= {401, 429}, [r.status_code for r in follow]
        limited = refused[0]
        assert int(limited.headers["Retry-After"]) >= 1
        assert "valid API key" in limited.json()["detail"]
        assert c.get("/runs").status_code == 200          # a valid key is never throttled
        assert c.get("/health").status_code == 200
        made = len(svc.keys.list())
        for i in range(MAX_KEYS - made):
            assert c.post("/keys", json={"role": "observer", "name": f"k{i}"}).status_code == 201
        over = c.post("/keys", json={"role": "observer", "name": "one too many"})
        assert over.status_code == 409 and "limit" in over.json()["detail"], over.text
        assert len(c.get("/keys").json()["keys"]) == MAX_KEYS
