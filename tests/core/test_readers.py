"""Records as users have them (bench.readers, bench.resample): other formats and column names,
other units, a PC logger's uneven timestamps with dropped samples, friction-torque records,
and the residuals at the file's own timestamps.  Seeds 5000+ (fresh; tuning used 1000-1999)."""
import json
import re
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy.io import savemat

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.readers import read_record
from bench.records import Record
from bench.grid_math import held_torque, second_difference
from virtual_drives.joint import simulate_record, sine_torque
from virtual_drives.presets import PRESETS

BENCH = [sys.executable, "-m", "bench.cli"]
KEYS = ("Fc", "Fs", "sigma2")


def run(*args):
    return subprocess.run(BENCH + [str(a) for a in args], capture_output=True, text=True, timeout=300)


def rel_errors(doc_or_params, spec) -> dict:
    p = doc_or_params.get("parameters", doc_or_params)
    return {k: abs(p[k] / getattr(spec.friction, k) - 1) for k in KEYS}


def logged(rec: Record, seed: int, drop: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Indices of a uniform 1 kHz record read the way a PC logger does: steps of 1-13 ms,
    now and then 3-7 samples in a row lost (gaps), as (times, fraction of each step)."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(1e-3, 13e-3, int(rec.duration / 6e-3)))
    t = t[t < rec.t[-1]]
    keep = np.ones(len(t), dtype=bool)
    for s in rng.choice(len(t), int(drop * len(t)), replace=False):
        keep[s:s + rng.integers(3, 8)] = False
    return t[keep]


def friction_log(joint: str, seed: int, duration: float, offset: float = 0.0):
    """A torque-sensing arm's friction log: the joint's true friction (eq. 5 on the true
    motion) plus sensor noise and an optional constant offset, position in degrees."""
    spec = PRESETS[joint]
    sim = simulate_record(spec, *spec.excitation, duration=duration, seed=seed)
    t = sim.record.t
    F = held_torque(sine_torque(*spec.excitation, t)) - spec.inertia * second_difference(sim.true_q, 1e-3)
    rng = np.random.default_rng(seed + 1)
    F = F + 0.02 * spec.friction.Fc * rng.standard_normal(len(t)) + offset * spec.friction.Fc
    return spec, t, F, np.degrees(sim.true_q), np.degrees(sim.true_v)


def test_formats_round_trip(tmp_path):
    rec = simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=3.0, seed=5301).record
    cols = {"time": rec.t, "torque": rec.tau, "pos": rec.q}
    # semicolon and decimal comma (a European spreadsheet), no metadata lines
    lines = ["time;torque;pos"] + [";".join(f"{x:.10g}".replace(".", ",") for x in row)
                                   for row in zip(rec.t, rec.tau, rec.q)]
    (tmp_path / "r.csv").write_text("\n".join(lines))
    pq.write_table(pa.table(cols), tmp_path / "r.parquet")
    savemat(tmp_path / "vars.mat", cols)
    savemat(tmp_path / "struct.mat", {"log": cols})
    (tmp_path / "r.txt").write_text("\n".join(" \t".join(f"{x:.10g}" for x in row)
                                              for row in zip(rec.t, rec.tau, rec.q)))
    mapping = "t=time,tau=torque,q=pos"
    for f, m in (("r.csv", mapping), ("r.parquet", mapping), ("vars.mat", mapping),
                 ("struct.mat", "t=log.time,tau=log.torque,q=log.pos"), ("struct.mat", mapping),
                 ("r.txt", "t=1,tau=2,q=3")):
        got = read_record(tmp_path / f, columns=m, inertia=30.0)
        for k in ("t", "tau", "q"):
            np.testing.assert_allclose(getattr(got, k), getattr(rec, k), rtol=1e-9, atol=1e-12, err_msg=f)
        assert got.reading["resampling"]["resampled"] is False and got.inertia == 30.0
    # the project's own run traces: the host's gravity model comes off the torque
    trace = pa.table({"t": rec.t, "tau_j2": rec.tau + 5.0, "g_j2": np.full(len(rec.t), 5.0), "q_j2": rec.q,
                      "v_j2": np.gradient(rec.q, 1e-3), "segment": ["x"] * len(rec.t)})
    pq.write_table(trace, tmp_path / "trace.parquet")
    got = read_record(tmp_path / "trace.parquet", inertia=30.0)
    np.testing.assert_allclose(got.tau, rec.tau, atol=1e-9)
    assert got.qd is not None and got.reading["columns"]["tau"] == "tau_j2 - g_j2"


def test_duplicate_timestamps_are_dropped_and_reported():
    rec = simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=2.0, seed=5309).record
    dup = np.sort(np.concatenate([np.arange(len(rec.t)), [10, 500, 501, 1500]]))
    raw = Record(t=rec.t[dup], tau=rec.tau[dup], q=rec.q[dup], meta=dict(rec.meta))
    got = read_record(raw.to_csv().encode(), name="dup.csv")
    assert got.reading["resampling"]["duplicates_dropped"] == 4 and not got.reading["resampling"]["resampled"]
    np.testing.assert_allclose(got.q, rec.q, rtol=1e-9)   # the CSV keeps 10 digits


def test_units_and_columns_give_the_si_parameters(tmp_path):
    for joint, pos, tq, fq, ft in (("j3", "deg", "mN*m", 180 / np.pi, 1e3), ("linear", "mm", "N", 1e3, 1.0)):
        spec = PRESETS[joint]
        rec = simulate_record(spec, *spec.excitation, duration=10.0 if joint == "j3" else 3.0, seed=5302).record
        si = analyze_record(rec, diagnose_effects=False).report()["parameters"]
        p = tmp_path / f"{joint}.csv"
        p.write_text("when,effort,angle\n" + "\n".join(
            f"{t:.6f},{x * ft:.12g},{q * fq:.14g}" for t, x, q in zip(rec.t, rec.tau, rec.q)))
        got = read_record(p, columns="t=when,tau=effort,q=angle", joint_type=spec.joint_type,
                          position_unit=pos, torque_unit=tq, inertia=spec.inertia)
        doc = analyze_record(got, diagnose_effects=False).report()
        for k, v in si.items():
            assert doc["parameters"][k] == pytest.approx(v, rel=1e-4), (joint, k)
        conv = doc["units"]["conversions"]
        assert conv["position"]["from"] == pos and (tq == "N" or conv["torque"]["factor"] == 1e-3)


@pytest.mark.parametrize("joint, seed", [("j3", 5303), ("j1", 5304)])
def test_jittered_log_with_dropped_samples_is_resampled_split_and_identified(joint, seed):
    spec = PRESETS[joint]
    rec = simulate_record(spec, *spec.excitation, duration=40.0, seed=seed).record
    t = logged(rec, seed + 1)
    # the logger samples position and torque at its own times (no torque_hold: it samples)
    raw = Record(t=t, tau=rec.tau[np.searchsorted(rec.t, t, side="right") - 1], q=np.interp(t, rec.t, rec.q),
                 meta={"inertia": spec.inertia})
    got = read_record(raw.to_csv().encode(), name="log.csv")
    rs = got.reading["resampling"]
    assert rs["resampled"] and 0.006 < rs["median_step"] < 0.008 and rs["jitter"] > 0.3
    assert rs["gaps"] >= 20 and len(got.segment_bounds()) == len(rs["segments"]) >= 10
    steps = np.diff(got.t)
    assert np.all(np.isclose(np.delete(steps, np.array(got.segments[1:]) - 1), rs["median_step"]))
    doc = analyze_record(got, diagnose_effects=False).report()
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)
    assert sum(s["scored"] for s in doc["resampling"]["segments"]) >= 5


@pytest.mark.parametrize("qd_noise, source", [(None, "q"), (0.0, "qd"), (0.05, "q (the logged qd is")])
def test_friction_torque_record_with_inertia_zero(qd_noise, source):
    """Friction column, inertia 0; a logged velocity is used unless it is much noisier than
    the position's differences."""
    spec, t, F, q_deg, v_deg = friction_log("j4", 5305, duration=24.0)
    header, cols = ["stamp", "joint_friction", "joint_pos"], [t, F, q_deg]
    if qd_noise is not None:
        rng = np.random.default_rng(5310)
        header.append("joint_vel")
        cols.append(v_deg + qd_noise * np.abs(v_deg).max() * rng.standard_normal(len(t)))
    text = ",".join(header) + "\n" + "\n".join(",".join(f"{x:.10g}" for x in row) for row in zip(*cols))
    mapping = "t=stamp,tau=joint_friction,q=joint_pos" + (",qd=joint_vel" if qd_noise is not None else "")
    rec = read_record(text.encode(), name="arm.csv", columns=mapping, inertia=0, position_unit="deg")
    doc = analyze_record(rec, diagnose_effects=False).report()
    assert doc["inertia"] == 0.0 and doc["fit"]["torque_hold"] == "sample"
    assert doc["input"]["velocity_from"].startswith(source)
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)


def test_friction_log_with_an_offset_is_read():
    """The issue's repro: a torque sensor's friction with a constant offset of a quarter of
    Fc.  Reading must not refuse it (whether the analysis reads the offset as such is the
    diagnosis's business)."""
    spec, t, F, q_deg, _ = friction_log("j3", 5306, duration=12.0, offset=0.25)
    rec = read_record(("t,tau,q\n" + "\n".join(f"{a:.4f},{b:.8g},{c:.10g}" for a, b, c in zip(t, F, q_deg))).encode(),
                      name="offset.csv", inertia=0, position_unit="deg")
    assert rec.inertia == 0.0 and rec.meta["position_unit"] == "rad"
    np.testing.assert_allclose(rec.tau, F, rtol=1e-7)   # the offset is data, kept as it is


def test_logger_file_end_to_end_with_residuals(tmp_path):
    """A file as a robot's logger writes it: other column names, no metadata lines, uneven
    time with dropped samples, a friction column; analysed with --columns and --inertia 0."""
    spec, t1k, F, q_deg, _ = friction_log("j3", 5307, duration=14.0)
    t = logged(Record(t=t1k, tau=F, q=q_deg), 5308, drop=0.002)
    f = np.interp(t, t1k, F)
    q = np.interp(t, t1k, q_deg)
    path = tmp_path / "arm_log.csv"
    path.write_text("timestamp\tfriction_torque\tjoint_angle\n"
                    + "\n".join(f"{a:.6f}\t{b:.6g}\t{c:.9g}" for a, b, c in zip(t, f, q)))
    out = tmp_path / "res.csv"
    r = run("analyze", path, "--columns", "t=timestamp,tau=friction_torque,q=joint_angle", "--inertia", "0",
            "--position-unit", "deg", "--residuals", out, "--json", tmp_path / "o.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "o.json").read_text())
    assert doc["resampling"]["resampled"] and doc["input"]["columns"]["tau"] == "friction_torque"
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)
    lines = out.read_text().splitlines()
    assert lines[0] == "t,measured,baseline,final,held_out"
    table = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_allclose(table["t"], t, atol=5e-7)          # the file's own times
    inside = ~np.isnan(table["measured"])
    assert 0.7 < inside.mean() < 1.0 and table["held_out"][inside].mean() > 0.5
    assert not table["held_out"][~inside].any()
    m = inside & (table["held_out"] == 1)
    err = np.sqrt(np.mean((table["measured"][m] - table["final"][m]) ** 2))
    assert err == pytest.approx(doc["final"]["rms_error"], rel=0.5)   # the same comparison


def test_a_logger_counting_nanoseconds_since_the_epoch(tmp_path):
    """Integer nanoseconds since the epoch (as ROS and many PC loggers write them): read in ns
    by their magnitude and told, a unit the user gives still wins, and the residuals' t column
    is the file's own integers, digit for digit (a float keeps only ~16 of their 19)."""
    spec, t1k, F, q_deg, _ = friction_log("j2", 5330, duration=14.0)
    t = logged(Record(t=t1k, tau=F, q=q_deg), 5331, drop=0.002)
    ticks = 1_764_190_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    path = tmp_path / "ros.csv"
    body = "\n".join(f"{a},{b:.6g},{c:.9g}" for a, b, c in zip(ticks, np.interp(t, t1k, F), np.interp(t, t1k, q_deg)))
    path.write_text("stamp,friction,angle\n" + body)
    args = ("analyze", path, "--columns", "t=stamp,tau=friction,q=angle", "--inertia", "0",
            "--position-unit", "deg")
    r = run(*args, "--time-unit", "us")
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2 and len(lines) == 1 and re.search(r"in ns it is a [0-9.]+ ms step: --time-unit ns\)$",
                                                                lines[0]), r.stderr
    out = tmp_path / "res.csv"
    r = run(*args, "--residuals", out, "--json", tmp_path / "o.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "o.json").read_text())
    assert doc["units"]["conversions"]["time"] == {"from": "ns", "to": "s", "factor": 1e-9}
    assert doc["input"]["epoch_time"]["unit"] == "ns"
    assert any(w.startswith("the time column counts ns since 1970 (from 2025-11-26 20:46:40 UTC)")
               for w in doc["warnings"]), doc["warnings"]
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)
    written = [ln.split(",")[0] for ln in out.read_text().splitlines()[1:]]
    assert written == [str(k) for k in ticks]
    # a column whose name says its unit (bench.column_names.suffix_unit) needs no option
    named = read_record(("stamp_ns,friction,angle\n" + body).encode(), name="ros.csv",
                        columns="t=stamp_ns,tau=friction,q=angle", inertia=0.0, position_unit="deg")
    assert named.reading["units"]["time"] == {"from": "ns", "to": "s", "factor": 1e-9}


@pytest.mark.parametrize("t, unit", [
    (1.7e9 + np.arange(5) * 1e-3, None),             # seconds since 1970: already seconds
    (1.7e12 + np.arange(5), "ms"), (1.7e15 + np.arange(5) * 1e3, "us"), (1.7e18 + np.arange(5) * 1e6, "ns"),
    (1.7e18 + np.arange(5) * 1e9, None),             # 1 s steps: no logger this tool reads
    (np.arange(5) * 1e6, None),                      # ns from the logger's start: no date to go by
    (1.5e12 + np.arange(5) * 100, None),             # us since a boot 17 days ago, at 10 kHz: 0.1 "s" steps
    (1.8e12 + np.arange(5), None)])                  # ms from 1970 would be 2027, after "now"
def test_the_epoch_names_its_unit_only_by_a_past_date_and_a_loggers_step(t, unit):
    from bench.units import epoch_unit
    assert epoch_unit(t, now=1.765e9) == unit        # 2025-12-06


def test_clock_times_in_a_csv_and_a_parquet_read_as_seconds_from_the_first(tmp_path):
    """A logger's time as ISO 8601 strings (CSV) or Arrow timestamps (Parquet) reads as the same
    instants in seconds do, counted from the first (one reader of clock times for every time
    column: bench.own_times.clock_or_numbers)."""
    spec, t1k, F, q, _ = friction_log("j2", 9777, duration=4.0)
    t = logged(Record(t=t1k, tau=F, q=q), 9778, drop=0.002)
    tau, pos = np.interp(t, t1k, F), np.interp(t, t1k, q)
    start = np.datetime64("2026-12-01T08:00:00", "ns")
    us = np.round(t * 1e6).astype(np.int64)        # a logger's microseconds
    stamps = start + us.astype("timedelta64[us]")
    cols = {"t": "stamp", "tau": "friction", "q": "angle"}
    seconds = tmp_path / "s.csv"
    seconds.write_text("stamp,friction,angle\n" + "\n".join(
        f"{a:.6f},{b!r},{c!r}" for a, b, c in zip(us * 1e-6, tau.tolist(), pos.tolist())))
    iso = tmp_path / "iso.csv"
    iso.write_text("stamp,friction,angle\n" + "\n".join(
        f"{a},{b!r},{c!r}" for a, b, c in zip(np.datetime_as_string(stamps, unit="us"), tau.tolist(), pos.tolist())))
    parquet = tmp_path / "clock.parquet"
    pq.write_table(pa.table({"stamp": pa.array(stamps, pa.timestamp("us")), "friction": tau,
                             "angle": pos}), parquet)
    ref = read_record(seconds, columns=cols, inertia=0.0, position_unit="deg")
    for path in (iso, parquet):
        rec = read_record(path, columns=cols, inertia=0.0, position_unit="deg")
        assert len(rec.t) == len(ref.t)
        assert np.allclose(rec.t, ref.t - ref.t[0], rtol=0, atol=1e-9), path
        assert np.allclose(rec.tau, ref.tau) and np.allclose(rec.q, ref.q), path


@pytest.mark.parametrize("joint, condition, seed", [("j3", "robot joint log", 5333),
                                                   ("linear", "PD closed-loop tracking", 5334)])
def test_a_torque_counting_positive_against_the_position_is_reversed_and_said(joint, condition, seed):
    """A drive whose torque counts positive the other way than its encoder (CiA 402's polarity,
    a mirrored joint): friction would feed energy in.  Analysed with the torque reversed, the
    same parameters as the record as it should have been, and a warning saying so."""
    from dataclasses import replace

    from virtual_drives.conditions import make_record
    rec, _ = make_record(PRESETS[joint], condition, seed)
    right = analyze_record(rec, diagnose_effects=False).report()
    mirrored = replace(rec, tau=-rec.tau, meta=dict(rec.meta), reading=dict(rec.reading))
    doc = analyze_record(mirrored, diagnose_effects=False).report()
    assert doc["parameters"] == pytest.approx(right["parameters"], rel=1e-9)
    assert "torque's sign was reversed" in doc["warnings"][0]
    assert not any("reversed" in w for w in right["warnings"])


def test_a_position_that_wraps_at_a_whole_turn_is_unwrapped_and_said(tmp_path):
    """A single-turn encoder (or an angle logged modulo 360 degrees) on the rotary motor, whose
    sine test turns it by nearly a revolution: each wrap was a 2 pi step inside a sample and the
    record was refused as "never reaches sliding".  Unwrapped, the parameters are the unwrapped
    record's, and the report says what was done."""
    spec = PRESETS["rotary"]
    rec = simulate_record(spec, *spec.excitation, duration=12.0, seed=5338).record
    plain = analyze_record(rec, diagnose_effects=False).report()
    for name, angle, unit in (("zero_to_two_pi.csv", np.mod(rec.q, 2 * np.pi), "rad"),
                              ("plus_minus_180.csv", np.mod(np.degrees(rec.q + 1.5) + 180.0, 360.0) - 180.0, "deg")):
        lines = ["t,tau,q"] + [f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in zip(rec.t, rec.tau, angle)]
        (tmp_path / name).write_text("\n".join(lines))
        assert np.any(np.abs(np.diff(angle)) > 0.9 * (np.pi if unit == "rad" else 180.0) * 2)
        out = run("analyze", tmp_path / name, "--no-diagnosis", "--inertia", spec.inertia,
                  "--position-unit", unit, "--json", tmp_path / "w.json")
        assert out.returncode == 0, out.stderr
        doc = json.loads((tmp_path / "w.json").read_text())
        assert doc["input"]["turns_unwrapped"] >= 2
        assert "wraps at a whole turn" in doc["warnings"][0]
        assert doc["parameters"] == pytest.approx(plain["parameters"], rel=1e-5)


def test_unwrapping_leaves_real_motion_and_prismatic_joints_alone():
    """Only whole turns are taken out: a step that is not a whole turn (a glitch, a joint
    that is sampled too slowly) and a prismatic joint's position stay as they are."""
    from bench.turns import unwrap_turns
    t = np.arange(2000) * 1e-3
    q = 3.0 * np.sin(2 * np.pi * 0.5 * t)
    glitch = Record(t=t, tau=np.sin(t), q=np.where(np.arange(2000) == 700, q + 4.0, q), meta={})
    assert unwrap_turns(glitch) == 0 and np.array_equal(glitch.q, np.where(np.arange(2000) == 700, q + 4.0, q))
    wrapped = np.mod(q, 2 * np.pi)
    slider = Record(t=t, tau=np.sin(t), q=wrapped.copy(), meta={"joint_type": "prismatic"})
    assert unwrap_turns(slider) == 0 and np.array_equal(slider.q, wrapped)
    turning = Record(t=t, tau=np.sin(t), q=wrapped.copy(), meta={"joint_type": "revolute"})
    assert unwrap_turns(turning) > 0
    assert np.allclose(turning.q - turning.q[0], q - q[0], atol=1e-12)


@pytest.mark.parametrize("joint, seed, estimate", [("j1", 5339, "filtered"), ("linear", 5340, "filtered"),
                                                   ("j3", 5341, "backward difference")])
def test_a_logged_velocity_that_lags_the_position_is_set_aside(joint, seed, estimate):
    """A drive's velocity estimate (a first-order filter of 2 ms, or a backward difference on
    the 4 ms logger grid) lags the position's derivative; driving the model with it, the
    diagnosis named a `torque_lag` (j1 and the linear stage, these seeds, before).  The velocity
    now comes from q, as for a record without qd, and the report says why."""
    from dataclasses import replace

    from scipy.signal import lfilter

    from bench.resample import on_grid
    from virtual_drives.conditions import make_record
    rec, _ = make_record(PRESETS[joint], "robot joint log", seed)
    rec = on_grid(rec, "log")
    if estimate == "filtered":
        a = rec.dt / (2e-3 + rec.dt)
        qd = lfilter([a], [1, a - 1], rec.qd, zi=[rec.qd[0] * (1 - a)])[0]
    else:
        qd = np.r_[rec.qd[0], np.diff(rec.q) / rec.dt]
    right = analyze_record(rec).report()
    assert right["input"]["velocity_from"] == "qd"          # the true velocity keeps time
    lagging = analyze_record(replace(rec, qd=qd, meta=dict(rec.meta), reading=dict(rec.reading))).report()
    assert lagging["input"]["velocity_from"].startswith("q (the logged qd lags q's derivative by")
    assert lagging["final"]["effects"] == [] and not lagging["unexplained"]["structured"]
    without = analyze_record(replace(rec, qd=None, meta=dict(rec.meta), reading=dict(rec.reading)),
                             diagnose_effects=False).report()
    assert lagging["baseline"]["parameters"] == pytest.approx(without["parameters"], rel=1e-9)
    assert max(rel_errors(lagging, PRESETS[joint]).values()) < 0.05, rel_errors(lagging, PRESETS[joint])


@pytest.mark.parametrize("unit, bits, seed", [("ms", 16, 5344), ("us", 32, 5345)])
def test_a_time_counter_that_wraps_is_unwrapped_and_written_back_as_the_file_has_it(tmp_path, unit, bits, seed):
    """A drive's or logger's free-running counter as the time column (16-bit milliseconds wrap
    every 65.5 s, 32-bit microseconds every 71.6 min): crossing the wrap read as time going
    back and the file was refused.  Unwrapped in the file's unit, the same parameters as the
    counts without the wrap; --residuals writes t as the file holds it; a decrease that is
    not a wrap is still refused."""
    spec = PRESETS["j4"]
    rec = simulate_record(spec, *spec.excitation, duration=14.0, seed=seed).record
    per_s = {"ms": 1e3, "us": 1e6}[unit]
    counts = np.round(rec.t * per_s).astype(np.int64)
    start = 2 ** bits - int(5.5 * per_s)          # the counter wraps 5.5 s into the record
    wrapped = (counts + start) % 2 ** bits
    meta = f"# inertia: {spec.inertia}\n# time_unit: {unit}\n"

    def write(path, t):
        path.write_text(meta + "t,tau,q\n" + "\n".join(f"{a},{b:.9g},{c:.12g}" for a, b, c in zip(t, rec.tau, rec.q)))

    write(tmp_path / "wrapped.csv", wrapped)
    write(tmp_path / "plain.csv", counts + start)
    docs = {}
    for name in ("wrapped", "plain"):
        out = run("analyze", tmp_path / f"{name}.csv", "--no-diagnosis", "--json", tmp_path / f"{name}.json",
                  "--residuals", tmp_path / f"{name}_res.csv")
        assert out.returncode == 0, out.stderr
        docs[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert docs["wrapped"]["input"]["time_counter"] == {"bits": bits, "wraps": 1}
    assert "counter that wraps" in docs["wrapped"]["warnings"][0] and "time_counter" not in docs["plain"]["input"]
    assert docs["wrapped"]["parameters"] == pytest.approx(docs["plain"]["parameters"], rel=1e-9)
    written = [int(ln.split(",")[0]) for ln in (tmp_path / "wrapped_res.csv").read_text().splitlines()[1:]]
    assert written == wrapped.tolist()
    restarted = np.concatenate([counts[:7000], counts[7000:] - counts[7000] + 5])   # a logger restarted
    write(tmp_path / "restart.csv", restarted)
    out = run("analyze", tmp_path / "restart.csv", "--no-diagnosis")
    assert out.returncode == 2 and "time is not increasing" in out.stderr and len(out.stderr.splitlines()) == 1


def test_units_stated_in_the_header_are_used_unless_an_option_says_otherwise(tmp_path):
    """Loggers write units into the header ("angle [deg]") or in a row under it; an angle in
    degrees had been analysed as radians without a word.  Stated units are used (the report
    says so), an option or metadata line wins (a warning names the conflict), a unit that is
    not one for the column is left alone and said, and a length makes the joint prismatic."""
    spec = PRESETS["j2"]
    rec = simulate_record(spec, *spec.excitation, duration=12.0, seed=5346).record
    rows = list(zip(rec.t, rec.tau, rec.q))
    meta = f"# inertia: {spec.inertia}\n"

    def analyse(fname, text, *opts):
        (tmp_path / fname).write_text(meta + text)
        out = run("analyze", tmp_path / fname, "--no-diagnosis", "--json", tmp_path / "d.json", *opts)
        assert out.returncode == 0, out.stderr
        return json.loads((tmp_path / "d.json").read_text())

    si = analyse("si.csv", "t,tau,q\n" + "\n".join(f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in rows))
    in_names = analyse("names.csv", "t [ms];tau (Nm);q [deg]\n" + "\n".join(
        f"{a * 1e3:.3f};{b:.9g};{np.degrees(c):.12g}" for a, b, c in rows))
    units_row = analyse("row.csv", "time\ttorque\tangle\nms\tN·m\tdeg\n" + "\n".join(
        f"{a * 1e3:.3f}\t{b:.9g}\t{np.degrees(c):.12g}" for a, b, c in rows), "--columns", "t=time,tau=torque,q=angle")
    for doc in (in_names, units_row):
        assert doc["units"]["from_header"] == {"t": "ms", "tau": "N*m", "q": "deg"}
        # the same fit to rounding: milliseconds at 3 decimals and degrees at 12 digits move
        # the least determined parameter (alpha) by 1.3e-6 with numpy 2.4 / scipy 1.17
        # (2026-11-29); a unit left unapplied would move everything by orders of magnitude
        assert doc["parameters"] == pytest.approx(si["parameters"], rel=1e-5)
    # a row of descriptions under the names is skipped and said once, not read as units
    described = analyse("words.csv", "time,torque,angle\nTime since start,Motor torque,Joint angle\n" + "\n".join(
        f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in rows), "--columns", "t=time,tau=torque,q=angle")
    assert described["parameters"] == pytest.approx(si["parameters"], rel=1e-9)
    assert "description row" in described["warnings"][0]
    assert not any("is not a" in w for w in described["warnings"]) and "from_header" not in described["units"]
    amps = analyse("amps.csv", "t,tau [A],q [rad]\n" + "\n".join(f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in rows))
    assert amps["parameters"] == pytest.approx(si["parameters"], rel=1e-9)
    assert any("'A' is not a torque or force unit" in w and "torque-unit K*N*m" in w for w in amps["warnings"])
    # ... and said with a scale: a current with its torque constant, encoder counts, ticks
    kt, per_turn = 0.12, 4096
    scaled = analyse("scaled.csv", "t [ticks],tau [A],q [counts]\n" + "\n".join(
        f"{round(a * 40e6)},{b / kt:.12g},{c * per_turn / (2 * np.pi):.12g}" for a, b, c in rows),
        "--torque-unit", f"{kt}*N*m", "--position-unit", f"{2 * np.pi / per_turn!r}*rad", "--time-unit", "25*ns")
    # 12 significant digits of counts and amperes move alpha as the rounding above does (3e-6
    # in a fresh clone's run on 2026-11-30, with the model velocity's 12x band)
    assert scaled["parameters"] == pytest.approx(si["parameters"], rel=1e-5)
    assert scaled["units"]["conversions"]["torque"]["factor"] == pytest.approx(kt)
    # ... or in the header's names themselves, found without --columns
    in_header = analyse("scaled_names.csv", f"t [25*ns],tau [{kt}*N*m],q/{2 * np.pi / per_turn!r}*rad\n" + "\n".join(
        f"{round(a * 40e6)},{b / kt:.12g},{c * per_turn / (2 * np.pi):.12g}" for a, b, c in rows))
    assert in_header["parameters"] == pytest.approx(si["parameters"], rel=1e-5)
    assert in_header["units"]["from_header"] == {"t": "25*ns", "tau": f"{kt}*N*m", "q": f"{2 * np.pi / per_turn!r}*rad"}
    overridden = analyse("over.csv", "t,tau,q [deg]\n" + "\n".join(f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in rows),
                         "--position-unit", "rad")
    assert overridden["parameters"] == pytest.approx(si["parameters"], rel=1e-9)
    assert any("position_unit 'rad' was given and is used" in w for w in overridden["warnings"])
    (tmp_path / "badjt.csv").write_text(meta + "t,tau [A],q\n" + "\n".join(f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in rows))
    out = run("analyze", tmp_path / "badjt.csv", "--joint-type", "rotary", "--no-diagnosis")
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and "joint_type" in out.stderr, out.stderr
    slider = read_record(b"t,F [N],x [mm]\n" + "\n".join(f"{a:.6f},{b:.9g},{c * 1e3:.9g}" for a, b, c in rows).encode(),
                         name="stage.csv", columns="t=t,tau=F [N],q=x [mm]", inertia=spec.inertia)
    assert slider.meta["joint_type"] == "prismatic" and np.allclose(slider.q, rec.q, atol=1e-9)


@pytest.mark.parametrize("joint, condition, seed", [("j2", "white process noise", 5347),
                                                    ("linear", "coarse encoder", 5348),
                                                    ("j3", "jittered timestamps with dropped samples", 5349)])
def test_position_glitches_are_mended_and_said(joint, condition, seed):
    """An encoder's bad samples (eight, three of them two samples long, 1 % of the travel):
    left in, one such record became Fc 245 000x the truth with a `joint_flexibility` credited
    and "nothing left".  Mended from the samples around them, the record analyses like the
    clean one: nothing credited, nothing left, Fc, Fs, sigma2 within 5 %."""
    from virtual_drives.conditions import make_record
    rec, _ = make_record(PRESETS[joint], condition, seed)
    rng = np.random.default_rng(seed)
    at = rng.choice(np.arange(200, len(rec.t) - 200), 8, replace=False)
    h = 0.01 * np.ptp(rec.q) * rng.choice([-1, 1], len(at))
    q = rec.q.copy()
    q[at] += h
    q[at[:3] + 1] += h[:3]
    meta = "".join(f"# {k}: {v}\n" for k, v in rec.meta.items() if k in ("inertia", "joint_type", "torque_hold"))
    text = meta + "t,tau,q\n" + "\n".join(f"{a:.6f},{b:.9g},{c:.12g}" for a, b, c in zip(rec.t, rec.tau, q))
    doc = analyze_record(read_record(text.encode(), name="glitchy.csv")).report()
    assert doc["resampling"]["position_glitches_mended"] == 11
    assert "jumped away from their neighbours" in doc["warnings"][0]
    assert doc["final"]["effects"] == [] and not doc["unexplained"]["structured"], doc["diagnosis"][:2]
    assert max(rel_errors(doc, PRESETS[joint]).values()) < 0.05, rel_errors(doc, PRESETS[joint])


def test_position_glitches_in_a_record_built_in_memory_are_mended_too():
    """A drive's trace during a calibration reaches the analysis as a Record, not a file: its
    encoder glitches are mended the same way, and the caller's record is left as it was."""
    from virtual_drives.conditions import make_record
    rec, _ = make_record(PRESETS["j4"], "clean", 5352)
    rng = np.random.default_rng(5352)
    at = rng.choice(np.arange(200, len(rec.t) - 200), 6, replace=False)
    rec.q = rec.q.copy()
    rec.q[at] += 0.01 * np.ptp(rec.q) * rng.choice([-1, 1], len(at))
    before = rec.q.copy()
    doc = analyze_record(rec).report()
    assert np.array_equal(rec.q, before) and "glitches" not in rec.reading
    assert doc["resampling"]["position_glitches_mended"] == 6
    assert "jumped away from their neighbours" in doc["warnings"][0]
    assert doc["final"]["effects"] == [] and not doc["unexplained"]["structured"], doc["diagnosis"][:2]
    assert max(rel_errors(doc, PRESETS["j4"]).values()) < 0.05, rel_errors(doc, PRESETS["j4"])


def test_ringing_contacts_and_coarse_encoders_are_not_glitches():
    """What must not be mended: a gear's contact ringing at 200 Hz, lightly damped, seen by
    the motor encoder (5 samples a period), and a coarse encoder's counts at rest."""
    from independent_joint import independent_record

    from bench.glitches import find_glitches
    from virtual_drives.conditions import make_record
    ringing, _ = independent_record(PRESETS["linear"], seed=5350, backlash=0.003, contact_hz=200.0,
                                    contact_damping=0.02)
    coarse, _ = make_record(PRESETS["j4"], "coarse encoder", 5351)
    for rec in (ringing, coarse):
        assert not find_glitches(np.asarray(rec.t, float), np.asarray(rec.q, float)).any()


def test_rows_with_empty_or_nan_cells_are_dropped_samples():
    """A logger that writes an empty cell or "nan" for a sample it lost: the row is dropped,
    counted, and the rest analysed like any logger's uneven time."""
    spec, t, F, q_deg, _ = friction_log("j4", 5335, duration=14.0)
    rng = np.random.default_rng(5336)
    cells = [[f"{a:.6f}", f"{b:.6g}", f"{c:.9g}"] for a, b, c in zip(t, F, q_deg)]
    lost = rng.choice(np.arange(100, len(t) - 100), 140, replace=False)
    for i in lost:
        cells[i][1 + i % 2] = ("", "nan", "NaN")[i % 3]
    text = "time;friction;angle\n" + "\n".join(";".join(r) for r in cells)
    rec = read_record(text.encode(), name="lossy.csv", columns="t=time,tau=friction,q=angle",
                      inertia=0, position_unit="deg")
    assert len(rec.t) < len(t) and rec.reading["empty_rows"] == len(lost)
    doc = analyze_record(rec, diagnose_effects=False).report()
    assert doc["resampling"]["empty_rows_dropped"] == len(lost) and doc["resampling"]["resampled"]
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)


def test_a_window_of_a_long_log_and_a_log_too_long_to_analyse(tmp_path):
    """--window START:END takes the part of a log with the excitation; a log past the sample
    limit is refused at once with that hint, before anything is allocated for it."""
    spec, t, F, q_deg, _ = friction_log("j1", 5337, duration=16.0)
    path = tmp_path / "long.csv"
    path.write_text("t,f,q\n" + "\n".join(f"{a + 100:.6f},{b:.6g},{c:.9g}" for a, b, c in zip(t, F, q_deg)))
    out, js = tmp_path / "res.csv", tmp_path / "o.json"
    r = run("analyze", path, "--columns", "t=t,tau=f,q=q", "--inertia", "0", "--position-unit", "deg",
            "--window", "3:15", "--no-diagnosis", "--residuals", out, "--json", js)
    assert r.returncode == 0, r.stderr
    doc = json.loads(js.read_text())
    assert doc["input"]["window"] == {"start": 3.0, "end": 15.0, "samples": 12001}
    assert max(rel_errors(doc, spec).values()) < 0.05, rel_errors(doc, spec)
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table["t"][0] == pytest.approx(103.0) and table["t"][-1] == pytest.approx(115.0)
    for bad in ("15:3", "abc", "3"):
        r = run("analyze", path, "--columns", "t=t,tau=f,q=q", "--inertia", "0", "--window", bad)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert r.returncode == 2 and len(lines) == 1 and "is not START:END" in lines[0], r.stderr
    n = 4_000_001
    huge = Record(t=np.arange(n) * 1e-3, tau=np.sin(np.arange(n) * 1e-3), q=np.zeros(n), meta={"inertia": 0})
    with pytest.raises(InputError, match=r"would need about 6 GB to analyse .* --window START:END"):
        analyze_record(huge)


def test_milliseconds_from_a_metadata_line_are_seconds_inside():
    spec = PRESETS["j4"]
    rec = simulate_record(spec, *spec.excitation, duration=3.0, seed=5332).record
    text = "# time_unit: ms\n# inertia: %r\nt,tau,q\n" % spec.inertia + "".join(
        f"{1e3 * a:.3f},{b:.17g},{c:.17g}\n" for a, b, c in zip(rec.t, rec.tau, rec.q))
    got = read_record(text.encode(), name="ms.csv")
    np.testing.assert_allclose(got.t, rec.t, atol=1e-9)
    assert got.reading["units"]["time"]["from"] == "ms" and got.dt == pytest.approx(1e-3)


@pytest.mark.parametrize("content, options, expect", [
    ("t,tau,q\n0,1,1\n", {"time_unit": "min"}, "time_unit 'min' is not one of s, ms, us, ns"),
    ("a,b,c\n0,1,2\n", {"columns": "t=a,tau=b,q=zz"}, "no column 'zz' (for q); the file's columns: a, b, c"),
    ("a,b,c\n0,1,2\n", {"columns": "t=a,tau=b"}, "--columns must map t, tau and q (missing: q;"),
    ("t,tau,q\n" + "".join(f"{(i if i != 30 else 12) / 1000},{i},{i}\n" for i in range(60)), {"inertia": 1},
     "time is not increasing"),
    ("t,tau,q\n" + "".join(f"{i / 1000 + 0.05 * (i // 3)},{np.sin(i)},{i}\n" for i in range(60)), {"inertia": 1},
     "segments too short to analyse"),
    ("t,tau,q\n0,1,1\n", {"position_unit": "furlong"}, "position_unit 'furlong' is not one for a revolute joint"),
    ("t,tau,q\n" + "".join(f"{i / 1000},{i},{i}\n" for i in range(60)), {"inertia": -1}, "inertia must be positive"),
    ("# encoder: output\nt,tau,q\n" + "".join(f"{i / 1000},{i},{i}\n" for i in range(60)), {"inertia": 1},
     "encoder must be motor or load"),
    # valid UTF-8 that is no text (Arrow said "Could not skip initial 1 rows ...")
    ("garbage\x00\x01", {}, "holds control characters (binary content), not a text record"),
    ("t,tau,q", {}, "a header row and no data rows"),
])
def test_bad_input_is_one_line(content, options, expect):
    with pytest.raises(InputError) as e:
        read_record(content.encode(), name="x.csv", **options)
    assert expect in str(e.value) and "\n" not in str(e.value)


def test_mat_without_the_variable_and_decreasing_time_on_the_command_line(tmp_path):
    """Exit 2 and one line on the command line; the .mat case in-process (same error path)."""
    savemat(tmp_path / "m.mat", {"time": np.arange(50) / 1e3, "trq": np.ones(50), "ang": np.arange(50.0)})
    with pytest.raises(InputError, match=r"no column 'torque' \(for tau\); the file's columns: time, trq, ang"):
        read_record(tmp_path / "m.mat", columns="t=time,tau=torque,q=ang", inertia=1)
    p = tmp_path / "back.csv"
    p.write_text("# inertia: 1\nt,tau,q\n" + "".join(f"{(i if i != 30 else 12) / 1000},{i},{i}\n" for i in range(60)))
    r = run("analyze", p)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2 and len(lines) == 1 and "time is not increasing" in lines[0], r.stderr


def test_a_quoted_header_name_holding_the_delimiter_stays_one_column():
    """Excel quotes a name holding the delimiter ("time, s"); split on every comma the header
    had five fields over rows of three and the file was refused."""
    rec = simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=10.0, seed=10230).record
    body = '# inertia: 30\n"time, s","torque, N*m",q\n' + "\n".join(
        f"{t:.6f},{x:.9g},{q:.10g}" for t, x, q in zip(rec.t, rec.tau, rec.q))
    for columns in ("t=1,tau=2,q=3", 't="time, s","tau=torque, N*m",q=q'):   # by number, or quoted
        got = read_record(body.encode(), name="excel.csv", columns=columns)
        np.testing.assert_allclose(got.q, rec.q, atol=1e-9)
        np.testing.assert_allclose(got.tau, rec.tau, rtol=1e-8)
    with pytest.raises(InputError, match="a quote is not closed"):
        read_record(body.encode(), name="excel.csv", columns='t="time, s,tau=2,q=3')
