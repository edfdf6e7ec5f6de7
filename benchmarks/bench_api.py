"""Benchmark: the REST service under load while a calibration runs on a realtime bench.

Not a timed test: prints a markdown table.  Loopback only; bounded request counts and time.

    python benchmarks/bench_api.py [--pattern poll|page] [--clients 50] [--poll 0.2] [--pages 20]
                                   [--seconds 5] [--rounds 6] [--estops 5]
                                   [--client-cpus server|any] [--client-procs N] [--no-pin] [--rt-priority N]
    python benchmarks/bench_api.py --estop-table 20      # only: e-stop per run type, both clocks

1. ``bench serve`` in a child process with macro4 switched to the realtime clock, as in
   production: every run's control loop runs in its own process (``api.run_process``), its
   emulated CANopen / serial drives paced at 1 ms there, its host pacer counting missed
   periods (overruns).  The server relays each run's live count; ``/health`` sums them.  By
   default the server keeps the last CPU and the control processes get the others
   (``api.cpus``; ``--no-pin`` turns that off).
2. A calibration of the bench starts (its rig cycles all four joints every period), with
   10-cycle search trials so that the phases below all fall in its first stage.
3. ``--rounds`` pairs of phases of ``--seconds`` each: quiet (no clients), then loaded.
   ``--pattern poll``: ``--clients`` concurrent clients each polling ``GET /runs/{id}`` every
   ``--poll`` s plus one SSE stream (10 Hz samples).  ``--pattern page``: ``--pages`` open
   technician's pages (api/static), each doing what the page does, at the rates the page
   declares (``POLL`` in api/static/api.js, read from there): every page polls ``/health``;
   half of them are on the live view of the calibration (``GET /runs/{id}`` plus their own
   event stream at the page's sample rate), the other half on the bench view (``GET
   /joints/{id}`` for every joint).  Latency percentiles of every request; host overruns per
   phase kind from /health (the calibration's process).  Targets: p99 <= 50 ms, no more
   overruns loaded than quiet: overruns come in bursts on a shared VM, so the rounds' ratio
   carries a bootstrap interval (``overrun_comparison``); more rounds narrow it.
4. The calibration is cancelled; its run record's overrun count is reported.
5. E-stop latency, ``--estops`` times: a tracking run on j3+j4 moving, then POST /estop;
   client round trip and the server's latch -> every run process answered (its drives
   stopped and read back).  Target <= 50 ms.

The clients stand in for technicians' browsers on other machines.  ``--pattern page``: light
HTTP/1.1 clients in ``--client-procs`` processes (default one per page; ``page_clients.py``
says why not httpx in one process); ``--pattern poll``: httpx in this process.
``--client-cpus server`` (default) keeps them on the server's CPU, so what the control loop
sees under load is what the server costs it; ``any`` lets them take the control CPU too
(``--client-nice`` lowers their priority).  Client processes freeze their heaps: a collector
pause would bunch the requests of all their clients.  Besides latency (which a loaded machine
inflates), the table gives CPU time per request of the server and of the clients, which
hardly depends on the machine's other load.  On a shared machine read the printed load first.
"""
from __future__ import annotations

import argparse
import asyncio
import gc
import json
import multiprocessing
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import httpx
import numpy as np

import page_clients
from api import cpus
from api.server import free_port


def start_server(tmp: Path, port: int, pin: bool = True, rt_priority: int = 0,
                 clock: str = "realtime") -> subprocess.Popen:
    text = resources.files("procedures.benches").joinpath("macro4.toml").read_text()
    bench = tmp / f"macro4-{clock}.toml"
    bench.write_text(re.sub(r'^clock = "lockstep"', f'clock = "{clock}"', text, flags=re.M))
    env = {**os.environ, "BENCH_API_KEY": ""}
    proc = subprocess.Popen([sys.executable, "-c", "from bench.cli import main; main()", "serve", "--bench", str(bench),
                             "--data", str(tmp / "data"), "--port", str(port), "--log-level", "warning",
                             "--pin-cpus" if pin else "--no-pin-cpus", "--rt-priority", str(rt_priority)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, env=env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/health", timeout=1).status_code == 200:
                return proc
        except httpx.HTTPError:
            time.sleep(0.2)
    proc.kill()
    raise SystemExit("server did not start")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` (all its threads; not its children)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def overrun_comparison(pairs: list[tuple[int, int]], draws: int = 20000) -> str:
    """Loaded against quiet overruns, round by round.  Overruns on a shared VM come in bursts
    (one hypervisor stall is tens of missed periods, in whichever phase it falls), so a sum
    over a few rounds says little: the ratio of the sums gets a 95 % bootstrap interval over
    rounds, beside how many rounds had more under load than quiet and fewer."""
    q, l = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    if len(q) == 0:
        return "no rounds"
    idx = np.random.default_rng(0).integers(0, len(q), (draws, len(q)))
    ratio = l[idx].sum(1) / np.maximum(q[idx].sum(1), 1)
    lo, hi = np.percentile(ratio, [2.5, 97.5])
    return (f"ratio {l.sum() / max(q.sum(), 1):.2f} (95 % CI {lo:.2f}-{hi:.2f}); rounds with more loaded "
            f"{int((l > q).sum())}, fewer {int((l < q).sum())}, equal {int((l == q).sum())}; "
            f"median per round {np.median(q):g} / {np.median(l):g}")


def pct(xs: list[float], p: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100 * (len(xs) - 1))))]


async def load(url: str, key: str, run_id: str, clients: int, poll: float, seconds: float) -> dict:
    lat: list[float] = []
    errors = 0
    sse_events = 0
    stop_at = time.monotonic() + seconds
    headers = {"Authorization": f"Bearer {key}"}
    limits = httpx.Limits(max_connections=clients + 5, max_keepalive_connections=clients + 5)
    async with httpx.AsyncClient(base_url=url, headers=headers, timeout=10, limits=limits) as c:
        async def poller(i: int):
            nonlocal errors
            await asyncio.sleep(poll * i / clients)        # spread the clients over a poll period
            while time.monotonic() < stop_at:
                t0 = time.perf_counter()
                try:
                    r = await c.get(f"/runs/{run_id}")
                    ok = r.status_code == 200
                except httpx.HTTPError:
                    ok = False
                lat.append(time.perf_counter() - t0)
                errors += not ok
                await asyncio.sleep(max(0.0, poll - (time.perf_counter() - t0)))

        async def sse():
            nonlocal sse_events
            try:
                async with c.stream("GET", f"/runs/{run_id}/events", params={"sample_hz": 10},
                                    timeout=httpx.Timeout(10, read=seconds + 10)) as r:
                    async for line in r.aiter_lines():
                        if line.startswith("event:"):
                            sse_events += 1
                        if time.monotonic() >= stop_at:
                            return
            except httpx.HTTPError:
                pass

        await asyncio.gather(sse(), *[poller(i) for i in range(clients)])
    return {"latencies": lat, "errors": errors, "sse_events": sse_events}


def page_pattern() -> dict:
    """The page's own polling periods and sample rate: the ``POLL`` line of api/static/api.js."""
    text = resources.files("api").joinpath("static/api.js").read_text()
    m = re.search(r"^export const POLL = (\{.*\});$", text, flags=re.M)
    if m is None:
        raise SystemExit("api/static/api.js: no 'export const POLL = {...};' line")
    return json.loads(m.group(1))


def overruns(c: httpx.Client) -> int:
    return c.get("/health").json()["host_overruns"] or 0


def wait_state(c: httpx.Client, run_id: str, states, timeout: float = 60) -> dict:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        info = c.get(f"/runs/{run_id}").json()
        if info["state"] in states:
            return info
        time.sleep(0.1)
    raise SystemExit(f"run {run_id} not in {states} after {timeout} s")


RUN_TYPES = {     # e-stop table: each run type on a CANopen and a serial joint (a calibration: all four)
    "identify": {"procedure": "identify", "joints": ["j1", "j3"], "options": {"plots": False}},
    "tracking": {"procedure": "tracking", "joints": ["j1", "j3"],
                 "options": {"compensation": "off", "plots": False, "tracking_cycles": 2.0}},
    "calibrate": {"procedure": "calibrate", "options": {"plots": False, "search_max_trials": 2,
                                                        "search_cycles": 1.0, "tracking_cycles": 0.5}},
}


def estop_table(clock: str, n: int, pin: bool) -> list[str]:
    """``n`` e-stops per run type on macro4 with the ``clock``, each at a drawn moment (0-0.6 s)
    after the run's drives are open: the client's round trip, the server's latch -> every
    drive confirmed, and whether every drive reported its torque off."""
    import random
    rng = random.Random(7)
    rows = []
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp, port = Path(tmpdir), free_port()
        proc = start_server(tmp, port, pin=pin, clock=clock)
        try:
            key = (tmp / "data" / "admin.key").read_text().strip()
            c = httpx.Client(base_url=f"http://127.0.0.1:{port}", headers={"Authorization": f"Bearer {key}"},
                             timeout=30)
            for kind, body in RUN_TYPES.items():
                rtt, server, confirmed, drives = [], [], 0, 0
                for _ in range(n):
                    rid = c.post("/runs", json=body).json()["id"]
                    end = time.monotonic() + 60
                    while time.monotonic() < end and not c.get("/joints/j1").json()["drive"]["open"]:
                        time.sleep(0.02)
                    time.sleep(rng.uniform(0.0, 0.6))
                    t0 = time.perf_counter()
                    stop = c.post("/estop").json()
                    rtt.append(1e3 * (time.perf_counter() - t0))
                    server.append(stop["stop_latency_ms"])
                    drives += len(stop["drives"])
                    confirmed += sum(d["torque_off"] is True for d in stop["drives"])
                    wait_state(c, rid, ("failed", "cancelled", "succeeded", "interrupted"), 120)
                    while c.post("/estop/reset").status_code == 409:
                        time.sleep(0.1)
                rows.append(f"| {clock} | {kind} | {n} | {statistics.median(rtt):.1f} / {max(rtt):.1f} | "
                            f"{statistics.median(server):.1f} / {max(server):.1f} | {confirmed} / {drives} |")
        finally:
            proc.terminate()
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pattern", choices=("poll", "page"), default="poll",
                    help="poll: --clients polling one run + one SSE stream; page: --pages open pages "
                         "following the page's own request pattern")
    ap.add_argument("--pages", type=int, default=20, help="--pattern page: open pages")
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--poll", type=float, default=0.2, help="s between one client's polls")
    ap.add_argument("--seconds", type=float, default=5.0, help="length of one quiet and of one loaded phase")
    ap.add_argument("--rounds", type=int, default=6, help="quiet/loaded phase pairs")
    ap.add_argument("--estops", type=int, default=5)
    ap.add_argument("--client-nice", type=int, default=0, help="niceness of this (client) process")
    ap.add_argument("--client-cpus", choices=("server", "any"), default="server",
                    help="clients on the server's CPU (default) or on any CPU")
    ap.add_argument("--client-procs", type=int, default=0,
                    help="--pattern page: client processes, the pages dealt out among them (0: one per page)")
    ap.add_argument("--no-pin", action="store_true", help="bench serve --no-pin-cpus")
    ap.add_argument("--rt-priority", type=int, default=0,
                    help="bench serve --rt-priority: SCHED_FIFO for the run control processes (0: normal)")
    ap.add_argument("--estop-table", type=int, default=0, metavar="N",
                    help="only the e-stop table: N stops per run type on the lock-step and the realtime bench")
    args = ap.parse_args()
    load0, uptime0 = os.getloadavg()[0], uptime()
    if args.estop_table:
        rows = [r for clock in ("lockstep", "realtime") for r in estop_table(clock, args.estop_table, not args.no_pin)]
        print(f"## E-stop per run type (macro4; {args.estop_table} stops each, 0-0.6 s after the drives opened)\n")
        print(f"uptime at start: {uptime0}\nuptime at end:   {uptime()}\n")
        print("| clock | run type | stops | round trip (client) median / max [ms] | latch -> drives confirmed "
              "(server) median / max [ms] | drives torque_off: true |")
        print("|---|---|---|---|---|---|")
        print("\n".join(rows))
        return
    placement = None if args.no_pin else cpus.split()
    client_cpus = placement[0] if args.client_cpus == "server" and placement is not None else None
    # the clients stand in for technicians' browsers on other machines; --client-nice lets
    # them yield the shared cores to the server (but then their own latency clock suffers)
    if args.client_nice:
        os.nice(args.client_nice)
    procs = min(args.pages, args.client_procs or args.pages)
    pool = None
    if args.pattern == "page":      # started before the server: their start-up is not measured
        pool = multiprocessing.get_context("spawn").Pool(procs, initializer=page_clients.worker_init,
                                                           initargs=(client_cpus,))
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        port = free_port()
        proc = start_server(tmp, port, pin=not args.no_pin, rt_priority=args.rt_priority)
        if client_cpus is not None:
            cpus.pin(client_cpus)
        # the clients' garbage collector pauses would bunch their requests (and add to the
        # latencies they measure): browsers on other machines do neither
        gc.collect()
        gc.freeze()
        url = f"http://127.0.0.1:{port}"
        try:
            key = (tmp / "data" / "admin.key").read_text().strip()
            c = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {key}"}, timeout=10)
            # every joint: in realtime that lasts minutes, longer than the phases (cancelled after).
            # Long search trials keep the whole measurement inside j1's excitation search: a
            # stage change parks the rig for a fraction of a second, and the pacer counts such
            # a pause as hundreds of missed periods, in whichever phase it falls
            r = c.post("/runs", json={"procedure": "calibrate", "options": {"plots": False, "search_cycles": 10}})
            run_id = r.json()["id"]
            joints = [j["id"] for j in c.get("/joints").json()["joints"]]
            wait_state(c, run_id, ("running",))
            time.sleep(3.0)                              # past rig start-up
            # alternate quiet and loaded phases: the machine is shared, its background load
            # drifts, and adjacent phases see about the same background
            pairs: list[tuple[int, int]] = []     # host overruns per round, quiet / loaded
            res = {"latencies": [], "errors": 0, "sse_events": 0}
            by_kind: dict[str, list[float]] = {}
            cpu = {"server": 0.0, "clients": 0.0}     # CPU seconds the load cost, over all rounds
            poll = page_pattern()
            for _ in range(args.rounds):
                o0, s0, t0 = overruns(c), cpu_seconds(proc.pid), time.monotonic()
                time.sleep(args.seconds)
                o1, s1, t1 = overruns(c), cpu_seconds(proc.pid), time.monotonic()
                if args.pattern == "page":
                    start_at = time.monotonic() + 0.05
                    parts = pool.starmap(page_clients.worker, [
                        (url, key, run_id, list(range(k, args.pages, procs)), args.pages, joints, poll, start_at,
                         args.seconds) for k in range(procs)])
                    part = {"latencies": [x for p in parts for x in p["latencies"]], "by_kind": {},
                            **{k: sum(p[k] for p in parts) for k in ("errors", "sse_events", "cpu")}}
                    for p in parts:
                        for k, v in p["by_kind"].items():
                            part["by_kind"].setdefault(k, []).extend(v)
                else:
                    r0 = time.process_time()
                    part = asyncio.run(load(url, key, run_id, args.clients, args.poll, args.seconds))
                    part["cpu"] = time.process_time() - r0
                o2, s2, t2 = overruns(c), cpu_seconds(proc.pid), time.monotonic()
                if c.get(f"/runs/{run_id}").json()["state"] != "running":
                    break           # the calibration ended in this round: no control loop to compare
                pairs.append((o1 - o0, o2 - o1))
                # the server's CPU time beyond its quiet rate (relaying the run's status)
                cpu["server"] += (s2 - s1) - (s1 - s0) / (t1 - t0) * (t2 - t1)
                cpu["clients"] += part["cpu"]
                for k in res:
                    res[k] += part[k]
                for k, v in part.get("by_kind", {}).items():
                    by_kind.setdefault(k, []).extend(v)
            still = c.get(f"/runs/{run_id}").json()["state"]
            c.post(f"/runs/{run_id}/cancel")
            final = wait_state(c, run_id, ("succeeded", "failed", "cancelled", "interrupted"), 120)
            run_overruns = (final.get("result") or {}).get("control", {}).get("host_overruns")

            rtt, server = [], []
            for i in range(args.estops):
                r = c.post("/runs", json={"procedure": "tracking", "joints": ["j3", "j4"],
                                          "options": {"compensation": "off", "plots": False}})
                rid = r.json()["id"]
                end = time.monotonic() + 30
                while time.monotonic() < end and not c.get("/joints/j3").json()["drive"]["open"]:
                    time.sleep(0.05)
                time.sleep(0.5)
                t0 = time.perf_counter()
                body = c.post("/estop").json()
                rtt.append(time.perf_counter() - t0)
                server.append(body["stop_latency_ms"] / 1e3)
                assert all(d["torque_off"] for d in body["drives"]), body
                wait_state(c, rid, ("failed", "cancelled", "succeeded"), 60)
                while c.post("/estop/reset").status_code == 409:
                    time.sleep(0.1)
        finally:
            proc.terminate()
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()
            if pool is not None:
                pool.terminate()
    lat = [x * 1e3 for x in res["latencies"]]
    ms = lambda x: f"{x * 1e3:.1f}"  # noqa: E731
    print(f"## REST service under load (macro4, realtime 1 ms clock, calibration {still} during the load)\n")
    print(f"machine load average (1 min) at start / end: {load0:.1f} / {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    print(f"uptime at start: {uptime0}\nuptime at end:   {uptime()}")
    where = ("not pinned" if placement is None else
             f"server on CPU {sorted(placement[0])}, run processes on {sorted(placement[1])}")
    sched = f"SCHED_FIFO {args.rt_priority}" if args.rt_priority else "normal scheduling"
    clients = (f"{procs} client processes (light HTTP/1.1)" if args.pattern == "page" else "clients in one process (httpx)")
    print(f"run processes: {sched}; CPUs: {where}; {clients} on {'the server CPU' if client_cpus else 'any CPU'}"
          f"{f', nice {args.client_nice}' if args.client_nice else ''}\n")
    measured = len(pairs)
    if measured < args.rounds:
        print(f"**the calibration ended ({still}) in round {measured + 1} of {args.rounds}: only {measured} "
              f"round(s) counted**\n")
    print("| metric | value | target |")
    print("|---|---|---|")
    total = measured * args.seconds
    periods = int(total / 0.001)
    if args.pattern == "page":
        p = page_pattern()
        print(f"| requests of {args.pages} open pages ({total:g} s): /health every {p['health_ms']} ms; "
              f"{(args.pages + 1) // 2} on the live view: GET /runs/{{id}} every {p['run_ms']} ms + event stream at "
              f"{p['sample_hz']} Hz; {args.pages // 2} on the bench view: GET /joints/{{id}} x{len(joints)} every "
              f"{p['joints_ms']} ms | {len(lat)} ({res['errors']} errors) | |")
    else:
        print(f"| GET /runs/{{id}} requests ({args.clients} clients, every {args.poll:g} s, {total:g} s) "
              f"| {len(lat)} ({res['errors']} errors) | |")
    print(f"| latency p50 / p90 / p99 / max [ms] | {pct(lat, 50):.1f} / {pct(lat, 90):.1f} / {pct(lat, 99):.1f} / "
          f"{max(lat):.1f} | p99 <= 50 |")
    for kind, xs in sorted(by_kind.items()):
        xs = [x * 1e3 for x in xs]
        print(f"| latency of /{kind}... p50 / p99 / max [ms], n={len(xs)} | {pct(xs, 50):.1f} / {pct(xs, 99):.1f} / "
              f"{max(xs):.1f} | |")
    print(f"| SSE events received during load | {res['sse_events']} | |")
    # CPU time, unlike latency, hardly depends on what else the machine runs (the control loops
    # run in their own processes: the server's own CPU time is its requests' and the relay's)
    n = max(1, len(lat))
    print(f"| server CPU per request beyond its quiet rate (SSE included) [ms] | {1e3 * cpu['server'] / n:.2f} | |")
    print(f"| clients' CPU per request (SSE included) [ms] | {1e3 * cpu['clients'] / n:.2f} | |")
    print(f"| host overruns, quiet phases ({total:g} s, {periods} periods) | {sum(p[0] for p in pairs)} | |")
    print(f"| host overruns, loaded phases ({total:g} s, {periods} periods) | {sum(p[1] for p in pairs)} | "
          f"no more than quiet |")
    print(f"| host overruns per round, quiet / loaded | {', '.join(f'{q} / {l}' for q, l in pairs)} | |")
    print(f"| loaded / quiet overruns over the rounds | {overrun_comparison(pairs)} | the interval reaches 1 or below |")
    print(f"| overruns in the calibration run record (whole run) | {run_overruns} | |")
    print(f"| e-stop round trip (client) median / max [ms], n={len(rtt)} | {ms(statistics.median(rtt))} / "
          f"{ms(max(rtt))} | <= 50 |")
    print(f"| e-stop latch -> every run process answered (server) median / max [ms] | {ms(statistics.median(server))} / "
          f"{ms(max(server))} | <= 50 |")


if __name__ == "__main__":
    main()
