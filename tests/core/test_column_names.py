"""Columns named as loggers name them (bench.column_names): with no --columns, a ROS
joint_states export's position/velocity/effort, a drive's CiA 402 object names or a plain
time,position,torque log are read, and the report says what was taken by name; two columns
that could each be the torque keep asking for a mapping.  Fresh seed 10238 (j3, 20 s)."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from bench.cli import app
from bench.column_names import default_mapping
from bench.errors import InputError
from bench.readers import REQUIRED, ROLES, read_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS

J3 = PRESETS["j3"]


@pytest.fixture(scope="module")
def rec():
    return simulate_record(J3, *J3.excitation, duration=20.0, seed=10238).record


def _log(rec, header: str, deg: bool = False) -> str:
    """No '#' lines: a logger's CSV, its columns in the order t, q, qd, tau."""
    k = 180 / np.pi if deg else 1.0
    qd = np.gradient(rec.q, rec.t)
    rows = (f"{t:.6f},{q * k:.10g},{v * k:.8g},{x:.9g}" for t, q, v, x in zip(rec.t, rec.q, qd, rec.tau))
    return header + "\n" + "\n".join(rows) + "\n"


def test_a_joint_states_export_is_analysed_without_a_mapping(rec, tmp_path):
    p = tmp_path / "joint_states.csv"
    p.write_text(_log(rec, "time,position,velocity,effort"))
    out = tmp_path / "r.json"
    res = CliRunner().invoke(app, ["analyze", str(p), "--inertia", "30", "--joint-type", "revolute",
                                   "--no-diagnosis", "--json", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["input"]["columns"] == {"t": "time", "tau": "effort", "q": "position", "qd": "velocity"}
    said = [w for w in doc["warnings"] if "taken by their names" in w]
    assert len(said) == 1 and "'effort' as torque" in said[0], doc["warnings"]
    p_ = doc["parameters"]
    for k in ("Fc", "Fs", "sigma2"):
        assert abs(p_[k] / getattr(J3.friction, k) - 1) < 0.05, (k, p_[k])


def test_drive_object_names_with_units_are_read_in_their_units(rec):
    raw = _log(rec, "Time [s],Position actual value [deg],Velocity actual value [deg/s],Torque actual value [N*m]",
               deg=True)
    got = read_record(raw.encode(), name="drive.csv", inertia=30.0)
    np.testing.assert_allclose(got.q, rec.q, atol=1e-8)
    assert got.reading["columns_by_name"]["q"] == "Position actual value [deg]"
    assert got.reading["header_units"]["taken"]["q"] == "deg"


def test_a_role_named_by_its_own_name_wins_and_is_not_said(rec):
    mapping, by_name, _ = default_mapping(["t", "tau", "q", "position", "velocity"], ROLES, REQUIRED)
    assert mapping == {"t": "t", "tau": "tau", "q": "q", "qd": "velocity"} and by_name == {"qd": "velocity"}


@pytest.mark.parametrize("header,role", [("time,position,torque,effort", "tau"),       # which one?
                                         ("time,position,torque_cmd,torque_measured", "tau"),
                                         ("time,pos,angle,effort", "q")])
def test_a_column_that_is_not_named_one_way_is_left_to_the_user(rec, header, role):
    raw = _log(rec, header)
    with pytest.raises(InputError) as err:
        read_record(raw.encode(), name="log.csv", inertia=30.0)
    assert str(err.value).startswith(f"log.csv: missing column '{role}' (header is: {header.replace(',', ', ')})"), \
        str(err.value)


def test_a_velocity_in_another_unit_found_by_name_is_set_aside_and_mapped_is_refused(rec, tmp_path):
    """A drive logs its speed in rpm beside a position in rad: taken by our guess, the speed
    is set aside (the position alone serves) and said; mapped by the user, it is refused with
    the unit it looks like."""
    rpm = 60 / (2 * np.pi)
    body = _log(rec, "time,position,velocity,torque").splitlines()
    body = [body[0]] + [",".join(f"{float(x) * rpm:.8g}" if i == 2 else x for i, x in enumerate(ln.split(",")))
                        for ln in body[1:]]
    p = tmp_path / "drive.csv"
    p.write_text("\n".join(body) + "\n")
    out = tmp_path / "r.json"
    runner = CliRunner()
    res = runner.invoke(app, ["analyze", str(p), "--inertia", "30", "--no-diagnosis", "--json", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["input"]["velocity_from"].startswith("q (the column 'velocity' is 9.55 times"), doc["input"]
    said = [w for w in doc["warnings"] if "as rpm against rad would be, and was set aside" in w]
    assert len(said) == 1 and not any("'velocity' as velocity" in w for w in doc["warnings"]), doc["warnings"]
    assert abs(doc["parameters"]["Fc"] / J3.friction.Fc - 1) < 0.05, doc["parameters"]
    res = runner.invoke(app, ["analyze", str(p), "--inertia", "30", "--columns", "t=time,tau=torque,q=position,qd=velocity"])
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and len(lines) == 1 and "9.55 times the derivative of q, as rpm against rad would be" in lines[0], res.output


def test_a_unit_after_an_underscore_is_read_mapped_or_not(rec):
    """Lab scripts name columns "t_s, q_deg, tau_Nm": read in those units, as "q [deg]" is;
    "q_m" is a motor's position as often as one in metres, so it says no unit."""
    raw = _log(rec, "t_s,q_deg,dq_deg_s,tau_Nm", deg=True).encode()
    got = read_record(raw, name="lab.csv", inertia=30.0)
    np.testing.assert_allclose(got.q, rec.q, atol=1e-8)
    assert got.reading["columns"] == {"t": "t_s", "tau": "tau_Nm", "q": "q_deg", "qd": "dq_deg_s"}
    assert got.reading["header_units"]["taken"] == {"t": "s", "tau": "N*m", "q": "deg"}
    mapped = read_record(raw.replace(b"q_deg", b"joint_angle_deg", 1), name="lab.csv", inertia=30.0,
                         columns="t=t_s,tau=tau_Nm,q=joint_angle_deg")
    np.testing.assert_allclose(mapped.q, rec.q, atol=1e-8)
    mapping, _, _ = default_mapping(["t", "tau", "q_m", "q_l"], ROLES, REQUIRED)
    assert mapping["q"] == "q"          # neither taken: the reader then says q is missing


def test_a_velocity_column_stating_its_own_unit_is_converted_by_it(rec):
    """A drive logs degrees and rpm, each saying so: the speed is converted by its own unit
    (it was scaled by the position's, 6x off, and refused or set aside)."""
    qd = np.gradient(rec.q, rec.t)
    rows = "\n".join(f"{t:.6f},{np.degrees(q):.10g},{v * 30 / np.pi:.8g},{x:.9g}"
                     for t, q, v, x in zip(rec.t, rec.q, qd, rec.tau))
    for header in ("time [s],angle [deg],speed [rpm],torque [Nm]", "t_s,q_deg,dq_rpm,tau_Nm"):
        got = read_record(f"{header}\n{rows}\n".encode(), name="drive.csv", inertia=30.0)
        np.testing.assert_allclose(got.qd, qd, rtol=1e-7, atol=1e-9)
        assert got.reading["units"]["velocity"] == {"from": "rpm", "to": "rad/s", "factor": np.pi / 30}
        assert got.reading["columns"]["qd"] == header.split(",")[2]


def test_a_velocity_unit_of_the_other_joint_type_is_never_read_as_this_ones(tmp_path):
    """A ball screw's log: the carriage in mm, the motor's speed in rpm.  The rpm column was
    scaled by rpm's factor and labelled m/s; found by name it is now set aside (the position
    serves) and said, mapped it is refused.  A velocity in mm/s beside unlabelled columns makes
    the joint prismatic, as a position in mm does; a header whose units disagree on the joint
    type (degrees beside newtons) is refused naming both.  Fresh seed 10251 (linear stage)."""
    spec = PRESETS["linear"]
    lin = simulate_record(spec, *spec.excitation, duration=12.0, seed=10251).record
    qd = np.gradient(lin.q, lin.t)
    rows = "\n".join(f"{t:.6f},{1e3 * q:.10g},{v * 30 / np.pi * 200:.8g},{x:.9g}"
                     for t, q, v, x in zip(lin.t, lin.q, qd, lin.tau))
    p = tmp_path / "screw.csv"
    p.write_text(f"time [s],position [mm],speed [rpm],force [N]\n{rows}\n")
    out = tmp_path / "r.json"
    runner = CliRunner()
    res = runner.invoke(app, ["analyze", str(p), "--inertia", repr(spec.inertia), "--no-diagnosis", "--json", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["input"]["velocity_from"] == "q" and "velocity" not in doc["units"]["conversions"], doc["input"]
    assert any("the velocity was taken from the position: the column 'speed [rpm]' is in rpm" in w
               for w in doc["warnings"]), doc["warnings"]
    assert not any("'speed [rpm]' as velocity" in w for w in doc["warnings"]), doc["warnings"]
    assert abs(doc["parameters"]["Fc"] / spec.friction.Fc - 1) < 0.05, doc["parameters"]
    with pytest.raises(InputError, match=r"velocity column is in rpm, not a unit for a prismatic joint .*; "
                                         r"give it in one of them, or leave qd out$"):
        read_record(p, inertia=spec.inertia, columns="t=time [s],tau=force [N],q=position [mm],qd=speed [rpm]")
    # mm/s alone says the joint is linear; read as revolute it was 1e-3 "rad/s"
    si = "\n".join(f"{t:.6f},{x:.9g},{q:.12g},{1e3 * v:.8g}" for t, q, v, x in zip(lin.t, lin.q, qd, lin.tau))
    got = read_record(f"t,tau,q,qd [mm/s]\n{si}\n".encode(), name="mm_s.csv", inertia=spec.inertia)
    assert got.meta["joint_type"] == "prismatic" and got.reading["header_units"]["taken"] == {"joint_type": "prismatic"}
    np.testing.assert_allclose(got.qd, qd, rtol=1e-7, atol=1e-12)
    with pytest.raises(InputError, match=r"mm/s, not a unit for a revolute joint .*; give it in one of them, "
                                         r"or leave qd out$"):
        read_record(f"t,tau [N*m],q,qd [mm/s]\n{si}\n".encode(), name="v.csv", inertia=spec.inertia)
    # a position unit given as an option, the joint type left at its default: the type is the suspect
    with pytest.raises(InputError, match=r"position_unit 'mm' is not one for a revolute joint .*; it is one for a "
                                         r"prismatic joint: give --joint-type prismatic if the joint is one$"):
        read_record(f"t,tau,q,qd\n{si}\n".encode(), name="o.csv", inertia=spec.inertia, position_unit="mm")
    with pytest.raises(InputError, match=r"the header's units disagree on the joint type \(q in deg: revolute; "
                                         r"tau in N: prismatic\): give --joint-type revolute or prismatic"):
        read_record("t,tau [N],q [deg]\n0,1,2\n0.001,1,2\n".encode(), name="mixed.csv", inertia=1.0)


def test_a_mapped_name_may_leave_out_the_unit_its_column_states(rec):
    """``--columns t=time,tau=torque,q=angle`` on a header "time [s], angle [deg], ...": each
    name the one column whose name before its unit it is, read in that unit (it was refused
    as "no column 'time'"); two columns of that name in different units stay refused."""
    raw = _log(rec, "time [s],angle [deg],velocity [deg/s],torque [N*m]", deg=True).encode()
    got = read_record(raw, name="lab.csv", inertia=30.0, columns="t=time,tau=torque,q=angle")
    np.testing.assert_allclose(got.q, rec.q, atol=1e-8)
    assert got.reading["columns"]["q"] == "angle [deg]"
    both = _log(rec, "t,q [deg],q [rad],tau", deg=True).encode()
    with pytest.raises(InputError, match=r"no column 'q' \(for q\); the file's columns: t, q \[deg\], q \[rad\], tau"):
        read_record(both, name="two.csv", inertia=30.0, columns="t=t,tau=tau,q=q")
