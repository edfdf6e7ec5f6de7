"""Probe (not wired into the diagnosis) for friction that grows with the torque a gear carries,
the README known limit "A gear's friction that rises with the torque it carries"; tuning seeds
1000-1999 only.

    python tools/probe_load_mesh.py "SOURCE:JOINT:WHAT:SEED;..."
SOURCE ours: WHAT is a recording condition of ``virtual_drives.conditions``; SOURCE ind: the
independent simulator, WHAT is EXCITATION/MU with EXCITATION two (two torque tones, a felt
disturbance of 1 % of Fc), tworead (two tones, reading noise of 2 % of Fc) or pid, and MU its
``load_mu`` (0: clean).

Within each motion segment (sliding samples) the final residual times the direction is
regressed on a torque, the speed beside it, for two torques: the recorded |tau| ("cmd", which
a loop's answer to a disturbance leaks into) and the torque the motion needs, |tau - residual|
("need", which open-loop process noise leaks into).  Printed per torque: the slope times the
torque's spread in % of Fc, and the t of the per-segment slopes.  2026-12-02, tuning seeds
1650-1679: loaded meshes at mu 0.15 3.1-10.8 % with t >= 3.2 on both; 18 clean records under
nine conditions never above 1.2 % (t <= 1.3) on the smaller of the two, though cmd alone leaked
up to 34 % (a robot joint log) and need alone 3.2 % in an earlier probe (1600-1601)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
from independent_joint import independent_record, two_tones  # noqa: E402
from tests.diagnosis.test_independent_records import _travel  # noqa: E402

from bench.analysis import analyze_record  # noqa: E402
from bench.signals import reversals  # noqa: E402
from virtual_drives.conditions import make_record  # noqa: E402
from virtual_drives.presets import PRESETS  # noqa: E402


def slopes(a) -> dict:
    d, data = a.diagnosis, a.ident.data
    c, m = data.c, data.mask
    r = data.friction - d.contexts[-1].model
    vmax = float(np.percentile(np.abs(c.v[m]), 99.5))
    cuts = np.concatenate(([0], reversals(c.v, 0.05 * vmax), [len(c.v)]))
    out = {}
    for name, x in (("cmd", np.abs(c.tau)), ("need", np.abs(c.tau - r))):
        per, X, Y = [], [], []
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            sel = np.arange(lo, hi)
            sel = sel[m[sel] & (np.abs(c.v[sel]) >= 0.3 * vmax)]
            if len(sel) < 20:
                continue
            y, xx, vv = r[sel] * np.sign(c.v[sel]), x[sel], np.abs(c.v[sel])
            A = np.c_[xx - xx.mean(), vv - vv.mean()]
            X.append(A)
            Y.append(y - y.mean())
            if np.std(xx) > 0:
                per.append(np.linalg.lstsq(A, y - y.mean(), rcond=None)[0][0] * np.std(xx))
        A, yy = np.vstack(X), np.concatenate(Y)
        b = np.linalg.lstsq(A, yy, rcond=None)[0][0]
        per = np.array(per)
        t = per.mean() / (per.std(ddof=1) / np.sqrt(len(per))) if len(per) > 2 else 0.0
        out[name] = (round(100 * b * np.std(A[:, 0]) / data.coulomb, 2), round(float(t), 1))
    return out


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
        a = analyze_record(rec)
        doc = a.report()
        print(json.dumps(dict(job=job, named=[e["effect"] for e in doc["diagnosis"] if e["significant"]],
                              structured=doc["unexplained"]["structured"],
                              Fc=round(doc["parameters"]["Fc"] / spec.friction.Fc - 1, 3),
                              slopes=slopes(a))), flush=True)
