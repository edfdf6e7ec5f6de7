"""One joint out of a log of several (``bench analyze --joint``, bench.joint_columns), and the
names robotics tools give columns (PlotJuggler's paths, rostopic's %time and field.*): a
Franka-like log, a `rostopic echo -p` export and PlotJuggler's CSV are read without a mapping,
and a log of several joints read without --joint is refused naming its joints.  Fresh seed
10241 (j4, 20 s); the shapes were tried on j3 (seed 1960) before these tests were written."""
import json
from datetime import datetime, timezone

import numpy as np
import pytest
from typer.testing import CliRunner

from bench.cli import app
from bench.column_names import default_mapping
from bench.errors import InputError
from bench.joint_columns import joint_columns, labels_in
from bench.readers import REQUIRED, ROLES
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS

J4 = PRESETS["j4"]
EPOCH = 1_764_000_000


@pytest.fixture(scope="module")
def rec():
    return simulate_record(J4, *J4.excitation, duration=20.0, seed=10241).record


def _analyze(path, *args):
    out = path.parent / (path.stem + ".json")
    res = CliRunner().invoke(app, ["analyze", str(path), "--inertia", str(J4.inertia), "--joint-type", "revolute",
                                   "--no-diagnosis", "--json", str(out), *args])
    return res, (json.loads(out.read_text()) if res.exit_code == 0 else None)


def _same_friction(doc):
    p = doc["parameters"]
    for k in ("Fc", "Fs", "sigma2"):
        assert abs(p[k] / getattr(J4.friction, k) - 1) < 0.05, (k, p[k])


def _rows(rec, joint: int, joints: int):
    """Per sample: (t, q of every joint, qd of every joint, tau of every joint), the record's
    joint at ``joint``, the others standing still with torques of their own."""
    qd = np.gradient(rec.q, rec.t)
    for t, q, v, x in zip(rec.t, rec.q, qd, rec.tau):
        qs = [0.1 * i for i in range(joints)]
        vs = [0.0] * joints
        xs = [5.0 + i for i in range(joints)]
        qs[joint], vs[joint], xs[joint] = q, v, x
        yield t, qs, vs, xs


def test_a_franka_log_gives_the_joint_asked_for_and_names_its_joints_when_not_asked(rec, tmp_path):
    p = tmp_path / "franka.csv"
    head = ["time"] + [f"{k}{i}" for k in ("q", "dq", "tau_J") for i in range(7)]
    p.write_text(",".join(head) + "\n" + "\n".join(
        f"{t:.6f}," + ",".join(f"{a:.10g}" for a in qs + vs + xs) for t, qs, vs, xs in _rows(rec, 3, 7)) + "\n")
    res, doc = _analyze(p, "--joint", "3")
    assert res.exit_code == 0, res.output
    assert doc["input"]["joint"] == "3"
    assert doc["input"]["columns"] == {"t": "time", "tau": "tau_J3", "q": "q3", "qd": "dq3"}
    assert any(w.startswith("no column mapping was given: joint 3's columns 'tau_J3' as torque")
               for w in doc["warnings"]), doc["warnings"]
    _same_friction(doc)
    res, _ = _analyze(p)
    assert res.exit_code == 2
    assert "a log of several joints (0, 1, 2, 3, 4, 5, 6): choose one with --joint N" in res.output, res.output


def _rostopic(rec, path, start_ns: int):
    """`rostopic echo -p /joint_states` of three joints, its stamps counting ns from ``start_ns``:
    %time (when received) and field.header.stamp (when sampled)."""
    head = ("%time,field.header.seq,field.header.stamp,field.header.frame_id,field.name0,field.name1,field.name2,"
            "field.position0,field.position1,field.position2,field.velocity0,field.velocity1,field.velocity2,"
            "field.effort0,field.effort1,field.effort2")
    body = []
    for i, (t, qs, vs, xs) in enumerate(_rows(rec, 2, 3)):
        ns = start_ns + int(round(t * 1e9))
        body.append(f"{ns + 250_000 + 7_000 * (i % 5)},{i},{ns},base,a,b,c," + ",".join(f"{a:.10g}" for a in qs + vs + xs))
    path.write_text(head + "\n" + "\n".join(body) + "\n")
    return path


def test_a_rostopic_export_is_read_on_its_sample_stamps_in_ns(rec, tmp_path):
    """The stamp is the time, its unit (ns since 1970) read off its magnitude and told; with
    the unit given nothing is guessed; the same counts from 0 name no date, and their refusal
    names ns."""
    p = _rostopic(rec, tmp_path / "joint_states.csv", EPOCH * 10**9)
    res, doc = _analyze(p, "--joint", "2")
    assert res.exit_code == 0, res.output
    assert doc["input"]["columns"] == {"t": "field.header.stamp", "tau": "field.effort2",
                                       "q": "field.position2", "qd": "field.velocity2"}
    assert doc["input"]["epoch_time"]["unit"] == "ns" and doc["units"]["conversions"]["time"]["from"] == "ns"
    when = datetime.fromtimestamp(EPOCH, timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    assert any(w.startswith(f"the time column counts ns since 1970 (from {when} UTC)") for w in doc["warnings"]), doc["warnings"]
    _same_friction(doc)
    res, doc = _analyze(p, "--joint", "2", "--time-unit", "ns")
    assert res.exit_code == 0 and "epoch_time" not in doc["input"], res.output
    _same_friction(doc)
    res, _ = _analyze(_rostopic(rec, tmp_path / "from_zero.csv", 0), "--joint", "2")
    assert res.exit_code == 2 and "in ns it is a 1 ms step: --time-unit ns" in res.output, res.output


def test_a_plotjuggler_export_of_one_joint_needs_no_mapping(rec, tmp_path):
    p = tmp_path / "pj.csv"
    p.write_text("__time,/joint_states/joint4/effort,/joint_states/joint4/position,/joint_states/joint4/velocity\n"
                 + "\n".join(f"{EPOCH + t:.6f},{xs[0]:.10g},{qs[0]:.10g},{vs[0]:.10g}"
                             for t, qs, vs, xs in _rows(rec, 0, 1)) + "\n")
    res, doc = _analyze(p)
    assert res.exit_code == 0, res.output
    assert doc["input"]["columns"]["t"] == "__time" and doc["input"]["columns"]["tau"] == "/joint_states/joint4/effort"
    _same_friction(doc)


PJ = ["__time"] + [f"/joint_states/panda_joint{i}/{k}" for i in (1, 2, 3, 4) for k in ("effort", "position", "velocity")]


@pytest.mark.parametrize("label", ["panda_joint4", "4", "PANDA_JOINT4"])
def test_a_joint_by_its_name_or_number_among_paths(label):
    mapping, shared, of_joint = default_mapping(PJ, ROLES, REQUIRED, label)
    assert mapping == {"t": "__time", "tau": PJ[10], "q": PJ[11], "qd": PJ[12]}
    assert shared == {"t": "__time"} and set(of_joint) == {"tau", "q", "qd"}


UR_PJ = ["__time"] + [f"/joint_states/{j}_joint/{k}" for j in ("shoulder_pan", "shoulder_lift", "elbow")
                       for k in ("position", "velocity", "effort")]


def test_joints_named_by_words_alone_are_listed_by_their_names():
    """A UR's joint_states through PlotJuggler: no numbers, so the path's folders name the
    joints; "joint_states", which holds them all, is not one of them."""
    assert labels_in(UR_PJ) == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"]
    assert labels_in(PJ) == ["1", "2", "3", "4"]     # numbered: the numbers, not panda_joint1..4
    one = [n for n in UR_PJ if "elbow" in n or n == "__time"]
    assert labels_in(one) == ["elbow_joint"]          # one joint, in joint_states/: not two
    mapping, _, _ = default_mapping(UR_PJ, ROLES, REQUIRED, "elbow_joint")
    assert mapping == {"t": "__time", "q": UR_PJ[7], "qd": UR_PJ[8], "tau": UR_PJ[9]}


def test_a_log_of_joints_named_by_words_is_refused_naming_them(rec, tmp_path):
    p = tmp_path / "ur.csv"
    p.write_text(",".join(UR_PJ) + "\n" + "\n".join(
        f"{EPOCH + t:.6f}," + ",".join(f"{a:.10g}" for i in range(3) for a in (qs[i], vs[i], xs[i]))
        for t, qs, vs, xs in _rows(rec, 1, 3)) + "\n")
    res, _ = _analyze(p)
    assert res.exit_code == 2
    assert ("a log of several joints (shoulder_pan_joint, shoulder_lift_joint, elbow_joint): choose one "
            "with --joint NAME") in res.output, res.output
    res, doc = _analyze(p, "--joint", "shoulder_lift_joint")
    assert res.exit_code == 0, res.output
    _same_friction(doc)


@pytest.mark.parametrize("names,label,want", [
    (["t", "q3", "q13", "tau3", "tau13"], "3", {"q": "q3", "tau": "tau3"}),    # a whole number only
    (["t", "q3", "q13", "tau3", "tau13"], "13", {"q": "q13", "tau": "tau13"}),
    (["t", "position[2]", "position[3]", "effort[2]", "effort[3]"], "3", {"q": "position[3]", "tau": "effort[3]"}),
    (["t", "joint_3_position", "joint_3_torque", "joint_4_position", "joint_4_torque"], "3",
     {"q": "joint_3_position", "tau": "joint_3_torque"}),
    (["t", "J3 Position [deg]", "J3 Torque [Nm]", "J4 Position [deg]", "J4 Torque [Nm]"], "3",
     {"q": "J3 Position [deg]", "tau": "J3 Torque [Nm]"}),
    (["t", "q_3", "tau_3", "q_4", "tau_4"], "3", {"q": "q_3", "tau": "tau_3"}),
    (["t", "effort(1)", "effort(2)", "pos(1)", "pos(2)"], "1", {"q": "pos(1)", "tau": "effort(1)"}),
])
def test_a_joints_columns_in_the_ways_loggers_number_them(names, label, want):
    mapping, _, _ = default_mapping(names, ROLES, REQUIRED, label)
    assert {r: mapping[r] for r in want} == want and mapping["t"] == "t"
    assert len(labels_in(names)) == 2


def test_a_joint_no_column_names_and_one_beside_a_mapping_are_refused(rec, tmp_path):
    with pytest.raises(InputError, match=r"^--joint 9: no column names that joint \(columns: t, q3, tau3\)$"):
        joint_columns(["t", "q3", "tau3"], "9")
    with pytest.raises(InputError, match="give the joint's number or name"):
        joint_columns(["t", "q3", "tau3"], "q 3")
    p = tmp_path / "two.csv"
    p.write_text("t,q3,tau3\n" + "\n".join(f"{t:.6f},{q:.10g},{x:.10g}" for t, q, x in zip(rec.t, rec.q, rec.tau)))
    res, _ = _analyze(p, "--joint", "3", "--columns", "t=t,tau=tau3,q=q3")
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and len(lines) == 1 and "with --columns give the columns' full names" in lines[0], res.output
    res, _ = _analyze(p, "--joint", "9")      # through the reader: the file named first
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and lines == [f"error: {p}: --joint 9: no column names that joint (columns: t, q3, tau3)"], res.output


def test_a_matlab_matrix_of_joints_gives_its_column_and_its_index_is_no_unit(rec, tmp_path):
    """A .mat of N x 3 matrices (q, dq, tau): their columns q(1)..q(3) are joints, not one
    column with a unit "(1)" -- read so before, the first joint's was taken as q."""
    from scipy.io import savemat

    from bench.header_units import split_unit
    from bench.readers import read_record
    n = len(rec.t)
    rows = list(_rows(rec, 1, 3))
    q, qd, tau = (np.array([r[k] for r in rows]) for k in (1, 2, 3))
    assert q.shape == (n, 3)
    for path, data in ((tmp_path / "m.mat", {"t": rec.t, "q": q, "dq": qd, "tau": tau}),
                       (tmp_path / "s.mat", {"log": {"time": rec.t, "position": q, "velocity": qd, "effort": tau}})):
        savemat(path, data)
        got = read_record(path, inertia=J4.inertia, joint="2")
        np.testing.assert_allclose(got.q, rec.q, atol=1e-9)
        np.testing.assert_allclose(got.tau, rec.tau, atol=1e-9)
        assert not got.reading.get("stated_units"), got.reading
        with pytest.raises(InputError, match=r"a log of several joints \(1, 2, 3\): choose one with --joint N"):
            read_record(path, inertia=J4.inertia)
    assert split_unit("q(2)") == ("q(2)", None) and split_unit("q (deg)") == ("q", "deg")


def test_a_ur_rtde_recording_and_camel_case_names(rec, tmp_path):
    """UR's RTDE recorder (space-delimited; target_q beside actual_q; actual_current in
    amperes is no torque) and a KUKA-like camelCase log (MeasuredTorque beside ExternalTorque)."""
    kinds = ("target_q", "actual_q", "actual_qd", "actual_current", "actual_current_as_torque")
    head = ["timestamp"] + [f"{k}_{i}" for k in kinds for i in range(6)]
    rows = []
    for t, qs, vs, xs in _rows(rec, 2, 6):
        cur = [x / 12.0 for x in xs]
        rows.append(" ".join(f"{a:.10g}" for a in [t] + [q + 0.01 for q in qs] + qs + vs + cur + xs))
    p = tmp_path / "ur.csv"
    p.write_text(" ".join(head) + "\n" + "\n".join(rows) + "\n")
    res, doc = _analyze(p, "--joint", "2")
    assert res.exit_code == 0, res.output
    assert doc["input"]["columns"] == {"t": "timestamp", "tau": "actual_current_as_torque_2", "q": "actual_q_2",
                                       "qd": "actual_qd_2"}
    _same_friction(doc)
    old = tmp_path / "ur_old.csv"       # a recording with the current only: no torque is guessed
    old.write_text("\n".join(" ".join(ln.split()[:25]) for ln in p.read_text().splitlines()) + "\n")
    res, _ = _analyze(old, "--joint", "2")
    assert res.exit_code == 2 and "joint 2's columns (target_q_2, actual_q_2, actual_qd_2, actual_current_2) hold " \
        "no torque" in " ".join(res.output.split()), res.output
    mapping, _, _ = default_mapping(["Time", "JointPosition", "JointVelocity", "MeasuredTorque", "ExternalTorque"],
                                    ROLES, REQUIRED)
    assert mapping == {"t": "Time", "tau": "MeasuredTorque", "q": "JointPosition", "qd": "JointVelocity"}


def test_a_run_trace_of_two_joints_gives_the_one_asked_for(rec):
    """The project's own run traces (bench.traces) hold every joint: --joint picks one, as
    tau=tau_<id>,q=q_<id> did; without it the refusal says to."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    from bench.readers import read_record
    n = len(rec.t)
    table = pa.table({"t": rec.t, "segment": ["sine"] * n, "tau_j1": np.full(n, 2.0), "g_j1": np.zeros(n),
                      "q_j1": np.full(n, 0.3), "tau_j4": rec.tau + 1.5, "g_j4": np.full(n, 1.5), "q_j4": rec.q})
    buf = io.BytesIO()
    pq.write_table(table, buf)
    got = read_record(buf.getvalue(), name="trace.parquet", inertia=J4.inertia, joint="j4")
    np.testing.assert_allclose(got.tau, rec.tau, atol=1e-9)      # the host's gravity taken off
    np.testing.assert_allclose(got.q, rec.q)
    with pytest.raises(InputError, match="a run trace of joints j1, j4: choose one with --joint <joint>"):
        read_record(buf.getvalue(), name="trace.parquet", inertia=J4.inertia)
    with pytest.raises(InputError, match="--joint j2: the run trace holds joints j1, j4"):
        read_record(buf.getvalue(), name="trace.parquet", inertia=J4.inertia, joint="j2")
