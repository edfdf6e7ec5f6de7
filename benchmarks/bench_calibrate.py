"""Benchmark: calibrate macro4 in lock-step (search -> identify -> validate on all four joints).

Not a timed test: prints a markdown table (wall time per joint, simulated seconds, trials,
parameter errors against the preset truth, tracking improvement).  Target: < 60 s wall on 2 cores.

    python benchmarks/bench_calibrate.py [--seed 31] [--bench macro4]
"""
from __future__ import annotations

import argparse
import tempfile
import time

from bench.store import Store
from procedures.calibration import CalibrationSettings, calibrate, start_calibration
from procedures.config import load_bench
from virtual_drives.presets import PRESETS


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", default="macro4")
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--plots", action="store_true")
    args = ap.parse_args()
    cfg = load_bench(args.bench)
    stamps: dict[str, list[float]] = {}

    def on_event(doc):
        d = doc["data"]
        if doc["name"] == "stage" and d.get("status") == "running" and d.get("stage") == "search":
            stamps.setdefault(d["joint"], [time.perf_counter()])
        elif doc["name"] == "stage" and d.get("stage") == "validate" and d.get("status") != "running":
            stamps[d["joint"]].append(time.perf_counter())

    with tempfile.TemporaryDirectory() as tmp:
        store = Store(tmp)
        t0 = time.perf_counter()
        run_id = start_calibration(store, args.bench, None, args.seed)
        report = calibrate(store, run_id, on_event=on_event, settings=CalibrationSettings(plots=args.plots))
        wall = time.perf_counter() - t0
    print(f"## calibrate {args.bench} (lock-step, seed {args.seed})\n")
    print("| joint | status | wall s | trials | A | f Hz | max param error | sigma1 err | tracking RMS off/on |")
    print("|---|---|---|---|---|---|---|---|---|")
    for jid, j in report["joints"].items():
        s = j["stages"]
        srch, ident, val = (s[k].get("result") or {} for k in ("search", "identify", "validate"))
        tr = PRESETS[cfg.joint(jid)["preset"]].friction
        errs = {k: abs(v - getattr(tr, k)) / getattr(tr, k) for k, v in (ident.get("parameters") or {}).items()}
        worst = max((k for k in errs if k != "sigma1"), key=errs.get, default=None)
        ts = stamps.get(jid, [0, 0])
        print(f"| {jid} | {j['status']} | {ts[-1] - ts[0]:.1f} | {srch.get('trials', '-')} | "
              f"{srch.get('amplitude', float('nan')):.4g} | {srch.get('frequency', float('nan')):.3g} | "
              + (f"{worst} {errs[worst]:.2%}" if worst else "-") + " | "
              + (f"{errs['sigma1']:.1%}" if "sigma1" in errs else "-") + " | "
              + (f"x{val['improvement']:.0f}" if "improvement" in val else "-") + " |")
    print(f"\n**total wall time: {wall:.1f} s** (target < 60 s)")


if __name__ == "__main__":
    main()
