"""Joints described by their own physics ([joints.physics], no preset), made up far from the
paper's: a small SCARA wrist (0.003 kg m^2, Fc 0.05 N m) on CANopen and a heavy linear axis
(40 kg, Fc 60 N) on serial.  `bench calibrate` through the real stacks (lock-step) finds an
excitation inside the workspace that reaches sliding and identifies Fc, Fs and sigma2 within
5 %; the two-level excitation stays inside the window and slides both ways."""
import json
from pathlib import Path

import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.records import read_csv
from bench.store import Store
from procedures.config import load_bench
from procedures.excitation import SearchSettings, search
from procedures.plugs import open_drives
from procedures.rig import Rig
from procedures.waveforms import level

from test_calibrate import check_limits, check_real_stacks, run_cli

MADE_UP = Path(__file__).parent / "data" / "made_up.toml"


def test_calibrate_joints_described_by_their_physics(tmp_path):
    out = tmp_path / "r.json"
    r = run_cli("--bench", str(MADE_UP), "--data", str(tmp_path), "--json", str(out), "--seed", "5011", "--no-plots")
    assert r.exit_code == 0, r.output
    report = json.loads(out.read_text())
    cfg = load_bench(MADE_UP)
    check_real_stacks(report, cfg)        # wrist on CANopen, axis on serial
    for jid, j in report["joints"].items():
        assert j["status"] == "succeeded", j["reason"]
        search = j["stages"]["search"]["result"]
        assert search["reason"] == "accepted"
        # the default excitation is not one repeated sine: alternate cycles at two amplitudes
        assert search["waveform"] == "two_level 0.6"
        rec = read_csv(search["record"])
        ratios = _small_to_large_peaks(rec, search["frequency"])
        assert ratios == pytest.approx(0.6, abs=0.05), (jid, ratios)
        truth = cfg.joint(jid)["physics"]["friction"]
        found = j["stages"]["identify"]["result"]["parameters"]
        for k in ("Fc", "Fs", "sigma2"):
            assert abs(found[k] / truth[k] - 1) < 0.05, (jid, k, found[k], truth[k])
        assert j["stages"]["validate"]["result"]["improvement"] > 3.0, jid
    assert check_limits(Store(tmp_path), cfg) > 10000


def _small_to_large_peaks(rec, frequency: float) -> float:
    """Median peak |tau| of the small cycles over that of the large ones (whole cycles
    between torque zero crossings)."""
    phase = rec.t * frequency
    peaks = {True: [], False: []}
    for cyc in range(1, int(phase[-1] - 0.25) + 1):
        sel = (phase >= cyc - 0.75) & (phase < cyc + 0.25)
        peaks[bool(level(cyc, "two_level", 0.6) < 1)].append(np.max(np.abs(rec.tau[sel])))
    assert peaks[True] and peaks[False]
    return float(np.median(peaks[True]) / np.median(peaks[False]))


@pytest.mark.parametrize("jid,seed", [("wrist", 5021), ("axis", 5022)])
def test_two_level_excitation_breaks_the_cycle_lock_inside_the_workspace(jid, seed):
    """Not one repeated sine: alternate cycles at two amplitudes; every sample inside the
    search window; sliding in both directions on the small cycles too; the analysis reads it
    (simulated plugs: the search itself, fast)."""
    cfg = load_bench(MADE_UP)
    rig = Rig(cfg, open_drives(cfg.joints, force_simulated=True, seed=seed))
    rig.start()
    try:
        st = SearchSettings()               # the default: two_level, ratio 0.6
        res = search(rig, jid, st)
    finally:
        rig.park()
    assert res.ok, res.reason
    rec = res.record
    lo, hi = cfg.joint(jid)["position_limits"]
    margin = st.margin_fraction * (hi - lo)
    assert lo + margin <= rec.q.min() and rec.q.max() <= hi - margin
    assert _small_to_large_peaks(rec, res.frequency) == pytest.approx(0.6, abs=0.05)
    phase = rec.t * res.frequency
    v_peak = res.trials[-1].metrics["v_peak"]
    for cyc in range(1, int(phase[-1] - 0.25) + 1):   # whole cycles between torque zero crossings
        sel = (phase >= cyc - 0.75) & (phase < cyc + 0.25)
        v = np.gradient(rec.q[sel], rec.dt)
        # both directions slide on every cycle, the small ones too: well past presliding creep
        assert v.max() > 0.2 * v_peak and v.min() < -0.2 * v_peak, cyc
    doc = analyze_record(rec, inertia=rec.inertia).report()
    truth = cfg.joint(jid)["physics"]["friction"]
    for k in ("Fc", "Fs", "sigma2"):
        assert abs(doc["parameters"][k] / truth[k] - 1) < 0.05, (k, doc["parameters"][k])


def test_physics_effects_are_in_the_emulated_drive():
    """The drive simulates its physics table's hidden effects: a torque offset larger than
    breakaway (a joint pulled by a spring or a cable) moves the wrist under zero command."""
    from drivers.joint_config import complete_joint
    from virtual_drives.drive_core import DriveCore
    cfg = load_bench(MADE_UP)
    moved = {}
    for offset in (0.0, 0.1):          # N m; Fs = 0.065
        j = dict(cfg.joint("wrist"), clock="lockstep", control_period=0.001)
        j["physics"] = dict(j["physics"], effects=[f"torque_offset:value={offset}"] if offset else [])
        core = DriveCore(complete_joint(j), clock="lockstep", seed=5031)
        assert core.enable()
        q0 = core.vj.state.q
        core.set_command(0.0)
        core.step(200)
        moved[offset] = core.vj.state.q - q0
    assert abs(moved[0.0]) < 1e-6
    assert moved[0.1] < -0.01          # the offset opposes positive motion: it pulls negative
