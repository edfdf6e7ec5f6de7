"""Diagnosis accuracy with a single sine vs the two-level excitation (tuning seeds 1000-1999
only; tests use 5000+).

    python tools/excitation_table.py [--seeds 3] [--joints linear,j1] [--kinds cogging,...,none,saturation]
        [--ratio 0.6] [--out table.jsonl]      (--summary table.jsonl: the table of a run)

For every preset x hidden effect (``virtual_drives.scenarios``, drawn from the same seed for
both excitations), plus ``none`` and an out-of-library physics (``saturation``: a torque
constant that falls at high current, tau_felt = tau (1 - drop (tau/tau_peak)^2), which a sine
makes look like cogging), one record per excitation: the preset's own (amplitude, frequency),
as a sine and as ``procedures.waveforms`` two_level with the same peak.  A record is *right*
when the diagnosis adds exactly the hidden effect (``none`` and ``saturation``: adds nothing).
Prints one line per record and the summary table (markdown) at the end.
"""
from __future__ import annotations

import argparse
import json
import time
import zlib
from collections import defaultdict

import numpy as np

from bench.analysis import analyze_record
from bench.effects import EFFECTS
from bench.effects.inject import parse_injections
from bench.records import Record
from procedures.waveforms import torque
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects
from virtual_drives.joint import simulate_record

OUT_OF_LIBRARY = ("saturation",)


def record(spec, kind: str, seed: int, waveform: str, ratio: float, duration: float) -> tuple[Record, str]:
    amp, freq = spec.excitation
    t = np.arange(int(round(duration / 1e-3))) * 1e-3
    cmd = torque(amp, freq, t, waveform, ratio)
    if kind == "saturation":
        drop = float(np.random.default_rng(seed).uniform(0.05, 0.15))
        felt = cmd * (1.0 - drop * (cmd / amp) ** 2)
        rec = simulate_record(spec, amp, freq, duration, seed=seed, tau=felt).record
        return Record(t=rec.t, tau=cmd + (rec.tau - felt), q=rec.q, meta=rec.meta), f"saturation drop={drop:.3f}"
    effects = [] if kind == "none" else [kind]
    texts = random_effects(spec, effects, seed, duration)
    ev, factor, delta, lag = parse_injections(texts, spec)
    if delta is not None:
        spec = spec.with_(friction=spec.friction.with_(delta=delta))
    sim = simulate_record(spec, amp, freq, duration, seed=seed, extra=ev, tau=cmd,
                          declared_inertia=spec.inertia * factor, torque_lag=lag)
    return sim.record, "; ".join(texts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed-offset", type=int, default=0, help="skip the first N seeds of each kind")
    ap.add_argument("--joints", default=",".join(PRESETS))
    ap.add_argument("--kinds", default=",".join([*EFFECTS, "none", *OUT_OF_LIBRARY]))
    ap.add_argument("--ratio", type=float, default=0.6)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--out", default=None, help="also append one JSON line per record here")
    ap.add_argument("--summary", default=None, help="only print the table of an --out file")
    a = ap.parse_args()
    right = defaultdict(lambda: [0, 0, 0])       # (kind, waveform) -> [right, total, wrongly credited]
    if a.summary:
        for line in open(a.summary):
            d = json.loads(line)
            want = [] if d["kind"] in ("none", *OUT_OF_LIBRARY) else [d["kind"]]
            _count(right[d["kind"], d["waveform"]], d["ok"], d["added"], want)
        print(table(right))
        return
    out = open(a.out, "a") if a.out else None
    for joint in a.joints.split(","):
        spec = PRESETS[joint]
        for kind in a.kinds.split(","):
            if kind == "gravity" and spec.joint_type != "revolute":
                continue
            for s in range(a.seed_offset, a.seed_offset + a.seeds):
                seed = 1000 + 17 * s + zlib.crc32(kind.encode()) % 97
                for waveform in ("sine", "two_level"):
                    rec, hidden = record(spec, kind, seed, waveform, a.ratio, a.duration)
                    t0 = time.time()
                    doc = analyze_record(rec).report()
                    added = doc["final"]["effects"]
                    want = [] if kind in ("none", *OUT_OF_LIBRARY) else [kind]
                    ok = added == want
                    _count(right[kind, waveform], ok, added, want)
                    line = {"joint": joint, "kind": kind, "seed": seed, "waveform": waveform, "ok": ok,
                            "added": added, "structured": doc["unexplained"]["structured"],
                            "hidden": hidden, "seconds": round(time.time() - t0, 1)}
                    print(json.dumps(line), flush=True)
                    if out:
                        out.write(json.dumps(line) + "\n")
                        out.flush()
    print(table(right))


def _count(cell: list, ok: bool, added: list, want: list) -> None:
    cell[0] += ok
    cell[1] += 1
    cell[2] += len(set(added) - set(want))


def table(right) -> str:
    """Markdown: right / records, and (in brackets) the library effects credited that were
    not hidden, per hidden kind and excitation."""
    kinds = sorted({k for k, _ in right}, key=lambda k: (k in ("none", *OUT_OF_LIBRARY), k))
    rows = ["| hidden | sine: right (wrong effects credited) | two-level: right (wrong effects credited) |",
            "|---|---|---|"]
    tot = {"sine": [0, 0, 0], "two_level": [0, 0, 0]}
    for k in kinds:
        cells = []
        for w in ("sine", "two_level"):
            r, n, bad = right.get((k, w), (0, 0, 0))
            tot[w] = [tot[w][0] + r, tot[w][1] + n, tot[w][2] + bad]
            cells.append(f"{r}/{n} ({bad})")
        rows.append(f"| {k} | {cells[0]} | {cells[1]} |")
    rows.append("| **all** | " + " | ".join(f"**{t[0]}/{t[1]}** ({t[2]})" for t in tot.values()) + " |")
    return "\n".join(rows)


if __name__ == "__main__":
    main()
