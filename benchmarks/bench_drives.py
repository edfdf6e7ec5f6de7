"""Drive transport benchmark (a script, not a test): prints markdown tables.

    python benchmarks/bench_drives.py [--seconds 3] [--quick] [--only TEXT] [--rt-priority 40]

Real time, 1 kHz: 1, 2 and 4 joints over CANopen (CiA 402, one SYNC per round) and over ptys
(ODrive ASCII, one pipelined exchange per joint per round), in three placements, side by side:

* "in-process": the emulators share this process with the host (python-can ``virtual`` bus,
  pty responders on threads, one GIL for host and drives), normal scheduling;
* "child": the emulators run in a child process as real drives would (a socketcand server on
  127.0.0.1, ptys), pinned to their own CPU and the host to the others, normal scheduling;
* "child, FIFO": the same with every thread of both processes at SCHED_FIFO ``--rt-priority``
  (``drivers.realtime``; rows are skipped with a note where that is not permitted).

"machine floor" rows run the host's pacer alone on the host's CPUs, with no drives: the
stalls the machine itself imposes (on a virtual machine, the hypervisor's) bound what any
row can reach.

A round is one ``cycle`` per joint.  "period" is the gap between consecutive period starts,
i.e. SYNC to SYNC over CANopen (the instant every drive samples and applies its torque) and
command to command over serial; "latency" runs from a period's start to the round's last
sample.  "delivered" = rounds completed / periods the wall clock allowed; every boundary the
host missed is counted in "host overruns" (the pacer skips it, never bursts) and every
period a drive had to catch up in "drive overruns".  CPU is this process's CPU time over
wall time, in % of one core.

Lock-step: 4 joints over CANopen (virtual bus), simulated seconds per wall second, at several
control periods, with the process free to use every CPU and pinned to one.  A round moves 13
CAN frames (4 RPDOs, SYNC, 8 TPDOs) through python-can and python-canopen twice (host and
drive side); every frame wakes another thread of the same process, and a GIL hand-off between
threads on two cores costs about three times one on the same core.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from drivers import realtime
from drivers.pacing import Pacer
from drivers.registry import open_drive
from virtual_drives.launch import VirtualBench

PRESETS = ["rotary", "linear", "j1", "j3"]       # no gravity: open-loop torque stays safe


def joints(n: int, transport: str) -> list[dict]:
    return [{"id": f"q{i}", "preset": PRESETS[i], "transport": transport,
             "reply_timeout": 0.5} for i in range(n)]


def torque(j: dict, t: float) -> float:
    return 0.3 * j["torque_limit"] * 0.05 * np.sin(2 * np.pi * 2.0 * t)


class NotPermitted(Exception):
    pass


def _cpus() -> list[int]:
    """The CPUs this process may use, in order (empty where affinity is not supported)."""
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []


def realtime_run(n: int, transport: str, seconds: float, dt: float = 1e-3,
                 process: str = "inproc", priority: int = 0) -> dict:
    cpus = _cpus()
    with VirtualBench(joints(n, transport), clock="realtime", control_period=dt,
                      process=process) as vb:
        if process == "subprocess" and len(cpus) >= 2:
            # the drives are other hardware: give the emulator process its own CPU
            realtime.pin({cpus[-1]}, vb._child.pid)
            realtime.pin(set(cpus[:-1]))
        if priority:
            why_not = (realtime.set_priority(priority, vb._child.pid)
                       or realtime.set_priority(priority))
            if why_not:
                realtime.set_priority(0, vb._child.pid)
                raise NotPermitted(why_not)
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
            realtime.set_priority(0)
            if cpus:
                realtime.pin(set(cpus))
    ticks, ends = np.array(ticks[:len(ends)]), np.array(ends)
    period = np.diff(ticks) * 1e3              # SYNC-to-SYNC (CANopen), command-to-command
    latency = (ends - ticks) * 1e3             # period start to the round's last sample
    return {"rounds": len(ends), "expected": int(wall / dt),
            "delivered": len(ends) / (wall / dt), "fresh": fresh / (len(ends) * n),
            "p50": np.percentile(period, 50), "p99": np.percentile(period, 99),
            "max": period.max(), "lat50": np.percentile(latency, 50),
            "lat99": np.percentile(latency, 99), "overruns": pacer.overruns - overruns0,
            "drive_overruns": drive_overruns, "cpu": 100 * cpu / wall}


def floor_run(seconds: float, priority: int, dt: float = 1e-3) -> dict:
    """The machine's own floor: the host pacer alone on the host's CPUs, no drives."""
    cpus = _cpus()
    if len(cpus) >= 2:
        realtime.pin(set(cpus[:-1]))
    why_not = realtime.set_priority(priority) if priority else None
    try:
        if why_not:
            raise NotPermitted(why_not)
        pacer, tick = Pacer(True, dt), 0
        for _ in range(50):
            tick = pacer.next_tick(tick)
        pacer.record, overruns0 = [], pacer.overruns
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            tick = pacer.next_tick(tick)
        wall = time.perf_counter() - t0
    finally:
        realtime.set_priority(0)
        if cpus:
            realtime.pin(set(cpus))
    period = np.diff(pacer.record) * 1e3
    return {"rounds": len(pacer.record), "expected": int(wall / dt),
            "delivered": len(pacer.record) / (wall / dt), "p50": np.percentile(period, 50),
            "p99": np.percentile(period, 99), "max": period.max(),
            "overruns": pacer.overruns - overruns0}


def lockstep_run(n: int, transport: str, dt: float, rounds: int, one_cpu: bool = False) -> dict:
    cpus = _cpus()
    if one_cpu and cpus:
        realtime.pin({cpus[0]})        # before the bus threads start: they inherit it
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
            if cpus:
                realtime.pin(set(cpus))
    return {"rounds_per_s": rounds / wall, "speed": rounds * dt / wall,
            "cpu": 100 * cpu / wall}


PLACEMENTS = (("inproc", 0, "in-process"), ("subprocess", 0, "child"),
              ("subprocess", 1, "child, FIFO"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--quick", action="store_true", help="1 s runs, fewer lock-step rounds")
    ap.add_argument("--only", default="", help="run only the rows whose label contains this "
                    "(e.g. 'pty', 'child', 'FIFO', 'lock-step')")
    ap.add_argument("--rt-priority", type=int, default=40,
                    help="SCHED_FIFO priority of the 'child, FIFO' rows (default 40)")
    a = ap.parse_args()
    seconds = 1.0 if a.quick else a.seconds
    print("### Real time, 1 kHz control period\n")
    print("| transport | emulators, scheduling | joints | rounds | delivered | fresh samples | "
          "period p50 ms | period p99 ms | max period ms | latency p50 / p99 ms | "
          "host overruns | drive overruns | CPU % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for fifo in (0, 1):                  # what the machine itself allows, for comparison
        where = "machine floor" + (", FIFO" if fifo else "")
        if a.only not in f"no drives {where} real time":
            continue
        try:
            r = floor_run(seconds, a.rt_priority if fifo else 0)
        except NotPermitted as e:
            print(f"| no drives (pacer alone) | {where} | 0 | skipped: {e} |", flush=True)
            continue
        print(f"| no drives (pacer alone) | {where} | 0 | {r['rounds']} / {r['expected']} | "
              f"{100 * r['delivered']:.2f} % | | {r['p50']:.3f} | {r['p99']:.3f} | "
              f"{r['max']:.2f} | | {r['overruns']} | | |", flush=True)
    for process, fifo, where in PLACEMENTS:
        for transport in ("canopen", "serial"):
            label = {"canopen": "CANopen, " + ("virtual bus" if process == "inproc"
                                               else "socketcand"),
                     "serial": "ODrive ASCII, pty"}[transport]
            for n in (1, 2, 4):
                if a.only not in f"{label} {where} real time":
                    continue
                try:
                    r = realtime_run(n, transport, seconds, process=process,
                                     priority=a.rt_priority if fifo else 0)
                except NotPermitted as e:
                    print(f"| {label} | {where} | {n} | skipped: {e} |", flush=True)
                    continue
                print(f"| {label} | {where} | {n} | {r['rounds']} / {r['expected']} | "
                      f"{100 * r['delivered']:.2f} % | {100 * r['fresh']:.2f} % | "
                      f"{r['p50']:.3f} | {r['p99']:.3f} | {r['max']:.2f} | "
                      f"{r['lat50']:.2f} / {r['lat99']:.2f} | {r['overruns']} | "
                      f"{r['drive_overruns']} | {r['cpu']:.0f} |", flush=True)
    if a.only not in "lock-step CANopen":
        return
    print("\n### Lock-step, 4 joints over CANopen (virtual bus)\n")
    print("| control period | CPUs | rounds/s | CPU per round µs | simulated s per wall s | "
          "one CPU / any |")
    print("|---|---|---|---|---|---|")
    for dt in (0.001, 0.002, 0.005, 0.01):
        rounds = 1000 if a.quick else 3000
        pair = [lockstep_run(4, "canopen", dt, rounds, one_cpu=one) for one in (False, True)]
        for one, r in zip((False, True), pair):
            ratio = f"{pair[1]['speed'] / pair[0]['speed']:.2f}x" if one else ""
            print(f"| {dt * 1e3:g} ms | {'one' if one else 'any'} | {r['rounds_per_s']:.0f} | "
                  f"{1e6 * r['cpu'] / 100 / r['rounds_per_s']:.0f} | {r['speed']:.1f}x | "
                  f"{ratio} |", flush=True)


if __name__ == "__main__":
    main()
