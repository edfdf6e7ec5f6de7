"""The bench command line, run as a user runs it: a real subprocess."""
import json
import subprocess
import sys

import numpy as np
import pytest

from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS

BENCH = [sys.executable, "-m", "bench.cli"]


def run(*args, cwd=None):
    return subprocess.run(BENCH + [str(a) for a in args], capture_output=True, text=True, cwd=cwd, timeout=300)


def good_record(tmp_path, joint="j3", seed=5201, **kw):
    spec = PRESETS[joint]
    rec = simulate_record(spec, *spec.excitation, duration=kw.pop("duration", 12.0), seed=seed, **kw).record
    return rec


def test_simulate_then_analyze_writes_the_json_contract_and_plots(tmp_path):
    csv = tmp_path / "j3.csv"
    r = run("simulate", "--joint", "j3", "--duration", "12", "--seed", "5202", "-o", csv)
    assert r.returncode == 0, r.stderr
    r = run("analyze", csv, "--json", tmp_path / "out.json", "--plots", tmp_path / "plots",
            "--report", tmp_path / "report.html")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out.json").read_text())
    keys = {"Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2"}
    assert set(doc["parameters"]) == keys and set(doc["uncertainty"]) == keys and set(doc["identifiable"]) == keys
    assert {"rms_error", "nrmse"} <= set(doc["fit"]) and isinstance(doc["diagnosis"], list)
    assert abs(doc["parameters"]["Fc"] / 105.0 - 1) < 0.03
    for png in ("map.png", "presliding.png", "inertia_effect.png"):
        assert (tmp_path / "plots" / png).stat().st_size > 10_000
    assert "<img" in (tmp_path / "report.html").read_text()


def test_inertia_option_overrides_metadata(tmp_path):
    rec = good_record(tmp_path)
    rec.meta["inertia"] = 1.0  # wrong on purpose
    csv = tmp_path / "r.csv"
    rec.to_csv(csv)
    r = run("analyze", csv, "--no-diagnosis", "--inertia", "30", "--json", tmp_path / "o.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "o.json").read_text())
    assert doc["inertia"] == 30.0 and abs(doc["parameters"]["Fc"] / 105.0 - 1) < 0.03


def _bad(tmp_path, text, name="bad.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


HEADER = "# inertia: 1.0\nt,tau,q\n"


@pytest.mark.parametrize("case,content,expect", [
    ("missing column", "# inertia: 1\nt,tau\n0,1\n0.001,2\n", "missing column 'q'"),
    ("non-numeric", HEADER + "0,1,0\n0.001,abc,0\n" * 6, "not numeric"),
    ("nan", HEADER + "".join(f"{i/1000},1,nan\n" for i in range(20)), "no row holds a number in every one of t, tau, q"),
    ("time not increasing", HEADER + "".join(f"{(i if i != 7 else 3)/1000},{i},{i}\n" for i in range(20)), "not increasing"),
    # uneven time is resampled now; split at gaps into pieces too short to filter, it is refused
    ("gaps", HEADER + "".join(f"{i / 1000 + 0.05 * (i // 3)},{np.sin(i)},{i}\n" for i in range(60)), "segments too short"),
    ("constant position", HEADER + "".join(f"{i/1000},{np.sin(i/50)},0.5\n" for i in range(400)), "position is constant"),
    ("empty", "", "no header"),
    ("no header line", "".join(f"{i/1000},{np.sin(i/50)},{i}\n" for i in range(40)),
     "the file has no header line (3 columns); map its columns by number, --columns t=1,tau=2,q=3"),
])
def test_bad_records_give_one_line_and_exit_2(tmp_path, case, content, expect):
    r = run("analyze", _bad(tmp_path, content))
    assert r.returncode == 2, (case, r.stdout, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and expect in lines[0], (case, r.stderr)
    assert "Traceback" not in r.stderr


def test_too_short_and_never_sliding_records(tmp_path):
    spec = PRESETS["j3"]
    short = simulate_record(spec, *spec.excitation, duration=5.0, seed=1).record  # 1.25 cycles
    stuck = simulate_record(spec, 0.7 * spec.friction.Fs, 0.25, duration=12.0, seed=1).record
    for rec, expect in ((short, "at least 2 are needed"), (stuck, "never reaches sliding")):
        p = tmp_path / "r.csv"
        rec.to_csv(p)
        r = run("analyze", p)
        assert r.returncode == 2 and expect in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_missing_file_and_unknown_effect(tmp_path):
    r = run("analyze", tmp_path / "nope.csv")
    assert r.returncode == 2 and "no such file" in r.stderr
    rec = good_record(tmp_path)
    p = tmp_path / "r.csv"
    rec.to_csv(p)
    r = run("analyze", p, "--add", "friction_gremlin")
    assert r.returncode == 2 and "known effects:" in r.stderr and "cogging" in r.stderr
    r = run("simulate", "--joint", "j9", "-o", tmp_path / "x.csv")
    assert r.returncode == 2 and "unknown joint preset" in r.stderr
    r = run("simulate", "--effect", "cogging:amplitude=1", "-o", tmp_path / "x.csv")
    assert r.returncode == 2 and "missing parameter 'pitch'" in r.stderr
