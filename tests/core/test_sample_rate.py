"""A file without times, read at its stated sample rate (bench.sample_rate): a scope's or a
DAQ's export.  Fresh seed 10231 (j3, 10 s)."""
import json
import subprocess
import sys

import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.readers import read_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS


@pytest.fixture(scope="module")
def rec():
    return simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=10.0, seed=10231).record


def _untimed(rec, head=""):
    return ("# inertia: 30\n" + head + "tau,q\n" + "\n".join(
        f"{x:.9g},{q:.10g}" for x, q in zip(rec.tau, rec.q))).encode()


def test_rows_without_times_are_read_at_the_stated_rate(rec):
    want = analyze_record(rec, diagnose_effects=False).report()["parameters"]
    for raw, kw in ((_untimed(rec, "# sample_rate: 1000\n"), {}),
                    (_untimed(rec, "# sample_period: 0.001\n"), {}),
                    (_untimed(rec), {"sample_rate": 1000.0}),
                    # a time unit speaks of a time column: the rate's seconds stay seconds
                    (_untimed(rec), {"sample_rate": 1000.0, "time_unit": "ms"})):
        got = read_record(raw, name="scope.csv", **kw)
        np.testing.assert_allclose(got.t, rec.t, atol=1e-12)
        assert got.reading["columns"]["t"] == "row number / 1000 Hz"
        assert analyze_record(got, diagnose_effects=False).report()["parameters"] == pytest.approx(want, rel=1e-4)   # the CSV keeps 9 digits


@pytest.mark.parametrize("raw_of,kw,expect", [
    (lambda r: _untimed(r), {}, "missing column 't' (header is: tau, q)"),
    (lambda r: _untimed(r), {"columns": "tau=tau,q=q"}, "no time column mapped"),
    (lambda r: _untimed(r), {"sample_rate": 0.0}, "--sample-rate must be positive"),
    (lambda r: _untimed(r, "# sample_rate: fast\n"), {}, "sample_rate must be a number, got 'fast'"),
    (lambda r: r.to_csv().encode(), {"sample_rate": 1000.0}, "has a time column ('t') and a sample rate was given"),
])
def test_a_rate_that_cannot_stand_for_times_is_one_line(rec, raw_of, kw, expect):
    with pytest.raises(InputError) as err:
        read_record(raw_of(rec), name="scope.csv", **kw)
    assert expect in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_a_time_column_wins_over_a_stated_rate(rec):
    """The file's own times are the better clock: a wrong rate line beside them is not used."""
    got = read_record(("# sample_rate: 500\n" + rec.to_csv()).encode(), name="r.csv")
    np.testing.assert_allclose(got.t, rec.t, atol=1e-9)
    assert "sample_rate" not in got.reading


def test_the_command_line_takes_a_sample_rate(tmp_path, rec):
    p = tmp_path / "scope.csv"
    p.write_bytes(_untimed(rec))
    out = tmp_path / "r.json"
    r = subprocess.run([sys.executable, "-m", "bench.cli", "analyze", str(p), "--sample-rate", "1000",
                        "--no-diagnosis", "--json", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(out.read_text())["input"]["columns"]["t"] == "row number / 1000 Hz"
    r = subprocess.run([sys.executable, "-m", "bench.cli", "analyze", str(p)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "--sample-rate HZ" in r.stderr and "Traceback" not in r.stderr, r.stderr
