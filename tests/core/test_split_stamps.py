"""A ROS bag's CSV export stamps each row in two integer columns, seconds and nanoseconds
(bench.split_stamps): read as one clock, mapped or not.  Fresh seed 10228 (j3, 20 s)."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.readers import read_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS


@pytest.fixture(scope="module")
def rec():
    return simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=20.0, seed=10228).record


def _export(rec, sec_name, nsec_name, values="effort,position", jitter=0.0):
    rng = np.random.default_rng(10228)
    ns = 1764950400 * 10**9 + 999_500_000 + np.round((rec.t + jitter * 1e-3 * rng.uniform(-1, 1, len(rec.t))) * 1e9).astype(np.int64)
    sec, nsec = ns // 10**9, ns % 10**9
    rows = (f"{a},{b},{x:.9g},{q:.10g}" for a, b, x, q in zip(sec, nsec, rec.tau, rec.q))
    return ("# inertia: 30\n" + f"{sec_name},{nsec_name},{values}\n" + "\n".join(rows)).encode(), ns


@pytest.mark.parametrize("sec_name,nsec_name", [("header.stamp.sec", "header.stamp.nanosec"),   # ROS 2
                                                ("header.stamp.secs", "header.stamp.nsecs")])    # ROS 1
def test_a_stamp_in_seconds_and_nanoseconds_is_one_clock(rec, sec_name, nsec_name):
    raw, ns = _export(rec, sec_name, nsec_name)
    for columns in (f"t={sec_name},tau=effort,q=position", None):
        if columns is None:      # nothing mapped: the stamp is found, the values by their names
            raw = raw.replace(b",effort,position\n", b",tau,q\n", 1)
        got = read_record(raw, name="joint_states.csv", columns=columns)
        np.testing.assert_allclose(got.t, (ns - ns[0]) * 1e-9, atol=1e-12)
        np.testing.assert_allclose(got.q, rec.q, atol=1e-9)
        assert got.reading["columns"]["t"] == f"{sec_name} + {nsec_name}"
        assert got.reading["resampling"]["resampled"] is False    # the seconds roll over at row 500


def test_a_ros_log_with_lost_messages_gives_the_parameters_of_its_whole_record(rec):
    """Messages lost in runs of 3-7 (a busy node): the gaps are bridged like any logger's,
    and the parameters stay those of the whole record."""
    raw, _ = _export(rec, "header.stamp.sec", "header.stamp.nanosec", values="tau,q")
    lines = raw.decode().split("\n")
    rng = np.random.default_rng(10229)
    keep = np.ones(len(lines), dtype=bool)
    for at in rng.choice(np.arange(10, len(lines) - 10), 60, replace=False):
        keep[at:at + rng.integers(3, 8)] = False
    keep[:2] = True
    got = read_record("\n".join(np.array(lines)[keep]).encode(), name="joint_states.csv")
    assert got.reading["resampling"]["resampled"] is True
    doc = analyze_record(got, diagnose_effects=False).report()
    clean = analyze_record(rec, diagnose_effects=False).report()
    for k in ("Fc", "Fs", "sigma2"):
        assert doc["parameters"][k] == pytest.approx(clean["parameters"][k], rel=0.02), k


def test_columns_that_only_look_like_a_stamp_are_left_alone(rec):
    """A 'nanosec' column beyond a second (a counter since boot) is not the fraction of the
    seconds beside it: the time column is read as it is."""
    body = "# inertia: 30\nsec,nanosec,tau,q\n" + "\n".join(
        f"{t:.6f},{int(5e9 + t * 1e9)},{x:.9g},{q:.10g}" for t, x, q in zip(rec.t, rec.tau, rec.q))
    got = read_record(body.encode(), name="x.csv", columns="t=sec,tau=tau,q=q")
    assert got.reading["columns"]["t"] == "sec"
    np.testing.assert_allclose(got.t, rec.t, atol=1e-9)
