"""Property test (hypothesis): extreme and non-finite numbers at every boundary that takes
numbers from a user — ``bench simulate``'s options, ``bench analyze`` and ``POST /analyze``
on records scaled by 1e±300, truncated to nothing or a few rows, poisoned with NaN or
infinity, with absurd inertias.  The only acceptable outcomes: exit 0 with a sane record or
report (finite numbers), or exit 2 / a 4xx with one line naming the problem — never a
traceback, a 500 or a NaN-filled file.

The CLI runs in-process through ``bench.cli.run`` (the console script's own entry point, so
a traceback would surface here as an exception); ``POST /analyze`` goes to the session's
real server on loopback.  Bounded: a few dozen examples, derandomized, records of seconds.
"""
from __future__ import annotations

import contextlib
import io
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bench.cli import run as cli
from bench.records import read_csv

EXTREME = st.sampled_from([float("nan"), float("inf"), float("-inf"), -1.0, 0.0, 5e-324, 1e-300, 1e-9,
                           1e9, 1e12, 1e300, 2.0, 0.5])
pytestmark = pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning")
SETTINGS = settings(max_examples=25, derandomize=True, deadline=None, database=None,
                    suppress_health_check=list(HealthCheck))


def _cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli(argv)
    return code, out.getvalue(), err.getvalue()


def _one_line_error(code: int, err: str) -> None:
    assert code == 2, (code, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err


def _finite_csv(path) -> int:
    rows = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")][1:]
    values = np.array([[float(x) for x in r.split(",")] for r in rows])
    assert values.size and np.all(np.isfinite(values)), "a record with NaN or infinity was written"
    return len(rows)


def _sane_report(doc: dict) -> None:
    for k, v in doc["parameters"].items():
        assert isinstance(v, (int, float)) and math.isfinite(v), ("parameters", k, v)
    for k, v in doc["fit"].items():        # numbers finite (the fit also names its torque hold)
        assert not isinstance(v, float) or math.isfinite(v), ("fit", k, v)
    assert doc["fit"]["rms_error"] >= 0


@pytest.fixture(scope="module")
def base_record(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("extreme") / "j3.csv"
    code, _, err = _cli(["simulate", "--joint", "j3", "--duration", "8", "--frequency", "0.5", "--rate", "500",
                         "--seed", "5031", "-o", str(path)])
    assert code == 0, err
    return path.read_text()


@st.composite
def simulate_argv(draw):
    argv = ["simulate", "--joint", draw(st.sampled_from(["j3", "linear"]))]
    # the valid values are small so that a run that is accepted stays cheap
    numbers = {"--duration": st.sampled_from([1.0, 2.0]), "--rate": st.sampled_from([200.0, 1000.0]),
               "--amplitude": st.none(), "--frequency": st.none(), "--torque-noise": st.none(),
               "--encoder-resolution": st.none(), "--declared-inertia": st.none()}
    for opt, valid in numbers.items():
        v = draw(st.one_of(valid, EXTREME))
        if v is not None:
            argv += [opt, repr(v)]
    argv += ["--seed", str(draw(st.sampled_from([0, 5041, -1, 2**63, 2**70])))]
    if draw(st.booleans()):
        name = draw(st.sampled_from(["Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2", "delta"]))
        argv += ["--param", f"{name}={draw(EXTREME)!r}"]
    if draw(st.booleans()):
        argv += ["--effect", f"torque_offset:value={draw(EXTREME)!r}"]
    return argv


@SETTINGS
@given(argv=simulate_argv())
def test_simulate_extreme_options(tmp_path_factory, argv):
    path = tmp_path_factory.mktemp("sim") / "out.csv"
    code, _, err = _cli(argv + ["-o", str(path)])
    if code == 0:
        n = _finite_csv(path)
        duration = float(argv[argv.index("--duration") + 1]) if "--duration" in argv else 20.0
        rate = float(argv[argv.index("--rate") + 1]) if "--rate" in argv else 1000.0
        assert abs(n - duration * rate) <= 1, (n, duration, rate)
    else:
        _one_line_error(code, err)
        assert not path.exists()


TRANSFORMS = st.fixed_dictionaries({
    "column": st.sampled_from(["t", "tau", "q"]),
    "scale": st.sampled_from([1.0, 1e-300, 1e-30, 1e30, 1e300]),
    "rows": st.sampled_from([None, 0, 1, 2, 5, 11, 300]),
    "poison": st.sampled_from([None, "nan", "inf", "-inf", "1e400"]),
    "inertia": st.one_of(st.none(), EXTREME),
})


def _mangle(text: str, how: dict) -> str:
    lines = text.splitlines()
    meta = [ln for ln in lines if ln.startswith("#")]
    rows = [ln for ln in lines if ln and not ln.startswith("#")]
    header, data = rows[0], rows[1:]
    if how["rows"] is not None:
        data = data[:how["rows"]]
    col = header.split(",").index(how["column"])
    out = []
    for i, r in enumerate(data):
        cells = r.split(",")
        cells[col] = repr(float(cells[col]) * how["scale"])
        if how["poison"] is not None and i == len(data) // 2:
            cells[col] = how["poison"]
        out.append(",".join(cells))
    return "\n".join(meta + [header] + out) + "\n"


@SETTINGS
@given(how=TRANSFORMS)
def test_analyze_extreme_records(tmp_path_factory, base_record, how):
    d = tmp_path_factory.mktemp("ana")
    (d / "r.csv").write_text(_mangle(base_record, how))
    argv = ["analyze", str(d / "r.csv"), "--no-diagnosis", "--json", str(d / "r.json")]
    if how["inertia"] is not None:
        argv += ["--inertia", repr(how["inertia"])]
    code, _, err = _cli(argv)
    if code == 0:
        _sane_report(json.loads((d / "r.json").read_text()))
    else:
        _one_line_error(code, err)


@SETTINGS
@given(how=TRANSFORMS)
def test_post_analyze_extreme_records(operator, base_record, how):
    params = {"diagnose": "false"}
    if how["inertia"] is not None:
        params["inertia"] = repr(how["inertia"])
    r = operator.post("/analyze", params=params, content=_mangle(base_record, how).encode(),
                      headers={"content-type": "text/csv"}, timeout=120)
    assert r.status_code != 500 and r.status_code < 500, r.text
    if r.status_code == 200:
        _sane_report(r.json())
    else:
        assert 400 <= r.status_code < 500, r.text
        detail = r.json()["detail"]
        assert detail and "\n" not in detail and "Traceback" not in detail, detail


def test_the_untouched_record_is_analysed(base_record, tmp_path):
    """The base of the transforms is a good record: a refusal above is about the transform."""
    (tmp_path / "r.csv").write_text(base_record)
    code, _, err = _cli(["analyze", str(tmp_path / "r.csv"), "--no-diagnosis", "--json", str(tmp_path / "r.json")])
    assert code == 0, err
    _sane_report(json.loads((tmp_path / "r.json").read_text()))
    assert read_csv(tmp_path / "r.csv").inertia > 0
