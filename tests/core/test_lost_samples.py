"""A drive's own log with lost samples (``bench.resample``): every step a whole number of the
drive's steps, so the grid falls on its clock and the torque is what it was read as.  Taken
for samples, a held command was read half a step late: the rotary motor under two tones at
2 kHz with 1 % of its rows lost read Fc +19 %, determined, structure left (tuning seed 1781)."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from independent_joint import independent_record
from tests.core.test_slow_stream import _outcome
from virtual_drives.presets import PRESETS


def _two_tones(spec, dt):
    A, fr = spec.excitation
    t = np.arange(int(round(20.0 / dt))) * dt
    return A * (0.7 * np.sin(2 * np.pi * fr * t) + 0.45 * np.sin(2 * np.pi * 2.7 * fr * t + 1.0))


@pytest.mark.parametrize("joint,seed,dt", [("rotary", 9759, 1e-3), ("j2", 9760, 5e-4)])
def test_a_drive_log_with_lost_samples_keeps_its_clock(joint, seed, dt):
    """The independent simulator's drive, its command held per step and 1 % of the rows lost
    (no jitter, no metadata): the grid is the drive's clock, the held command is found as on
    an even record, and Fc, Fs, sigma2 come within 5 % with nothing named or left."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, duration=20.0, seed=seed, dt=dt, drop=0.01,
                                disturbance=0.01 * spec.friction.Fc, torque=_two_tones(spec, dt))
    assert "torque_hold" not in rec.meta
    doc = analyze_record(rec).report()
    rs = doc["resampling"]
    assert rs["resampled"] and rs.get("on_clock") is True, rs
    assert doc["fit"]["torque_hold"] == "zoh"
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)


def test_a_jittered_logger_is_not_on_a_clock():
    """A logger's own jittered instants: resampled, its torques samples of the command."""
    spec = PRESETS["j2"]
    rec, _ = independent_record(spec, duration=8.0, seed=9761, jitter=0.3, drop=0.01)
    doc = analyze_record(rec, diagnose_effects=False).report()
    assert doc["resampling"]["resampled"] and "on_clock" not in doc["resampling"]
    assert doc["fit"]["torque_hold"] == "sample"


def _with_a_short_tail(rec, dt, tail):
    """``rec`` whose logger, after a 0.2 s stall, wrote ``tail`` s more of the motion (the
    last samples of a log that stopped): a segment of its own after the gap."""
    from bench.records import Record
    k = len(rec.t) - int(round((0.2 + tail) / dt))
    keep = np.r_[np.arange(k), np.arange(len(rec.t) - int(round(tail / dt)), len(rec.t))]
    return Record(t=rec.t[keep], tau=rec.tau[keep], q=rec.q[keep], meta=dict(rec.meta))


@pytest.mark.parametrize("joint,seed,dt,tail", [("j1", 10363, 5e-4, 0.011), ("j3", 10364, 2e-3, 0.05)])
def test_a_segment_too_short_for_the_comparison_grid_is_dropped_and_said(joint, seed, dt, tail):
    """A few milliseconds after a logger's stall at the end of a log: too short for the comparison
    grid (its step is up to 20 ms), it is dropped and reported, and the rest is analysed as the
    log without it is.  Kept, it left an empty grid segment and the breakaway count raised
    IndexError (an 11 ms tail after a standstill cut at 2 kHz, soak seed 30027)."""
    from bench.records import Record
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, duration=12.0, seed=seed, dt=dt, drop=0.002,
                                disturbance=0.01 * spec.friction.Fc)
    doc = analyze_record(_with_a_short_tail(rec, dt, tail)).report()
    rs = doc["resampling"]
    assert rs["gaps"] >= 1 and len(rs["segments_dropped"]) == 1, rs
    d = rs["segments_dropped"][0]
    assert d["t_end"] - d["t_start"] < 0.12, d
    k = rec.t < rec.t[-1] - 0.2 - tail
    alone = analyze_record(Record(t=rec.t[k], tau=rec.tau[k], q=rec.q[k], meta=dict(rec.meta))).report()
    for key in ("Fc", "Fs", "sigma2"):
        assert doc["parameters"][key] == pytest.approx(alone["parameters"][key], rel=0.005), key
    assert [e["effect"] for e in doc["diagnosis"] if e["significant"]] == \
        [e["effect"] for e in alone["diagnosis"] if e["significant"]]
    assert doc["unexplained"]["structured"] == alone["unexplained"]["structured"]


def test_an_explicit_cutoff_too_low_for_a_segment_is_one_line():
    from bench.errors import InputError
    spec = PRESETS["j2"]
    rec, _ = independent_record(spec, duration=8.0, seed=10365, drop=0.002)
    with pytest.raises(InputError, match=r"too short for the comparison grid of a 0.5 Hz cutoff.*raise --cutoff"):
        analyze_record(_with_a_short_tail(rec, 1e-3, 0.15), cutoff=0.5)


def test_a_perfect_model_replayed_across_a_logger_gap_in_a_held_pose_leaves_no_rest_in_its_floor():
    """A robot's log (j1 under a PID, point-to-point moves with dwells, a jittered logger losing
    1.35 % of its rows, a felt disturbance): some gaps fall where the joint holds its pose, and
    the next segment starts at rest with its bristles loaded.  The perfect-model replay starts
    them where the fit does; started unloaded, its residual held the whole rest -- 32 N*m on
    this seed against the record's own 7.6 (59 against 8 on soak seed 30103), a floor under
    which nothing could be called structured.  Found scanning fresh seeds 10367-10379."""
    from independent_joint import point_to_point
    from tests.diagnosis.test_independent_records import _travel
    spec = PRESETS["j1"]
    ref = point_to_point(_travel(spec), 0.5 / spec.excitation[1], 30.0, np.random.default_rng([10373, 9]))
    rec, _ = independent_record(spec, duration=30.0, seed=10373, pd=(6.0, 0.0, 1.5), reference=ref, jitter=0.34,
                                drop=0.0135, disturbance=0.011 * spec.friction.Fc, disturbance_tau=0.003)
    doc = analyze_record(rec).report()
    assert doc["resampling"]["gaps"] >= 2, doc["resampling"]
    assert doc["unexplained"]["replay_rms"] < 0.75 * doc["baseline"]["rms_error"], \
        (doc["unexplained"]["replay_rms"], doc["baseline"]["rms_error"])
