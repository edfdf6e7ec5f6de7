"""A log stamped in Unix time (ROS bags and PC loggers write seconds since 1970, ~1.7e9 s)
is the same log as one stamped from zero.  At 1.7e9 s a float holds time to 0.24 us: the
grid's points, running sums over the time column (its decimation) and a lag subtracted from
the time all rounded there, so the comparison grid had repeated times (np.gradient divided by
zero, numpy's warnings on the terminal) and a fitted torque lag was quantised."""
import warnings

import numpy as np

from bench.analysis import analyze_record
from bench.records import Record
from virtual_drives.conditions import make_record
from virtual_drives.presets import PRESETS


def test_a_log_in_unix_time_is_analysed_as_the_same_log_from_zero():
    rec, _ = make_record(PRESETS["j2"], "jittered timestamps with dropped samples", 5350, duration=30.0,
                         effects=["torque_lag:delay=0.003"])
    epoch = rec.t + 1.7e9                       # the times a float at 1.7e9 s can hold
    docs = []
    for t in (epoch - 1.7e9, epoch):            # the same instants, from zero and in Unix time
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            a = analyze_record(Record(t=t, tau=rec.tau, q=rec.q, meta=dict(rec.meta)), add=["torque_lag"])
        d = np.diff(a.ident.data.c.t)
        assert d.min() > 0.5 * np.median(d), d.min()
        docs.append(a.report())
    zero, unix = docs
    for k, v in zero["parameters"].items():
        assert abs(unix["parameters"][k] / v - 1.0) < 1e-6, (k, v, unix["parameters"][k])
    assert abs(unix["final"]["rms_error"] / zero["final"]["rms_error"] - 1.0) < 1e-6
