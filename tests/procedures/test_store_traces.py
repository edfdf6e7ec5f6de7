import subprocess
import sys
import threading

import numpy as np
import pytest

from bench.errors import InputError
from bench.records import read_csv
from bench.store import Store
from bench.traces import TraceWriter, export_csv, read_trace


def test_runs_states_and_recover_dead_owner(data_dir):
    s = Store(data_dir)
    a = s.create_run("excitation", config={"x": 1}, seed=4, joint_id="j1")
    assert s.get_run(a)["state"] == "running" and "0.1.0" in s.get_run(a)["software"]
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    with s._tx() as c:
        c.execute("UPDATE runs SET owner_pid=? WHERE id=?", (dead.pid, a))
    b = s.create_run("tracking")            # owned by this (live) process
    assert Store(data_dir).recover() == [a]
    assert s.get_run(a)["state"] == "interrupted" and s.get_run(b)["state"] == "running"
    s.finish_run(b, "succeeded", {"ok": True})
    assert s.list_runs(state="succeeded")[0]["result"] == {"ok": True}
    with pytest.raises(InputError):
        s.get_run("nope")


def test_documents_from_threads(data_dir):
    s = Store(data_dir)
    r = s.create_run("x")

    def emit(offset):
        for i in range(50):
            s.emit({"run_id": r, "seq": offset + i, "time": 0.0, "doc": "event", "name": "n", "data": {"i": i}})
    ts = [threading.Thread(target=emit, args=(k * 100,)) for k in range(3)]
    [t.start() for t in ts]
    [t.join() for t in ts]
    assert len(s.events(r)) == 150 and len(s.events(r, after_seq=199)) == 50


def test_compensation_switch_persists(data_dir):
    s = Store(data_dir)
    assert s.get_compensation("j1")["enabled"] is False
    with pytest.raises(InputError):
        s.set_compensation("j1", True)      # no model yet
    m1 = s.add_model("j1", {"Fc": 1.0}, {"parameters": {}}, None)
    m2 = s.add_model("j1", {"Fc": 2.0}, None, None)
    assert s.set_compensation("j1", True)["model_id"] == m2          # newest by default
    assert s.set_compensation("j1", True, m1)["model_id"] == m1
    assert Store(data_dir).get_compensation("j1") | {"updated": 0} == \
        {"joint_id": "j1", "enabled": True, "model_id": m1, "updated": 0}
    with pytest.raises(InputError):
        s.set_compensation("j2", True, m1)  # another joint's model


def test_partial_trace_readable_and_csv_export(tmp_path):
    w = TraceWriter(tmp_path / "run", ["t", "q_a", "v_a", "tau_a", "g_a"], buffer_rows=100)
    for i in range(250):
        w.append([i * 1e-3, np.sin(i * 1e-2), np.cos(i * 1e-2), 2.0 + i, 1.0], "seg")
    # not closed: only the flushed chunks exist, and they read
    part = read_trace(tmp_path / "run")
    assert part.num_rows == 200 and part.column("q_a")[5].as_py() == pytest.approx(np.sin(0.05))
    w.close()
    assert read_trace(tmp_path / "run").num_rows == 250
    out = tmp_path / "a.csv"
    export_csv(tmp_path / "run", "a", out, meta={"inertia": 2.0, "joint_type": "revolute"})
    rec = read_csv(out)
    assert len(rec.t) == 250 and rec.inertia == 2.0 and rec.tau[3] == pytest.approx(2.0 + 3 - 1.0)
