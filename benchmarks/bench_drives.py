"""Drive transport benchmark (a script, not a test): prints markdown tables.

    python benchmarks/bench_drives.py [--seconds 3] [--quick]

Real time, 1 kHz: 1, 2 and 4 joints over CANopen (CiA 402, one SYNC per round) and over ptys
(ODrive ASCII, one pipelined exchange per joint per round).  Emulators either share this
process with the host ("in-process": python-can ``virtual`` bus, pty responders on threads,
one GIL for host and drives) or run in a child process as real drives would ("child
process": a socketcand server on 127.0.0.1, ptys).  A round is one ``cycle`` per joint.
"period" is the gap between consecutive period starts, i.e. SYNC to SYNC over CANopen (the
instant every drive samples and applies its torque) and command to command over serial;
"latency" runs from a period's start to the round's last sample.  "delivered" = rounds
completed / periods the wall clock allowed; every boundary the host missed is counted in
"host overruns" (the pacer skips it, never bursts) and every period a drive had to catch up
in "drive overruns".  CPU is this process's CPU time over wall time, in % of one core.
Lock-step: 4 joints over CANopen (virtual bus), simulated seconds per wall second, at
several control periods, and the host + emulator CPU per round.  A round moves 13 CAN frames
(4 RPDOs, SYNC, 8 TPDOs) through python-can and python-canopen twice (host and drive side).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from drivers.pacing import Pacer
from drivers.registry import open_drive
from virtual_drives.launch import VirtualBench

PRESETS = ["rotary", "linear", "j1", "j3"]       # no gravity: open-loop torque stays safe


def joints(n: int, transport: str) -> list[dict]:
    return [{"id": f"q{i}", "preset": PRESETS[i], "transport": transport,
             "reply_timeout": 0.5} for i in range(n)]


def torque(j: dict, t: float) -> float:
    return 0.3 * j["torque_limit"] * 0.05 * np.sin(2 * np.pi * 2.0 * t)


def realtime_run(n: int, transport: str, seconds: float, dt: float = 1e-3,
                 process: str = "inproc") -> dict:
    with VirtualBench(joints(n, transport), clock="realtime", control_period=dt,
                      process=process) as vb:
        drives = [open_drive(j) for j in vb.joints]
        try:
            for d in drives:
                d.enable()
            pacer = Pacer.shared("realtime", dt)
            ends, fresh, last_t = [], 0, [None] * n
            for _ in range(50):                  # settle: first rounds open the grid
                for d in drives:
                    d.cycle(0.0)
            overruns0 = pacer.overruns
            pacer.record = ticks = []
            cpu0, t0 = time.process_time(), time.perf_counter()
            while (now := time.perf_counter()) - t0 < seconds:
                for i, (d, j) in enumerate(zip(drives, vb.joints)):
                    s = d.cycle(torque(j, now - t0))
                    fresh += last_t[i] is None or s.t > last_t[i]
                    last_t[i] = s.t
                ends.append(time.perf_counter())
            wall = time.perf_counter() - t0
            cpu = time.process_time() - cpu0
            pacer.record = None
            drive_overruns = sum(vb.drive(j["id"]).snapshot()["overruns"] for j in vb.joints)
        finally:
            for d in drives:
                d.close()
    ticks, ends = np.array(ticks[:len(ends)]), np.array(ends)
    period = np.diff(ticks) * 1e3              # SYNC-to-SYNC (CANopen), command-to-command
    latency = (ends - ticks) * 1e3             # period start to the round's last sample
    return {"rounds": len(ends), "expected": int(wall / dt),
            "delivered": len(ends) / (wall / dt), "fresh": fresh / (len(ends) * n),
            "p50": np.percentile(period, 50), "p99": np.percentile(period, 99),
            "max": period.max(), "lat50": np.percentile(latency, 50),
            "lat99": np.percentile(latency, 99), "overruns": pacer.overruns - overruns0,
            "drive_overruns": drive_overruns, "cpu": 100 * cpu / wall}


def lockstep_run(n: int, transport: str, dt: float, rounds: int) -> dict:
    with VirtualBench(joints(n, transport), clock="lockstep", control_period=dt) as vb:
        drives = [open_drive(j) for j in vb.joints]
        try:
            for d in drives:
                d.enable()
            cpu0, t0 = time.process_time(), time.perf_counter()
            for k in range(rounds):
                for d, j in zip(drives, vb.joints):
                    d.cycle(torque(j, k * dt))
            wall = time.perf_counter() - t0
            cpu = time.process_time() - cpu0
        finally:
            for d in drives:
                d.close()
    return {"rounds_per_s": rounds / wall, "speed": rounds * dt / wall,
            "cpu": 100 * cpu / wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--quick", action="store_true", help="1 s runs, fewer lock-step rounds")
    a = ap.parse_args()
    seconds = 1.0 if a.quick else a.seconds
    print("### Real time, 1 kHz control period\n")
    print("| transport | emulators | joints | rounds | delivered | fresh samples | period p50 ms | "
          "period p99 ms | max period ms | latency p50 / p99 ms | host overruns | "
          "drive overruns | CPU % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for process, where in (("inproc", "in-process"), ("subprocess", "child process")):
        for transport in ("canopen", "serial"):
            label = {"canopen": "CANopen, " + ("virtual bus" if process == "inproc"
                                               else "socketcand"),
                     "serial": "ODrive ASCII, pty"}[transport]
            for n in (1, 2, 4):
                r = realtime_run(n, transport, seconds, process=process)
                print(f"| {label} | {where} | {n} | {r['rounds']} / {r['expected']} | "
                      f"{100 * r['delivered']:.2f} % | {100 * r['fresh']:.2f} % | "
                      f"{r['p50']:.3f} | {r['p99']:.3f} | {r['max']:.2f} | "
                      f"{r['lat50']:.2f} / {r['lat99']:.2f} | {r['overruns']} | "
                      f"{r['drive_overruns']} | {r['cpu']:.0f} |", flush=True)
    print("\n### Lock-step, 4 joints over CANopen (virtual bus)\n")
    print("| control period | rounds/s | CPU per round µs | simulated s per wall s |")
    print("|---|---|---|---|")
    for dt in (0.001, 0.002, 0.005, 0.01):
        r = lockstep_run(4, "canopen", dt, 1000 if a.quick else 3000)
        print(f"| {dt * 1e3:g} ms | {r['rounds_per_s']:.0f} | "
              f"{1e6 * r['cpu'] / 100 / r['rounds_per_s']:.0f} | {r['speed']:.1f}x |", flush=True)

if __name__ == "__main__":
    main()
