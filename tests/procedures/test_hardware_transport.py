"""`bench calibrate --transport hardware`: the drives the bench file names, as they are.

The "hardware" here is the emulated drives running in another process — a CiA 402 drive
behind a socketcand server on 127.0.0.1 and an ODrive on a pty — and the bench file the
host reads has no presets: only connection details, scaling and limits, as for real drives."""
import json
import subprocess
import sys

from procedures.config import load_bench
from virtual_drives.launch import VirtualBench
from virtual_drives.presets import PRESETS

HOST_KEYS = ("transport", "node_id", "interface", "channel", "bitrate", "host", "port", "baudrate",
             "axis", "checksum", "counts_per_unit", "rated_torque", "turns_per_unit", "inertia",
             "gravity", "position_limits", "velocity_limit", "torque_limit", "hold", "heartbeat_ms",
             "watchdog_s", "reply_timeout", "joint_type")


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(v)


def hardware_bench_file(path, joints, control_period):
    lines = ['name = "bench-in-the-next-room"', f"control_period = {control_period}", 'clock = "lockstep"', ""]
    for j in joints:
        lines += ["[[joints]]", f'id = "{j["id"]}"']
        lines += [f"{k} = {_toml_value(j[k])}" for k in HOST_KEYS if k in j]
        lines.append("")
    path.write_text("\n".join(lines))


def test_calibrate_real_transport_without_emulators(tmp_path):
    cfg = load_bench("macro4")
    with VirtualBench([cfg.joint("j1"), cfg.joint("j3")], clock="lockstep",
                      control_period=cfg.control_period, seed=61, process="subprocess") as vb:
        bench = tmp_path / "hw.toml"
        hardware_bench_file(bench, vb.joints, cfg.control_period)
        assert "preset" not in bench.read_text()
        out = tmp_path / "report.json"
        r = subprocess.run([sys.executable, "-m", "bench.cli", "calibrate", "--transport", "hardware",
                            "--bench", str(bench), "--data", str(tmp_path / "data"), "--no-plots",
                            "--json", str(out), "--rt-priority", "30"], capture_output=True, text=True,
                           timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    report = json.loads(out.read_text())
    assert report["transport"] == "hardware"
    # a lock-step bench never waits for a clock: it stays at normal priority, and says so
    assert report["scheduling"]["policy"] == "normal" and report["scheduling"]["cpus"], report["scheduling"]
    for jid in ("j1", "j3"):
        joint = report["joints"][jid]
        assert joint["status"] == "succeeded", joint
        truth = PRESETS[jid].friction.as_dict()
        found = joint["stages"]["identify"]["result"]["parameters"]
        for k, tol in (("Fc", 0.03), ("Fs", 0.03), ("sigma2", 0.03)):
            assert abs(found[k] / truth[k] - 1) <= tol, (jid, k, found[k])


def test_hardware_bench_without_limits_is_refused(tmp_path):
    bench = tmp_path / "hw.toml"
    bench.write_text('name = "x"\n[[joints]]\nid = "a"\ntransport = "canopen"\ninterface = "socketcan"\n'
                     'channel = "can0"\nnode_id = 1\n')
    r = subprocess.run([sys.executable, "-m", "bench.cli", "calibrate", "--transport", "hardware",
                        "--bench", str(bench), "--data", str(tmp_path / "d")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len([ln for ln in r.stderr.splitlines() if ln.strip()]) == 1, r.stderr
