"""A clock written coarser than the samples come (``bench.coarse_time``): a 1 kHz log whose
time column has two decimals holds ten rows per stamp.  It was refused ("sample step 0 s is
outside ..."); now the rows of a stamp are spread over it, and the analysis is the one of the
same log with its exact times.  Fresh seeds 9720-9722 (tuning: 1580-1581, 1610)."""
import json
import subprocess
import sys

import numpy as np

from bench.analysis import analyze_record
from bench.coarse_time import spread_stamps
from bench.readers import read_record
from bench.records import Record
from independent_joint import independent_record
from virtual_drives.conditions import make_record
from virtual_drives.presets import PRESETS

BENCH = [sys.executable, "-m", "bench.cli"]


def test_a_truncating_clock_gives_back_the_sample_times_up_to_one_shift():
    true = 0.0037 + 1e-3 * np.arange(3000)
    rec = Record(t=np.floor(true * 100) / 100, tau=np.zeros(3000), q=np.sin(true))
    done = spread_stamps(rec)
    assert done["samples_per_stamp"] == 10 and abs(done["quantum"] - 0.01) < 1e-12, done
    shift = rec.t - true
    assert np.ptp(shift) < 1e-9 and abs(shift[0]) < 0.01, (shift.min(), shift.max())
    # a first stamp fuller than the others stays inside its quantum: time keeps increasing
    full = Record(t=np.concatenate([np.zeros(13), np.repeat(0.01 * np.arange(1, 300), 10)]),
                  tau=np.zeros(3003), q=np.zeros(3003))
    assert spread_stamps(full) and np.diff(full.t).min() > 0 and full.t[12] < 0.01
    # a log writing a time twice now and then keeps its duplicates for bench.resample to drop
    few = Record(t=np.insert(true, [5, 900], true[[5, 900]]), tau=np.zeros(3002), q=np.zeros(3002))
    assert spread_stamps(few) is None and np.array_equal(few.t, np.insert(true, [5, 900], true[[5, 900]]))


def test_a_log_stamped_to_10_ms_is_the_log_with_its_exact_times(tmp_path):
    """A clean 1 kHz record written as a logger with a %.2f clock writes it (rounded, so
    neighbouring stamps hold 9 and 11 rows where the samples meet the stamps' edges), read
    with --columns and no metadata: the same parameters as from the exact times, the
    residuals one row per file row at the file's own stamps."""
    rec, _ = make_record(PRESETS["j3"], "clean", 9720)
    path = tmp_path / "coarse.csv"
    lines = ["time,torque,pos"] + [f"{a:.2f},{b:.9g},{c:.12g}" for a, b, c in zip(rec.t, rec.tau, rec.q)]
    path.write_text("\n".join(lines) + "\n")
    exact = analyze_record(Record(t=rec.t, tau=rec.tau, q=rec.q,
                                  meta={"inertia": rec.meta["inertia"]})).report()
    out, js = tmp_path / "res.csv", tmp_path / "o.json"
    r = subprocess.run(BENCH + ["analyze", str(path), "--columns", "t=time,tau=torque,q=pos",
                                "--inertia", str(rec.meta["inertia"]), "--residuals", str(out),
                                "--json", str(js)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    doc = json.loads(js.read_text())
    spread = doc["resampling"]["timestamps_spread"]
    assert spread["samples_per_stamp"] == 10 and not doc["resampling"]["resampled"], doc["resampling"]
    for k, v in exact["parameters"].items():
        assert abs(doc["parameters"][k] / v - 1.0) < 1e-4, (k, v, doc["parameters"][k])
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert len(table) == len(rec.t)
    stamps = np.array([float(f"{a:.2f}") for a in rec.t])
    np.testing.assert_allclose(table["t"], stamps, atol=1e-9)   # the file's own stamps
    inside = ~np.isnan(table["measured"])
    assert inside.mean() > 0.7 and np.ptp(table["measured"][inside]) > 0   # one value per row


def test_a_jittered_lossy_logger_with_a_coarse_clock_is_analysed():
    """The independent simulator's PC logger (30 % jitter, 0.5 % lost samples) stamped to
    10 ms (truncated) and to 5 ms (rounded): nothing named, nothing left, Fc, Fs and sigma2
    within 5 % (the samples' own jitter is lost with the stamps: j2 at 10 ms, tuning seed 1580,
    Fc +1.2 % against -0.5 % from the exact times)."""
    for joint, seed, quantum, cut in (("j4", 9721, 0.01, np.floor), ("j1", 9722, 0.005, np.round)):
        spec = PRESETS[joint]
        rec, _ = independent_record(spec, duration=20.0, seed=seed, disturbance=0.01 * spec.friction.Fc,
                                    jitter=0.3, drop=0.005)
        raw = Record(t=cut(rec.t / quantum) * quantum, tau=rec.tau, q=rec.q, meta=dict(rec.meta))
        doc = analyze_record(read_record(raw.to_csv().encode(), name="c.csv")).report()
        assert abs(doc["resampling"]["timestamps_spread"]["quantum"] / quantum - 1) < 1e-6
        assert not [d["effect"] for d in doc["diagnosis"] if d["significant"]], (joint, doc["diagnosis"][:2])
        assert not doc["unexplained"]["structured"], (joint, doc["unexplained"]["evidence"])
        errors = {k: doc["parameters"][k] / getattr(spec.friction, k) - 1 for k in ("Fc", "Fs", "sigma2")}
        assert max(abs(e) for e in errors.values()) < 0.05, (joint, errors)


def test_a_time_that_lost_its_digits_is_refused_saying_so(tmp_path):
    """An epoch in seconds stored as float32 (128 s steps at 1.76e9 s) holds one time for a
    20 s log: nothing to spread, so refused, one line, naming what the digits were lost to;
    a text export written with too few digits is told the same, both causes named."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    t = 1.764e9 + np.arange(20000) * 1e-3
    q = 0.3 * np.sin(np.pi * (t - t[0]))
    tau = 5.0 * np.tanh(50.0 * np.cos(np.pi * (t - t[0])))
    pq.write_table(pa.table({"time": t.astype(np.float32), "position": q, "effort": tau}), tmp_path / "f32.parquet")
    (tmp_path / "few.csv").write_text("t,tau,q\n" + "\n".join(f"{a:.7g},{b:.6g},{c:.6g}" for a, b, c in zip(t, tau, q)))
    for name in ("f32.parquet", "few.csv"):
        r = subprocess.run([*BENCH, "analyze", str(tmp_path / name), "--inertia", "0", "--no-diagnosis"],
                           capture_output=True, text=True)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert r.returncode == 2 and len(lines) == 1, r.stderr
        assert ("sample step 0 s is outside 1e-07..0.2 s (1 distinct times in 20000 rows: the time lost its "
                "digits (a float32 keeps only 128 s steps at this magnitude; a text export may have written "
                "too few)") in lines[0], lines[0]
