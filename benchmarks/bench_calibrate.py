"""Benchmark: `bench calibrate --bench macro4` (search -> identify -> validate on all joints),
with the default transport (the preset's emulated CANopen / serial drives in lock-step,
reached through the real python-canopen and ODrive-ASCII stacks) and with
``--transport simulated`` (in-process plugs), side by side in one run.

Each calibration is the command line itself, timed from outside (a child process: imports,
plots, report included).  Then, outside the timed part, each joint's identified model is
run on the tracking test against the model that knows the truth, on the same transport.
Prints markdown: wall / CPU time per transport, per-joint parameter errors against the
preset's truth, tracking RMS ratios.  Target: default transport < 60 s wall on 2 cores.

    python benchmarks/bench_calibrate.py [--bench macro4] [--seed 31] [--no-plots]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.lugre import LuGreParams
from procedures.calibration import CalibrationSettings, _close, _open_rig
from procedures.config import load_bench
from procedures.events import Cancel
from procedures.tracking import tracking_test
from virtual_drives.presets import PRESETS

TOL = {"Fc": 0.03, "Fs": 0.03, "sigma2": 0.03, "alpha": 0.15, "sigma0": 0.20, "sigma1": 0.30}
TRANSPORTS = ("virtual", "simulated")


def command() -> list[str]:
    exe = shutil.which("bench")
    return [exe] if exe else [sys.executable, "-m", "procedures.cli"]


def run_calibrate(bench: str, transport: str, seed: int, plots: bool, data: Path) -> dict:
    out = data / "report.json"
    cmd = command() + ["calibrate", "--bench", bench, "--data", str(data), "--seed", str(seed),
                       "--json", str(out), "--transport", transport, "--plots" if plots else "--no-plots"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode not in (0, 1) or not out.exists():
        raise SystemExit(f"calibrate ({transport}) exited {proc.returncode}: {proc.stderr[-2000:]}")
    return {"wall": wall, "cpu": cpu, "code": proc.returncode, "report": json.loads(out.read_text())}


def tracking_vs_truth(bench: str, transport: str, report: dict, seed: int) -> dict:
    cfg = load_bench(bench)
    rig = _open_rig(cfg, seed, Cancel(), CalibrationSettings(force_simulated=transport == "simulated"))
    out = {}
    try:
        for jid, j in report["joints"].items():
            ident = (j["stages"].get("identify") or {}).get("result")
            if not ident:
                continue
            params = LuGreParams.from_dict(ident["parameters"])
            true = PRESETS[cfg.joint(jid)["preset"]].friction
            out[jid] = tracking_test(rig, jid, {"none": None, "identified": params, "true": true})
    finally:
        _close(rig)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", default="macro4")
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--plots", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--no-tracking", action="store_true", help="skip the tracking-vs-truth check")
    args = ap.parse_args()
    cfg = load_bench(args.bench)
    load0 = os.getloadavg()[0]
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for tr in TRANSPORTS:
            res[tr] = run_calibrate(args.bench, tr, args.seed, args.plots, Path(tmp) / tr)
        load1 = os.getloadavg()[0]
        track = {tr: ({} if args.no_tracking else tracking_vs_truth(args.bench, tr, res[tr]["report"], args.seed + 1))
                 for tr in TRANSPORTS}

    print(f"## `bench calibrate --bench {args.bench}` (lock-step, control period "
          f"{cfg.control_period * 1e3:g} ms, seed {args.seed}, plots {'on' if args.plots else 'off'})\n")
    print(f"{os.cpu_count()} CPUs; load average (1 min) {load0:.2f} before, {load1:.2f} after the "
          f"calibrations.\n")
    print("| transport | drivers | wall s | CPU s | exit | joints succeeded |")
    print("|---|---|---|---|---|---|")
    for tr in TRANSPORTS:
        r = res[tr]
        rep = r["report"]
        drivers = ", ".join(f"{j}: {d}" for j, d in sorted(rep.get("drivers", {}).items()))
        ok = sum(j["status"] == "succeeded" for j in rep["joints"].values())
        label = "default (emulated drives, real stacks)" if tr == "virtual" else "`--transport simulated`"
        print(f"| {label} | {drivers} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['code']} | "
              f"{ok} / {len(rep['joints'])} |")
    print("\nParameter errors against the preset's truth (tolerance: Fc, Fs, sigma2 3 %; alpha 15 %; "
          "sigma0 20 %; sigma1 30 % or not identifiable), tracking RMS error: calibrate's own "
          "validation (off / on) and, on a second seed, identified vs. the true model.\n")
    keys = list(TOL)
    print("| joint | transport | " + " | ".join(keys) + " | worst / tol | RMS off / on | on / true |")
    print("|---|---|" + "---|" * len(keys) + "---|---|---|")
    for jid in cfg.ids:
        for tr in TRANSPORTS:
            j = res[tr]["report"]["joints"].get(jid)
            if j is None:
                continue
            ident = (j["stages"].get("identify") or {}).get("result") or {}
            val = (j["stages"].get("validate") or {}).get("result") or {}
            truth = PRESETS[cfg.joint(jid)["preset"]].friction
            if not ident:
                print(f"| {jid} | {tr} | " + " | ".join("-" for _ in keys) + f" | {j['status']} | - | - |")
                continue
            errs = {k: (ident["parameters"][k] - getattr(truth, k)) / getattr(truth, k) for k in keys}
            free = {k: abs(e) / TOL[k] for k, e in errs.items()
                    if not (k == "sigma1" and not ident["identifiable"].get("sigma1", True))}
            worst = max(free, key=free.get)
            cells = [f"{errs[k]:+.2%}" + ("" if k in free else " (n.i.)") for k in keys]
            t = track[tr].get(jid)
            vs_true = f"{t['vs_true']:.2f}" if t else "-"
            off_on = f"{val['none']['rms_error'] / val['identified']['rms_error']:.0f}x" if "none" in val else "-"
            print(f"| {jid} | {tr} | " + " | ".join(cells) + f" | {free[worst]:.2f} ({worst}) | {off_on} | {vs_true} |")
    v = res["virtual"]["wall"]
    print(f"\n**default transport: {v:.1f} s wall** (target < 60 s); simulated: "
          f"{res['simulated']['wall']:.1f} s; ratio {v / res['simulated']['wall']:.1f}x")


if __name__ == "__main__":
    main()
