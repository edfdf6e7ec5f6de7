"""Tuning sweep for the diagnosis (seeds 1000-1999 only; tests use 5000+).

    python tools/tune_diagnosis.py [--seeds 3] [--joints linear,j1] [--effects cogging,...]
Prints, per joint and effect, whether the hidden effect was ranked first and significant,
the held-out error reduction, false positives on no-effect records and, for the gear
effects, the found backlash width / resonance frequency over the injected one."""
from __future__ import annotations

import argparse
import zlib
import time

from bench.analysis import analyze_record
from bench.effects import EFFECTS
from bench.effects.inject import parse_injection
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import simulate_scenario

# hyper-parameter read back: effect -> (fitted name, injected key)
MEASURED = {"backlash": ("bl_width", "width"), "joint_flexibility": ("flex_frequency", "frequency")}


def measured(eff: str, texts: list[str], values: dict) -> str:
    if eff not in MEASURED or MEASURED[eff][0] not in values:
        return ""
    name, key = MEASURED[eff]
    true = float(parse_injection(texts[0])[1][key])
    return f" {key} found/true={values[name] / true:.3f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--joints", default=",".join(PRESETS))
    ap.add_argument("--effects", default=",".join(EFFECTS) + ",none")
    ap.add_argument("--duration", type=float, default=20.0)
    a = ap.parse_args()
    fails = 0
    for joint in a.joints.split(","):
        spec = PRESETS[joint]
        for eff in a.effects.split(","):
            if eff == "gravity" and spec.joint_type != "revolute":
                continue
            for s in range(a.seeds):
                seed = 1000 + 17 * s + zlib.crc32(eff.encode()) % 97
                effects = [] if eff == "none" else eff.split("+")
                sim, texts = simulate_scenario(spec, effects, seed, a.duration)
                t = time.time()
                an = analyze_record(sim.record)
                dt = time.time() - t
                doc = an.report()
                added = doc["final"]["effects"]
                red = 1 - doc["final"]["rms_error"] / doc["baseline"]["rms_error"]
                ok = (added == effects) if eff != "none" else not added
                first = doc["diagnosis"][0]
                fails += not ok
                print(f"{'ok  ' if ok else 'FAIL'} {joint:6s} {eff:28s} seed {seed} {dt:5.1f}s added={added} "
                      f"reduction={red:.0%} top={first['effect']}({'sig' if first['significant'] else 'ns'})"
                      f"{measured(eff, texts, doc['final']['parameters'])} {texts}",
                      flush=True)
    print("failures:", fails)


if __name__ == "__main__":
    main()
