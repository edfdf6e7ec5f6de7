"""A position in encoder counts with no unit given (bench.units.whole_number_position): read
as radians it was refused as a clock or inertia error; the refusal and the report now say
first that the column holds whole numbers only and how to give its unit.  Fresh seed 10239
(j3, 20 s, 2^20 counts a turn)."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from bench.cli import app
from bench.readers import read_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS

J3 = PRESETS["j3"]
K = 2 * np.pi / 2**20     # a 20-bit encoder: 4096 a turn is too coarse for j3 at the load (Fc +12 %)


@pytest.fixture(scope="module")
def rec():
    return simulate_record(J3, *J3.excitation, duration=20.0, seed=10239).record


def _counts(rec, tmp_path, meta=""):
    p = tmp_path / "drive.csv"
    p.write_text(meta + "t,tau,q\n" + "\n".join(f"{t:.6f},{x:.9g},{round(q / K)}"
                                                  for t, x, q in zip(rec.t, rec.tau, rec.q)) + "\n")
    return p


def test_counts_read_as_radians_are_refused_with_the_unit_to_give_first(rec, tmp_path):
    res = CliRunner().invoke(app, ["analyze", str(_counts(rec, tmp_path)), "--inertia", "30"])
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert "drive.csv: the position column holds whole numbers only" in lines[0] and "--position-unit K*rad" in lines[0], lines


def test_counts_with_their_unit_are_analysed_and_not_warned_about(rec, tmp_path):
    out = tmp_path / "r.json"
    res = CliRunner().invoke(app, ["analyze", str(_counts(rec, tmp_path)), "--inertia", "30", "--no-diagnosis",
                                   "--position-unit", f"{K!r}*rad", "--json", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert not any("whole numbers" in w for w in doc["warnings"]), doc["warnings"]
    for k in ("Fc", "Fs", "sigma2"):
        assert abs(doc["parameters"][k] / getattr(J3.friction, k) - 1) < 0.05, (k, doc["parameters"][k])


def test_a_friction_record_in_counts_is_analysed_and_warned_about(rec, tmp_path):
    """With --inertia 0 nothing differentiates twice and the fit may run: its velocities are then
    in counts per second, which the warning says."""
    friction = rec.tau - J3.inertia * np.gradient(np.gradient(rec.q, rec.t), rec.t)
    p = tmp_path / "f.csv"
    p.write_text("t,tau,q\n" + "\n".join(f"{t:.6f},{x:.9g},{round(q / K)}" for t, x, q in zip(rec.t, friction, rec.q)))
    got = read_record(p, inertia=0.0)
    assert got.reading["whole_number_position"] == (round(rec.q.min() / K), round(rec.q.max() / K))
    from bench.reading_warnings import reading_warnings
    said = [w for w in reading_warnings(got, J3.friction.Fc, 0.0) if "whole numbers only" in w]
    assert len(said) == 1 and "0.0015339808*rad for 4096 a turn" in said[0], said


def test_positions_that_are_not_whole_numbers_or_barely_move_are_not_counts(rec):
    body = "# inertia: 30\nt,tau,q\n" + "\n".join(f"{t:.6f},{x:.9g},{q:.10g}" for t, x, q in zip(rec.t, rec.tau, rec.q))
    assert "whole_number_position" not in read_record(body.encode(), name="rad.csv").reading
    few = "# inertia: 30\nt,tau,q\n" + "\n".join(f"{t:.6f},{x:.9g},{round(q * 20):d}" for t, x, q in zip(rec.t, rec.tau, rec.q))
    assert "whole_number_position" not in read_record(few.encode(), name="few.csv").reading   # 9 steps: a coarse rad
