"""Long standstills (a robot holding its pose before, between and after its moves) are cut
out like a logger's gaps; the excitation's own sticking at reversals never is
(``bench.standstill``).  Records only, no analysis: fast."""
import subprocess
import sys

import numpy as np
import pytest

from bench.resample import on_grid
from virtual_drives.conditions import make_record, recording_for
from virtual_drives.presets import PRESETS
from virtual_drives.recording import Recording

REST, DURATION = 12.0, 44.0


@pytest.mark.parametrize("joint, seed", [("j2", 5470), ("linear", 5471)])
def test_rest_before_and_after_the_motion_is_cut_out_and_reported(joint, seed):
    spec = PRESETS[joint]
    rec, truth = make_record(spec, recording_for(spec, "robot joint log", seed).with_(rest=REST), seed,
                             duration=DURATION)
    n, travel = int(0.9 * REST * 1000), np.ptp(truth.q)    # it did rest (process noise dithers it)
    assert np.ptp(truth.q[:n]) < 0.01 * travel and np.ptp(truth.q[-n:]) < 0.01 * travel
    g = on_grid(rec)
    report = g.reading["resampling"]
    cuts = report["standstills_cut"]
    # the logger's own gaps may split a rest into pieces; the cuts cover most of both rests
    # and none of the motion between them
    before = sum(c["t_end"] - c["t_start"] for c in cuts if c["t_end"] <= REST + 0.5)
    after = sum(c["t_end"] - c["t_start"] for c in cuts if c["t_start"] >= DURATION - REST - 0.5)
    assert before > 0.6 * REST and after > 0.6 * REST, cuts
    assert all(c["t_end"] <= REST + 0.5 or c["t_start"] >= DURATION - REST - 0.5 for c in cuts), cuts
    assert report["standstill_time"] == pytest.approx(before + after, rel=0.05)
    from bench.identify import prepare
    data, _ = prepare(g)
    assert data.c.rest_starts, "segments starting at rest must wait for sliding"
    # a cut sample is not in the grid: the record steps over it like a gap
    t = np.asarray(g.t)
    for c in cuts:
        assert not np.any((t > c["t_start"] + 0.05) & (t < c["t_end"] - 0.05)), c


def test_the_excitations_own_sticking_is_never_cut():
    """A torque sine just above the stiction level sticks at every reversal for a good part of
    each half cycle; a PD reference dwells at its extremes.  Neither is a standstill."""
    cut = []
    for joint, spec in PRESETS.items():
        for k, f in ((1.02, 0.5), (1.1, 1.0)):
            rec, _ = make_record(spec, Recording(amplitude=k * spec.friction.Fs, frequency=f * spec.excitation[1]),
                                 5472)
            cut += [(joint, k, f)] * ("standstills_cut" in on_grid(rec).reading.get("resampling", {}))
        for condition in ("PD closed-loop tracking", "robot joint log", "two-tone torque"):
            rec, _ = make_record(spec, condition, 5473)
            cut += [(joint, condition)] * ("standstills_cut" in on_grid(rec).reading.get("resampling", {}))
    assert not cut, cut


def test_simulate_refuses_a_rest_that_leaves_no_motion(tmp_path):
    out = subprocess.run([sys.executable, "-m", "bench.cli", "simulate", "--joint", "j2", "--excitation", "pd",
                          "--rest", "15", "--duration", "30", "-o", str(tmp_path / "r.csv")],
                         capture_output=True, text=True)
    assert out.returncode == 2, out
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--rest" in lines[0] and "Traceback" not in out.stderr, out.stderr
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.parametrize("joint, seed, share", [("j1", 5516, 0.5), ("j3", 5517, 0.7), ("linear", 5518, 0.9)])
def test_a_rest_split_by_a_logger_stall_is_one_standstill(joint, seed, share):
    """A robot holding its pose does not move while its logger stalls.  Judged apart, the rest
    before a stall was shorter than the length rule and stayed in the motion's segment, where
    at 100-125 Hz it bent the fit (tuning seed 1407 on j1: Fs fitted 0).  Here a 0.2 s stall
    lands after the motion stopped, at a ``share`` of the length rule: all of that rest is cut
    but the half reversal interval kept beside the motion (``KEEP``)."""
    from bench.standstill import KEEP, LONGER_THAN, reversal_interval
    spec = PRESETS[joint]
    rec, _ = make_record(spec, recording_for(spec, "robot joint log", seed).with_(rest=REST), seed,
                         duration=DURATION)
    t = np.asarray(rec.t)
    stopped = DURATION - REST
    into_rest = share * LONGER_THAN * reversal_interval(t, np.asarray(rec.q))
    stall = (t > stopped + into_rest) & (t < stopped + into_rest + 0.2)
    rec = type(rec)(t=t[~stall], tau=np.asarray(rec.tau)[~stall], q=np.asarray(rec.q)[~stall],
                    qd=None if rec.qd is None else np.asarray(rec.qd)[~stall], meta=dict(rec.meta))
    interval = reversal_interval(np.asarray(rec.t), np.asarray(rec.q))
    assert KEEP * interval < into_rest < LONGER_THAN * interval     # too short on its own
    g = on_grid(rec)
    kept = np.asarray(g.t)
    rest_kept = kept[(kept > stopped) & (kept < DURATION - 1.0)]
    # the rest kept after the motion: the KEEP share of an interval, plus the motion's own
    # stop (the envelope ends at `stopped`, the joint settles within a few tenths of a second)
    assert rest_kept.max(initial=stopped) < stopped + KEEP * interval + 0.6, (
        rest_kept.max(), g.reading["resampling"]["standstills_cut"])
    # the stall is counted once in the standstill's time: no more than the rests' cut spans
    report = g.reading["resampling"]
    spans = 0.0
    for rest in ([c for c in report["standstills_cut"] if c["t_end"] < stopped],
                 [c for c in report["standstills_cut"] if c["t_start"] > stopped]):
        spans += max(c["t_end"] for c in rest) - min(c["t_start"] for c in rest) + 2 * report["median_step"]
    assert report["standstill_time"] <= spans, (report["standstill_time"], spans)
