"""Tuning sweep for the 'nothing left to explain' verdict under users' recording conditions
(seeds 1000-1999 only; tests use 5000+).

    python tools/tune_noise_floor.py [--seeds 2] [--conditions all] [--effects none,cogging,...]
For each condition of ``virtual_drives.conditions`` (and the extra ones), each joint and seed:
the significant effects, the verdict (predicted fraction, t, size / Fc) and the errors of Fc,
Fs and sigma2.  With --effects, the library effects are injected too (one joint per effect,
rotating), and the line says whether the effect was named first and how far the error fell."""
from __future__ import annotations

import argparse
import time
import zlib

from bench.analysis import analyze_record
from virtual_drives.conditions import CONDITIONS, EXTRA_CONDITIONS, make_record
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--conditions", default="all")
    ap.add_argument("--joints", default=",".join(PRESETS))
    ap.add_argument("--effects", default="none")
    ap.add_argument("--outside", action="store_true",
                    help="instead: physics outside the library (virtual_drives.outside_physics)")
    a = ap.parse_args()
    if a.outside:
        return outside(a)
    conds = list(CONDITIONS) + list(EXTRA_CONDITIONS) if a.conditions == "all" else a.conditions.split(",")
    joints = a.joints.split(",")
    bad = 0
    for cond in conds:
        for e_i, eff in enumerate(a.effects.split(",")):
            for j_i, joint in enumerate(joints):
                if eff != "none" and j_i != e_i % len(joints):
                    continue
                spec = PRESETS[joint]
                if eff == "gravity" and spec.joint_type != "revolute":
                    spec = PRESETS["j2"]
                for s in range(a.seeds):
                    seed = 1000 + 31 * s + zlib.crc32(f"{cond}{eff}{joint}".encode()) % 500
                    texts = [] if eff == "none" else random_effects(spec, [eff], seed)
                    t0 = time.time()
                    try:
                        rec, truth = make_record(spec, cond, seed, effects=texts)
                        doc = analyze_record(rec).report()
                    except Exception as e:  # noqa: BLE001 - a tuning sweep reports and goes on
                        print(f"ERR  {cond:42s} {spec.name:6s} {eff:24s} {seed} {type(e).__name__}: {e}", flush=True)
                        bad += 1
                        continue
                    u = doc["unexplained"]
                    sig = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
                    p, f = doc["parameters"], spec.friction
                    err = {k: p[k] / getattr(f, k) - 1 for k in ("Fc", "Fs", "sigma2")}
                    if eff == "none":
                        ok = not sig and not u["structured"] and max(abs(x) for x in err.values()) <= 0.05
                    else:
                        ok = (sig[:1] == [eff] and doc["final"]["effects"] == [eff] and not u["structured"]
                              and doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"])
                    bad += not ok
                    print(f"{'ok  ' if ok else 'FAIL'} {cond:42s} {spec.name:6s} {eff:24s} {seed} "
                          f"{time.time() - t0:5.1f}s sig={sig} final={doc['final']['effects']} "
                          f"pred={u['predicted_fraction']:+.2f} t={u['predicted_t']:.1f} "
                          f"size={u['structured_vs_coulomb']:.4f} relies={u['relies_on']} "
                          + " ".join(f"{k}{v:+.1%}" for k, v in err.items()), flush=True)
    print("not ok:", bad)


def outside(a):
    """Each kind of outside physics on each joint: nothing credited, verdict 'unexplained'."""
    from virtual_drives.outside_physics import KINDS, outside_record
    bad = 0
    for kind in KINDS:
        for joint in a.joints.split(","):
            for s in range(a.seeds):
                seed = 1000 + 31 * s + zlib.crc32(f"{kind}{joint}".encode()) % 500
                rec, text = outside_record(PRESETS[joint], kind, seed)
                doc = analyze_record(rec).report()
                u = doc["unexplained"]
                credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
                ok = not credited and not doc["final"]["effects"] and u["structured"]
                bad += not ok
                print(f"{'ok  ' if ok else 'FAIL'} {kind:28s} {joint:6s} {seed} {text:40s} credited={credited} "
                      f"structured={u['structured']} pred={u['predicted_fraction']:+.2f} t={u['predicted_t']:.1f} "
                      f"size={u['structured_vs_coulomb']:.4f} relies={u['relies_on']}", flush=True)
    print("not ok:", bad)


if __name__ == "__main__":
    main()
