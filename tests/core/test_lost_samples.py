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
