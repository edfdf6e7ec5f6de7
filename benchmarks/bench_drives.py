"""Drive transport benchmark (a script, not a test): prints a markdown table.

    python benchmarks/bench_drives.py [--seconds 3] [--quick]

Real time, 1 kHz: 1, 2 and 4 joints over the virtual CAN bus (CiA 402, one SYNC per round)
and over ptys (ODrive ASCII, one pipelined exchange per joint per round), emulators in this
process.  A round is one ``cycle`` per joint; its period is the gap between the ends of
consecutive rounds.  "delivered" = rounds completed / rounds the wall clock allowed
(duration / period); every boundary the host missed is counted in "overruns" (host pacer)
and every period a drive had to catch up in "drive overruns".  CPU is this process's CPU
time (host and emulators) over wall time, in % of one core.
Lock-step: 4 joints over CANopen, simulated seconds per wall second, at several control
periods (the physics sub-steps inside a period, so a coarser period stays accurate for
open-loop excitation; it only holds the torque longer).
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


def realtime_run(n: int, transport: str, seconds: float, dt: float = 1e-3) -> dict:
    with VirtualBench(joints(n, transport), clock="realtime", control_period=dt) as vb:
        drives = [open_drive(j) for j in vb.joints]
        try:
            for d in drives:
                d.enable()
            pacer = Pacer.shared("realtime", dt)
            ends, fresh, last_t = [], 0, [None] * n
            overruns0 = pacer.overruns
            for _ in range(50):                  # settle: first rounds open the grid
                for d in drives:
                    d.cycle(0.0)
            overruns0 = pacer.overruns
            cpu0, t0 = time.process_time(), time.perf_counter()
            while (now := time.perf_counter()) - t0 < seconds:
                for i, (d, j) in enumerate(zip(drives, vb.joints)):
                    s = d.cycle(torque(j, now - t0))
                    fresh += last_t[i] is None or s.t > last_t[i]
                    last_t[i] = s.t
                ends.append(time.perf_counter())
            wall = time.perf_counter() - t0
            cpu = time.process_time() - cpu0
            drive_overruns = sum(vb.drive(j["id"]).snapshot()["overruns"] for j in vb.joints)
        finally:
            for d in drives:
                d.close()
    gaps = np.diff(ends) * 1e3
    return {"rounds": len(ends), "expected": int(wall / dt),
            "delivered": len(ends) / (wall / dt), "fresh": fresh / (len(ends) * n),
            "p50": np.percentile(gaps, 50), "p99": np.percentile(gaps, 99),
            "max": gaps.max(), "overruns": pacer.overruns - overruns0,
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
    print("| transport | joints | rounds | delivered | fresh samples | p50 ms | p99 ms | "
          "max gap ms | host overruns | drive overruns | CPU % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for transport, label in (("canopen", "CANopen, virtual bus"), ("serial", "ODrive ASCII, pty")):
        for n in (1, 2, 4):
            r = realtime_run(n, transport, seconds)
            print(f"| {label} | {n} | {r['rounds']} / {r['expected']} | "
                  f"{100 * r['delivered']:.2f} % | {100 * r['fresh']:.2f} % | {r['p50']:.3f} | "
                  f"{r['p99']:.3f} | {r['max']:.2f} | {r['overruns']} | {r['drive_overruns']} | "
                  f"{r['cpu']:.0f} |", flush=True)
    print("\n### Lock-step, 4 joints over CANopen (virtual bus)\n")
    print("| control period | rounds/s | simulated s per wall s | CPU % |")
    print("|---|---|---|---|")
    for dt in (0.001, 0.005, 0.01, 0.02):
        r = lockstep_run(4, "canopen", dt, 1000 if a.quick else 3000)
        print(f"| {dt * 1e3:g} ms | {r['rounds_per_s']:.0f} | {r['speed']:.1f}x | "
              f"{r['cpu']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
