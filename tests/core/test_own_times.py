"""MATLAB signals with time vectors of their own (``bench.own_times``): Simulink's To Workspace
"Structure With Time" and timeseries saved as structs, a 200 Hz encoder beside a 1 kHz
torque or two loggers' clocks.  Such a file was a traceback (columns of different lengths) or
read as if its signals were taken together."""
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.io import savemat

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.readers import read_record
from independent_joint import independent_record
from tests.core.test_slow_stream import _outcome
from virtual_drives.presets import PRESETS

BENCH = [sys.executable, "-m", "bench.cli"]


def _structure_with_time(time, values) -> dict:
    """What Simulink's To Workspace block saves as "Structure With Time"."""
    return {"time": time, "signals": {"values": np.reshape(values, (-1, 1)), "dimensions": 1,
                                      "label": ""}, "blockName": "rig/To Workspace"}


def _own_clock(rec, path, dt, n_sub, period, phase, seed):
    """A position read on a clock of its own (jittered by a tenth of its period) from the
    independent simulator's fine path."""
    rng = np.random.default_rng([seed, 7])
    n = int(rec.t[-1] / period)
    clock = phase + period * np.arange(n) + rng.uniform(-0.1, 0.1, n) * period
    clock = clock[(clock > 0) & (clock < rec.t[-1])]
    return clock, np.interp(clock, np.arange(len(path)) * dt / n_sub, path[:, 0])


@pytest.mark.parametrize("joint,seed,pid", [("j4", 9756, False), ("linear", 9757, True)])
def test_signals_with_their_own_times_are_joined_on_them(tmp_path, joint, seed, pid):
    """The torque on the jittered lossy logger, the position at 200 Hz on a clock of its own,
    each a Structure With Time, nothing mapped: both are read at their own instants -- Fc, Fs,
    sigma2 within 5 %, nothing named or left -- and the report says whose times they were."""
    spec = PRESETS[joint]
    dt, n_sub = 1e-3, 40
    kw = {}
    if pid:   # closed-loop tracking: half the travel of a 4 s sine record
        r0, _ = independent_record(spec, duration=4.0, seed=1)
        kw = dict(pd=(6.0, 0.5 * float(r0.q.max() - r0.q.min()), 1.5))
    rec, path = independent_record(spec, duration=20.0, seed=seed, disturbance=0.01 * spec.friction.Fc,
                                   jitter=0.3, drop=0.005, dt=dt, n_sub=n_sub, **kw)
    clock, q = _own_clock(rec, path, dt, n_sub, 5e-3, 0.37e-3, seed)
    savemat(tmp_path / "log.mat", {"tau": _structure_with_time(rec.t, rec.tau), "q": _structure_with_time(clock, q)})
    read = read_record(tmp_path / "log.mat", inertia=spec.inertia, joint_type=spec.joint_type)
    assert read.reading["own_times"] == {"tau": "tau.time", "q": "q.time"}
    doc = analyze_record(read).report()
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)
    assert doc["input"]["columns"] == {"t": "tau.time + q.time", "tau": "tau", "q": "q"}
    assert doc["resampling"]["joined_streams"] == {"rows_of": "tau", "placed": ["q"]}
    assert any("has a time vector of its own (q.time), at 200" in w for w in doc["warnings"]), doc["warnings"]


def test_one_length_on_other_instants_and_the_command_line(tmp_path):
    """Two timeseries saved as structs (Time, Data) of one length whose instants differ by half
    a step: read at their own instants, not as if taken together.  On the command line with
    --columns and --residuals, the residuals at the torque's times; a time vector shared
    by every signal changes nothing."""
    spec = PRESETS["j2"]
    rec, path = independent_record(spec, duration=12.0, seed=9758, dt=1e-3, n_sub=20)
    half = rec.t + 0.5e-3
    q = np.interp(half, np.arange(len(path)) * 1e-3 / 20, path[:, 0])
    savemat(tmp_path / "ts.mat", {"trq": {"Time": rec.t, "Data": rec.tau}, "pos": {"Time": half, "Data": q},
                                  "inertia": spec.inertia})
    read = read_record(tmp_path / "ts.mat", columns="t=trq.Time,tau=trq.Data,q=pos.Data")
    assert read.reading["own_times"] == {"q": "pos.Time"}
    # the torque's rows kept, each position reading placed at its own instant between them
    assert read.reading["joined_streams"] == {"rows_of": "tau", "placed": ["q"]}
    np.testing.assert_array_equal(read.reading["raw_t"], rec.t[1:])
    truth = np.interp(rec.t[1:], np.arange(len(path)) * 1e-3 / 20, path[:, 0])
    # (the last row has no reading after it to be read between)
    assert np.max(np.abs(read.q - truth)[:-1]) < 0.1 * np.max(np.abs(q[1:] - truth)), "read as if taken together"
    r = subprocess.run(BENCH + ["analyze", str(tmp_path / "ts.mat"), "--columns", "t=trq.Time,tau=trq,q=pos",
                                "--residuals", str(tmp_path / "res.csv"), "--json", str(tmp_path / "r.json")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    res = np.genfromtxt(tmp_path / "res.csv", delimiter=",", names=True)
    assert len(res) == len(rec.t) - 1 and np.all(np.diff(res["t"]) > 0)
    assert np.isfinite(res["final"]).mean() > 0.9
    named, left, worst, errors = _outcome(json.loads((tmp_path / "r.json").read_text()), spec)
    assert not named and not left and worst < 0.05, (named, left, errors)
    # one time vector for both: nothing joined, the rows as they are
    savemat(tmp_path / "one.mat", {"tau": _structure_with_time(rec.t, rec.tau),
                                   "q": _structure_with_time(rec.t, rec.q), "t": rec.t})
    one = read_record(tmp_path / "one.mat", inertia=spec.inertia)
    assert "own_times" not in one.reading and "joined_streams" not in one.reading
    np.testing.assert_array_equal(one.reading["raw_t"], rec.t)


def test_signals_of_different_lengths_without_times_are_one_line(tmp_path):
    """Variables of different lengths and no time of their own: one line naming them (it was
    a traceback); a signal's own time that runs backwards: one line naming that time."""
    t = np.arange(400) / 1e3
    savemat(tmp_path / "bad.mat", {"t": t, "tau": np.sin(t), "q": np.cos(t[::4])})
    with pytest.raises(InputError, match=r"bad.mat: the mapped variables differ in length "
                                         r"\('t' 400, 'tau' 400, 'q' 100\); give each signal its own time"):
        read_record(tmp_path / "bad.mat", inertia=1)
    r = subprocess.run(BENCH + ["analyze", str(tmp_path / "bad.mat"), "--inertia", "1"],
                       capture_output=True, text=True, timeout=120)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2 and len(lines) == 1 and "differ in length" in lines[0], r.stderr
    back = t[::4].copy()
    back[50] = 0.01
    savemat(tmp_path / "back.mat", {"tau": _structure_with_time(t, np.sin(t)),
                                    "q": _structure_with_time(back, np.cos(back))})
    with pytest.raises(InputError, match=r"back.mat: time 'q.time' decreases at sample 51"):
        read_record(tmp_path / "back.mat", inertia=1)


def test_a_csv_column_with_a_time_column_of_its_own(tmp_path):
    """A side-by-side export (``t_tau, tau, t_q, q``, the position's columns shorter and empty
    at the end): ``q=q@t_q`` reads each position at its own time.  Mapped as ``q=q`` it was
    placed on the torque's rows, its empty tail dropped as lost rows, and the record refused
    as never reaching sliding."""
    spec = PRESETS["j2"]
    rec, _ = independent_record(spec, duration=12.0, seed=9762, dt=1e-3)
    k = np.arange(0, len(rec.t), 5)
    rows = ["t_tau,tau,t_q,q"] + [
        f"{rec.t[i]:.6f},{rec.tau[i]:.8g}," + (f"{rec.t[k[i]]:.6f},{rec.q[k[i]]:.10g}" if i < len(k) else ",")
        for i in range(len(rec.t))]
    (tmp_path / "side.csv").write_text("\n".join(rows) + "\n")
    read = read_record(tmp_path / "side.csv", columns="t=t_tau,tau=tau,q=q@t_q", inertia=spec.inertia,
                       joint_type=spec.joint_type)
    assert read.reading["own_times"] == {"q": "t_q"} and read.reading["columns"]["q"] == "q"
    assert read.t[-1] > 11.9
    named, left, worst, errors = _outcome(analyze_record(read).report(), spec)
    assert not named and not left and worst < 0.05, (named, left, errors)
    with pytest.raises(InputError, match=r"no column 'tq' \(the time of q\); the file's columns: t_tau, tau, t_q, q"):
        read_record(tmp_path / "side.csv", columns="t=t_tau,tau=tau,q=q@tq", inertia=1.0)
    # mapped without @t_q, as before: one line saying what the file holds, not "never reaches
    # sliding" with advice to excite harder
    with pytest.raises(InputError, match=r"'q' fills its first 2400 rows and the time 't_tau' 12000 "
                                         r"rows; 't_q' rises on exactly those 2400 rows.*map it as q=q@t_q"):
        read_record(tmp_path / "side.csv", columns="t=t_tau,tau=tau,q=q", inertia=spec.inertia)


def test_a_second_time_column_alone_is_not_taken_for_an_own_time(tmp_path):
    """What a side-by-side export is not: a logger's second clock on every row (a host's
    receive time beside the drive's), and a position column whose empty tail sits beside the
    time column's own instants.  Both are read as they were."""
    t = np.arange(3000) / 1e3
    q = 0.3 * np.sin(2 * np.pi * t)
    rows = ["t,t_host,tau,q"] + [f"{t[i]:.6f},{t[i] + 0.0123 + 1e-4 * (i % 3):.6f},{np.cos(2 * np.pi * t[i]):.6f},{q[i]:.8f}"
                                 for i in range(len(t))]
    (tmp_path / "host.csv").write_text("\n".join(rows) + "\n")
    assert len(read_record(tmp_path / "host.csv", inertia=0.1).t) == 3000
    rows = ["t,tau,t_q,q"] + [f"{t[i]:.6f},{np.cos(2 * np.pi * t[i]):.6f}," + (f"{t[i]:.6f},{q[i]:.8f}" if i < 2500 else ",")
                              for i in range(len(t))]
    (tmp_path / "tail.csv").write_text("\n".join(rows) + "\n")
    read = read_record(tmp_path / "tail.csv", inertia=0.1)
    assert len(read.t) == 2500 and read.reading["empty_rows"] == 500


def test_own_times_in_clock_time(tmp_path):
    """Side-by-side time columns holding clock times (ISO strings in a CSV, Arrow timestamps
    with empty cells in Parquet) share one origin and read as the same columns in seconds do;
    clock times beside numbers have no common origin: one line.  Before, a CSV's were read as
    nanoseconds since 1970 ("sample step 1e+06 s")."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    spec = PRESETS["j4"]
    rec, _ = independent_record(spec, duration=3.0, seed=9763, dt=1e-3)
    n = len(rec.t)
    k = np.arange(0, n, 4)
    late = 0.3e-3        # the position's clock a third of a row behind the torque's
    start = np.datetime64("2026-11-30T10:00:00", "ns")
    tau_at = start + np.round(rec.t * 1e9).astype("timedelta64[ns]")
    q_at = start + np.round((rec.t[k] + late) * 1e9).astype("timedelta64[ns]")
    cell = lambda a, i: str(a[i]) if i < len(k) else ""           # noqa: E731
    num = lambda a, i: f"{a[i]:.10g}" if i < len(k) else ""       # noqa: E731
    rows = ["t_tau,tau,t_q,q"] + [f"{tau_at[i]},{rec.tau[i]:.8g},{cell(q_at, i)},{num(rec.q[k], i)}"
                                  for i in range(n)]
    (tmp_path / "clock.csv").write_text("\n".join(rows) + "\n")
    rows = ["t_tau,tau,t_q,q"] + [f"{rec.t[i]:.6f},{rec.tau[i]:.8g},{num(rec.t[k] + late, i)},{num(rec.q[k], i)}"
                                  for i in range(n)]
    (tmp_path / "seconds.csv").write_text("\n".join(rows) + "\n")
    t_q = np.full(n, np.datetime64("NaT"), dtype="datetime64[ns]")
    t_q[:len(k)] = q_at
    q = np.full(n, np.nan)
    q[:len(k)] = rec.q[k]
    pq.write_table(pa.table({"t_tau": pa.array(tau_at), "tau": rec.tau, "t_q": pa.array(t_q),
                             "q": pa.array(q, mask=np.isnan(q))}), tmp_path / "clock.parquet")
    opts = dict(columns="t=t_tau,tau=tau,q=q@t_q", inertia=spec.inertia, joint_type=spec.joint_type)
    ref = read_record(tmp_path / "seconds.csv", **opts)
    for f in ("clock.csv", "clock.parquet"):
        r = read_record(tmp_path / f, **opts)
        assert r.reading["own_times"] == {"q": "t_q"} and r.reading.get("clock_time"), f
        assert len(r.t) == len(ref.t) > 0.9 * n, (f, len(r.t), len(ref.t))
        assert np.allclose(r.t - r.t[0], ref.t - ref.t[0], atol=1e-9), f
        assert np.allclose(r.q, ref.q, atol=1e-9) and np.allclose(r.tau, ref.tau), f
    rows = ["t_tau,tau,t_q,q"] + [f"{tau_at[i]},{rec.tau[i]:.8g},{num(rec.t[k], i)},{num(rec.q[k], i)}"
                                  for i in range(n)]
    (tmp_path / "mixed.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(InputError, match=r"mixed.csv: time 't_tau' holds clock times and 't_q' "
                                         r"numbers; give the times in one kind"):
        read_record(tmp_path / "mixed.csv", **opts)
