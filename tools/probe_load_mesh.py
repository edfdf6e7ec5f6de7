"""Tuning probe for ``bench.load_torque`` (friction that grows with the torque a gear carries,
README known limits "A gear's friction that rises with the torque it carries"); tuning seeds
1000-1999 only.

    python tools/probe_load_mesh.py "SOURCE:JOINT:WHAT:SEED;..."
SOURCE ours: WHAT is a recording condition of ``virtual_drives.conditions``; SOURCE ind: the
independent simulator, WHAT is EXCITATION/MU with EXCITATION two (two torque tones, a felt
disturbance of 1 % of Fc), tworead (two tones, reading noise of 2 % of Fc) or pid, and MU its
``load_mu`` (0: clean).  Prints the verdict's ``load`` readings in % of Fc (effect, jackknife t)
for the recorded torque and the torque the motion needs."""
from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
from independent_joint import independent_record, two_tones  # noqa: E402
from tests.diagnosis.test_independent_records import _travel  # noqa: E402

from bench.analysis import analyze_record  # noqa: E402
from bench.load_torque import TORQUES  # noqa: E402
from virtual_drives.conditions import make_record  # noqa: E402
from virtual_drives.presets import PRESETS  # noqa: E402


def record(src: str, joint: str, what: str, seed: int):
    spec = PRESETS[joint]
    f = spec.friction
    if src == "ours":
        return make_record(spec, what, seed)[0], spec
    exc, mu = what.split("/")
    kw = dict(disturbance=0.01 * f.Fc, disturbance_tau=0.05, drop=0.01)
    if exc == "two":
        kw["torque"] = two_tones(spec)
    elif exc == "tworead":
        kw = dict(torque=two_tones(spec), torque_noise=0.02 * f.Fc, drop=0.01)
    elif exc == "pid":
        kw["pd"] = (6.0, 0.4 * _travel(spec), 1.5)
    physics = dict(load_mu=float(mu)) if float(mu) else None
    return independent_record(spec, duration=20.0, seed=seed, physics=physics, **kw)[0], spec


if __name__ == "__main__":
    for job in sys.argv[1].split(";"):
        src, joint, what, seed = job.split(":")
        if not 1000 <= int(seed) <= 1999:
            sys.exit("tuning seeds 1000-1999 only")
        rec, spec = record(src, joint, what, int(seed))
        doc = analyze_record(rec).report()
        load, fc = doc["unexplained"]["load"] or {}, spec.friction.Fc
        print(json.dumps(dict(job=job, named=[e["effect"] for e in doc["diagnosis"] if e["significant"]],
                              structured=doc["unexplained"]["structured"],
                              Fc=round(doc["parameters"]["Fc"] / spec.friction.Fc - 1, 3),
                              load={k: (round(100 * load[k]["effect"] / fc, 2), round(load[k]["t"], 1))
                                    for k in TORQUES if k in load})), flush=True)
