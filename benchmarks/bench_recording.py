"""Speed of the record generator (virtual_drives.recording), printed as a markdown table.

    python benchmarks/bench_recording.py

Wall time to make one record (best of 3, after a warm-up call that compiles the kernels),
and simulated seconds per wall second: PD tracking steps the physics one control period at
a time (the controller closes the loop on the quantised encoder), the open-loop
excitations simulate the whole command in one call.
"""
from __future__ import annotations

import os
import time

from virtual_drives.conditions import make_record
from virtual_drives.presets import PRESETS
from virtual_drives.recording import Logger, Recording

CASES = [
    ("PD closed-loop tracking, j1, 60 s at 1 kHz", "j1", "PD closed-loop tracking", 60.0, {}),
    ("two-tone torque, j1, 60 s at 1 kHz", "j1", "two-tone torque", 60.0, {}),
    ("coloured process noise, linear, 60 s at 1 kHz", "linear", "coloured process noise", 60.0, {}),
    ("robot joint log (PD, friction column, logger), j1, 60 s", "j1", "robot joint log", 60.0, {}),
    ("10-minute log at 500 Hz with jitter (sine, logger step 2 ms), j1", "j1",
     Recording(logger=Logger(step=0.002)), 600.0, {}),
]


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| record | samples | wall [s] | simulated s / wall s |")
    print("|---|---|---|---|")
    for label, joint, cond, duration, kw in CASES:
        spec = PRESETS[joint]
        make_record(spec, cond, seed=1, duration=2.0, **kw)          # compile
        best = float("inf")
        for seed in (1, 2, 3):
            t0 = time.perf_counter()
            rec, _ = make_record(spec, cond, seed=seed, duration=duration, **kw)
            best = min(best, time.perf_counter() - t0)
        print(f"| {label} | {len(rec.t)} | {best:.3f} | {duration / best:,.0f}x |", flush=True)


if __name__ == "__main__":
    main()
