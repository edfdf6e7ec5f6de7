"""Tuning sweep for the friction-level change test (``bench.level_drift``), seeds 1000-1999 only.

    python tools/tune_level_drift.py [--seeds 1] [--what clean,jump,warm,outside]
clean: every joint under every recording condition, the diagnosis's final residual (must not
change); jump: the independent simulator's step of both friction levels mid-record (must);
warm: its viscous warm-up, a library effect once fitted (must not, after it); outside: the
physics outside the library of ``virtual_drives.outside_physics`` (reported)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from independent_joint import independent_record  # noqa: E402

from bench.analysis import analyze_record  # noqa: E402
from bench.level_drift import level_change  # noqa: E402
from virtual_drives.conditions import CONDITIONS, EXTRA_CONDITIONS, make_record  # noqa: E402
from virtual_drives.outside_physics import outside_record  # noqa: E402
from virtual_drives.presets import PRESETS  # noqa: E402


def line(label, rec, spec):
    a = analyze_record(rec)
    d, data = a.diagnosis, a.ident.data
    p = level_change(data.c, data.friction - d.contexts[-1].model, data.mask)
    named = [s.effect for s in d.steps if s.significant and not s.removed]
    print(f"{label:60s} segs {p['segments']:3d} pred {p['predicted_fraction']:+.2f} t {p['t']:+6.1f} "
          f"size/Fc {p['changing_rms'] / spec.friction.Fc:.4f} named {named}", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--what", default="clean,jump,warm,outside")
    a = ap.parse_args()
    what = a.what.split(",")
    for s in range(a.seeds):
        if "clean" in what:
            for ci, cond in enumerate(list(CONDITIONS) + list(EXTRA_CONDITIONS)):
                for ji, joint in enumerate(PRESETS):
                    seed = 1300 + 100 * s + 10 * ci + ji
                    rec, _ = make_record(PRESETS[joint], cond, seed=seed)
                    line(f"clean {joint} {cond} {seed}", rec, PRESETS[joint])
        for ji, joint in enumerate(PRESETS):
            spec = PRESETS[joint]
            rng = np.random.default_rng([1400 + s, ji])
            kw = dict(disturbance=0.01 * spec.friction.Fc, jitter=0.3, drop=0.005)
            if "jump" in what:
                ph = dict(jump=float(rng.choice([-1, 1]) * rng.uniform(0.06, 0.12)), jump_t=float(rng.uniform(6, 14)))
                rec, _ = independent_record(spec, seed=1400 + 10 * s + ji, physics=ph, **kw)
                line(f"jump {joint} {ph['jump']:+.3f} at {ph['jump_t']:.1f} s", rec, spec)
            if "warm" in what:
                ph = dict(warm=float(rng.uniform(0.2, 0.35)), warm_tau=float(rng.uniform(4, 15)))
                rec, _ = independent_record(spec, seed=1450 + 10 * s + ji, physics=ph, **kw)
                line(f"warm {joint} {ph['warm']:.2f} tau {ph['warm_tau']:.1f}", rec, spec)
            if "outside" in what:
                for kind in ("saturating_torque_constant", "nonlinear_viscous"):
                    rec, text = outside_record(spec, kind, 1500 + 10 * s + ji)
                    line(f"outside {joint} {text}", rec, spec)


if __name__ == "__main__":
    main()
