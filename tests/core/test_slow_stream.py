"""A slower stream filled forward onto a faster one's rows (``bench.slow_stream``): a torque
read at 100 Hz merged onto a 1 kHz encoder's rows (pandas' merge_asof, a ROS bag exported on
the encoder's topic) repeats each reading for ten rows.  Read as written it sat up to 9 ms
late and was told as physics (an inertia error named on 8 of 10 tuning records, a torque lag
for a slow position stream); a drive's trace of a slower command it held looks the same and
is right as written.  Fresh seeds 9723-9731 (tuning: 1620-1623, 1630-1653)."""
import json
import subprocess
import sys

import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.records import Record
from bench.slow_stream import filled_forward, forward_fill_interval, reading_times
from independent_joint import independent_record
from virtual_drives.presets import PRESETS

BENCH = [sys.executable, "-m", "bench.cli"]


def _filled(x: np.ndarray, k: int) -> np.ndarray:
    """``x`` read every ``k`` rows and filled forward."""
    return x[(np.arange(len(x)) // k) * k]


def test_a_stream_filled_forward_is_found_and_coarse_readings_are_not():
    rng = np.random.default_rng(9723)
    t = np.sort(1e-3 * np.arange(20000) + 3e-4 * rng.uniform(-1, 1, 20000))
    smooth = 40.0 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * rng.standard_normal(len(t))
    interval, row = forward_fill_interval(t, _filled(smooth, 10))
    assert abs(interval / 0.01 - 1) < 0.02 and abs(row / 1e-3 - 1) < 0.02
    assert forward_fill_interval(t, _filled(smooth, 2)) is None        # half a row late: left
    assert forward_fill_interval(t, smooth) is None
    # a torque read in steps of 2 units (reading noise a tenth of a step): one size of change
    assert forward_fill_interval(t, 2.0 * np.round((smooth - 0.27 * rng.standard_normal(len(t))) / 2.0)) is None
    # a coarse encoder at a steady speed changes at a steady pace too, one count at a time
    assert forward_fill_interval(t, 1e-3 * np.floor(0.1 * t / 1e-3)) is None
    # a torque that stands still most of the record (long runs at no pace)
    idle = np.where(np.sin(2 * np.pi * 0.2 * t) > 0.8, smooth, 0.0)
    assert forward_fill_interval(t, idle) is None
    # an excitation of torque levels, each held for half a second: a command, not a stream
    assert forward_fill_interval(t, _filled(rng.uniform(-50, 50, len(t)), 500)) is None
    assert forward_fill_interval(t, _filled(smooth, 40)) is not None    # a 25 Hz stream is


def test_readings_are_interpolated_between_and_a_time_written_twice_is_no_trouble():
    """A 100 Hz torque filled forward onto 1 kHz rows stamped in whole milliseconds (times
    written twice now and then): the rows between its readings are interpolated, on average over
    five times closer to the torque than the staircase (duplicates move a reading a row), and
    the record is a copy."""
    t = np.round(np.sort(1e-3 * np.arange(6000) + 8e-4 * np.random.default_rng(9731).uniform(-1, 1, 6000)), 3)
    torque = 40.0 * np.sin(2 * np.pi * 0.7 * t)
    rec = Record(t=t, tau=_filled(torque, 10), q=np.sin(t), meta={"inertia": 1.0})
    assert np.count_nonzero(np.diff(t) == 0) > 100
    out = filled_forward(rec)
    assert out is not rec and np.array_equal(rec.tau, _filled(torque, 10))
    assert out.reading["filled_forward"]["tau"]["read_as"] == "readings, interpolated between"
    inside = slice(20, -20)
    assert np.abs(out.tau - torque)[inside].mean() < 0.2 * np.abs(rec.tau - torque)[inside].mean()
    plain = Record(t=t, tau=torque, q=np.sin(t))
    assert filled_forward(plain) is plain          # a torque read on every row: as it is


def _merged(t: np.ndarray, clock: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x`` read at the instants ``clock`` and merged onto rows at ``t`` the way pandas'
    ``merge_asof`` does: each row takes the last reading at or before it."""
    return x[np.maximum(np.searchsorted(clock, t, side="right") - 1, 0)]


def test_a_streams_own_clock_is_found_from_where_its_readings_show():
    """A merge of two loggers shows each reading on the first row at or after it, up to a row
    late at random; where the stream keeps a clock of its own (60 ppm off 5 ms, 5.37 ms,
    9.83 ms) its readings' instants are found to a few hundredths of a row, on a jittered lossy
    logger.  Readings every 5th row of that logger or of a clean one that lost a single row
    (each lost row moves the rest by one, which a line tilted a row across the record fits
    like a drifting clock) stay on their rows.  A clock in step with the rows (one phase
    throughout) is not pinned, and its readings are placed on the steadiest clock: off by
    one steady share of a row, where on their rows they were off at random."""
    rng = np.random.default_rng(9736)
    n = 20000
    nominal = 1e-3 * np.arange(n) + 1.5e-4 * rng.uniform(-1, 1, n)
    t = np.sort(nominal[rng.uniform(size=n) >= 0.005])
    wave = lambda s: np.sin(2 * np.pi * 0.7 * s) + 0.3 * np.sin(2 * np.pi * 3.1 * s)
    for period in (5e-3 * (1 + 60e-6), 5.37e-3, 9.83e-3):
        clock = np.arange(rng.uniform(0, period), t[-1], period)
        x = _merged(t, clock, wave(clock))
        starts = np.concatenate(([0], np.nonzero(np.diff(x))[0] + 1))
        interval, _ = forward_fill_interval(t, x)
        ts, found, pinned, room = reading_times(t, starts, interval)
        assert pinned and abs(found / period - 1) < 1e-4 and room <= 0.25e-3, (period, found, room)
        true = clock[np.searchsorted(clock, t[starts[1:]], side="right") - 1]
        late = (ts[1:] - true) / 1e-3                       # in rows
        on_rows = (t[starts[1:]] - true) / 1e-3
        assert np.median(np.abs(late)) < 0.05 and np.max(np.abs(late)) < 0.3, (period, np.abs(late).max())
        assert np.median(on_rows) > 0.3                     # on their rows: half a row late
        assert np.all(np.diff(ts) > 0)
    for rows in (t, np.delete(1e-3 * np.arange(n), 11111)):     # lossy; clean but for one lost row
        every_fifth = _filled(wave(rows), 5)
        starts = np.concatenate(([0], np.nonzero(np.diff(every_fifth))[0] + 1))
        ts, found, pinned, _ = reading_times(rows, starts, 5e-3)
        assert found is None and not pinned and np.array_equal(ts, rows[starts])
    in_step = np.arange(3.7e-4, t[-1], 5e-3)
    x = _merged(t, in_step, wave(in_step))
    starts = np.concatenate(([0], np.nonzero(np.diff(x))[0] + 1))
    ts, found, pinned, room = reading_times(t, starts, 5e-3)
    assert found is not None and not pinned and abs(found / 5e-3 - 1) < 1e-4, found
    assert 0.5e-3 < room <= 1e-3, room            # most of a row: bench.clock_room fits the offset
    true = in_step[np.searchsorted(in_step, t[starts[1:]], side="right") - 1]
    late, on_rows = (ts[1:] - true) / 1e-3, (t[starts[1:]] - true) / 1e-3     # in rows
    assert np.std(late) < 0.05 and np.std(late) < 0.2 * np.std(on_rows), (np.std(late), np.std(on_rows))
    assert np.all(np.abs(late) <= 1.0) and np.all(np.diff(ts) > 0)


def _outcome(doc: dict, spec) -> tuple:
    f = spec.friction
    errors = {k: doc["parameters"][k] / getattr(f, k) - 1 for k in ("Fc", "Fs", "sigma2")}
    return ([d["effect"] for d in doc["diagnosis"] if d["significant"]], doc["unexplained"]["structured"],
            max(abs(e) for e in errors.values()), errors)


@pytest.mark.parametrize("joint,seed,col,k", [("j3", 9724, "tau", 10), ("rotary", 9725, "tau", 4),
                                              ("j1", 9726, "q", 5), ("linear", 9727, "tau", 10)])
def test_a_slower_stream_filled_forward_is_read_between_its_readings(joint, seed, col, k):
    """On the jittered lossy logger: nothing named, nothing left, Fc, Fs, sigma2 within 5 %,
    and the report says which column was filled forward and how it was read."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, duration=20.0, seed=seed, disturbance=0.01 * spec.friction.Fc,
                                jitter=0.3, drop=0.005)
    cols = {"tau": rec.tau, "q": rec.q}
    cols[col] = _filled(cols[col], k)
    doc = analyze_record(Record(t=rec.t, meta={"inertia": spec.inertia, "joint_type": spec.joint_type},
                                **cols)).report()
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)
    ff = doc["resampling"]["filled_forward"]
    assert list(ff) == [col] and ff[col]["read_as"] == "readings, interpolated between", ff
    assert abs(ff[col]["rows_per_reading"] / k - 1) < 0.05, ff
    assert ff[col]["clock"] == "the rows'", ff             # read on the logger's own rows: kept there
    assert any("filled forward" in w for w in doc["warnings"]), doc["warnings"]


@pytest.mark.parametrize("joint,seed,col,period", [("j2", 9737, "q", 5e-3 * (1 + 60e-6)),
                                                   ("j4", 9738, "q", 5.37e-3),
                                                   ("linear", 9739, "tau", 9.83e-3),
                                                   ("j1", 9745, "q", 5e-3), ("rotary", 9746, "tau", 10e-3)])
def test_a_stream_on_its_own_clock_is_read_at_its_readings_instants(joint, seed, col, period):
    """A merge of two loggers: the readings of a stream with its own clock, each shown on the
    first row of the jittered lossy logger at or after it.  On the rows, up to a row late at
    random, a 200 Hz position named a gear spring (tuning seeds 1672-1674) or an inertia
    error (1671); at the clock's instants: nothing named or left, within 5 %, the
    report giving the clock's own rate.  A position under a PD loop, a torque under the sine
    test.  Clocks of exactly 5 and 10 ms keep one phase to the rows and may not be pinned:
    on the rows j1's position named a gear spring and the rotary motor's torque left its Fc
    undetermined (tuning seeds 1722, 1727); placed on their steadiest clock all the same."""
    spec = PRESETS[joint]
    extra = {"pd": (6.0, 0.05 if joint == "linear" else 0.3, 1.5)} if col == "q" else {}
    rec, path = independent_record(spec, duration=20.0, seed=seed, n_sub=40, jitter=0.3, drop=0.005,
                                   disturbance=0.01 * spec.friction.Fc, **extra)
    clock = np.arange(np.random.default_rng(seed).uniform(0, period), rec.t[-1], period)
    if col == "q":
        exact = np.interp(clock, np.arange(len(path)) * (1e-3 / 40), path[:, 0])
        reading = np.floor(exact / spec.encoder_resolution + 0.5) * spec.encoder_resolution
    else:
        reading = np.interp(clock, rec.t, rec.tau)
    cols = {"tau": rec.tau, "q": rec.q}
    cols[col] = _merged(rec.t, clock, reading)
    keep = rec.t >= clock[0]
    doc = analyze_record(Record(t=rec.t[keep], meta={"inertia": spec.inertia, "joint_type": spec.joint_type},
                                **{c: x[keep] for c, x in cols.items()})).report()
    ff = doc["resampling"]["filled_forward"][col]
    assert ff["clock"].startswith("its own") and abs(ff["rate_hz"] * period - 1) < 1e-4, ff
    assert any("clock of their own" in w for w in doc["warnings"]), doc["warnings"]
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)


@pytest.mark.parametrize("joint,seed", [("j2", 9728), ("j4", 9729)])
def test_a_command_held_longer_than_a_row_stays_as_written(joint, seed):
    """A drive's trace at 1 kHz of a 100 Hz torque command it held (the motion steps with
    it): read as a command held, and nothing named, nothing left, within 5 %."""
    spec = PRESETS[joint]
    amplitude, hz = spec.excitation
    t = 1e-3 * np.arange(20000)
    rec, _ = independent_record(spec, duration=20.0, seed=seed, disturbance=0.01 * spec.friction.Fc,
                                torque=amplitude * np.sin(2 * np.pi * hz * np.floor(t / 0.01) * 0.01),
                                torque_noise=0.0, jitter=0.3, drop=0.005)
    doc = analyze_record(Record(t=rec.t, tau=rec.tau, q=rec.q,
                                meta={"inertia": spec.inertia, "joint_type": spec.joint_type})).report()
    assert doc["resampling"]["filled_forward"]["tau"]["read_as"] == "a command held", doc["resampling"]
    assert any("held that long" in w for w in doc["warnings"]), doc["warnings"]
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)


def test_a_logger_merging_a_slow_torque_stream_is_analysed_end_to_end(tmp_path):
    """The file a robot's logger writes: other column names, no metadata lines, a 100 Hz
    torque filled forward onto a 1 kHz encoder's uneven rows.  ``bench analyze`` with
    --columns reads it between its readings and writes one residual row per file row."""
    spec = PRESETS["j2"]
    rec, _ = independent_record(spec, duration=20.0, seed=9730, disturbance=0.01 * spec.friction.Fc,
                                jitter=0.3, drop=0.005)
    tau = _filled(rec.tau, 10)
    path, js, res = tmp_path / "merged.csv", tmp_path / "o.json", tmp_path / "res.csv"
    path.write_text("stamp,joint_pos,joint_effort\n" + "".join(
        f"{a:.6f},{c:.12g},{b:.6g}\n" for a, b, c in zip(rec.t, tau, rec.q)))
    r = subprocess.run(BENCH + ["analyze", str(path), "--columns", "t=stamp,tau=joint_effort,q=joint_pos",
                                "--inertia", str(spec.inertia), "--json", str(js), "--residuals", str(res)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "filled forward" in r.stdout + r.stderr
    doc = json.loads(js.read_text())
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)
    assert doc["resampling"]["filled_forward"]["tau"]["read_as"] == "readings, interpolated between"
    table = np.genfromtxt(res, delimiter=",", names=True)
    assert len(table) == len(rec.t)
    np.testing.assert_allclose(table["t"], np.round(rec.t, 6), atol=1e-9)


def test_a_refusal_on_a_merged_stream_says_how_to_keep_its_times():
    """A merge loses a slower stream's own times (up to a row each), which can hide sliding on
    a fast joint (a 200 Hz position with its own scatter, the linear stage under a PID loop,
    tuning seed 1720: refused, read within 0.5 % at its own times).  A refusal on such a record
    says so, on its one line; the same record with every position keeps the plain refusal."""
    spec = PRESETS["j2"]
    t = np.arange(20000) * 1e-3
    below = 0.7 * spec.friction.Fc * np.sin(2 * np.pi * spec.excitation[1] * t)   # never breaks away
    rec, _ = independent_record(spec, duration=20.0, seed=9744, torque=below)
    refusals = []
    for q in (_filled(rec.q, 5), rec.q):
        with pytest.raises(InputError) as err:
            analyze_record(Record(t=rec.t, tau=rec.tau, q=q, meta=dict(rec.meta)))
        refusals.append(str(err.value))
    merged, plain = refusals
    assert "never reaches sliding" in merged and "\n" not in merged
    assert "the position column is a slower stream (200 Hz) merged onto these rows" in merged
    assert "each stream on rows of its own" in merged
    assert "never reaches sliding" in plain and "merged" not in plain
