"""Streams on rows of their own (``bench.joined_streams``): a table that holds each stream's
readings on the rows of their own instants, the other cells empty (an outer join of two
loggers, a ROS bag exported one row per message, a slower stream written every few rows)."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.joined_streams import sparse_columns
from bench.readers import read_record
from bench.records import Record
from independent_joint import independent_record
from tests.core.test_slow_stream import _outcome
from virtual_drives.presets import PRESETS


def _csv(rows) -> bytes:
    """(t, tau or None, q or None) rows, in time order, as a CSV with empty cells."""
    cell = lambda v: "" if v is None else f"{v:.12g}"
    return ("t,tau,q\n" + "".join(f"{t:.6f},{cell(a)},{cell(b)}\n" for t, a, b in sorted(rows))).encode()


def test_which_columns_are_streams_of_their_own():
    """Every tenth row, or rows of its own between the other stream's: a stream, placed on the
    torque's rows (or a stream's with 2.5x its readings).  A logger's lost samples (1 %) and a
    sensor dead for a stretch stay lost samples (None: their rows are dropped, as before)."""
    rng = np.random.default_rng(9740)
    n = 2000
    t = 1e-3 * np.arange(n)
    tau, q = np.sin(t), np.cos(t)
    every_tenth = np.where(np.arange(n) % 10 == 3, tau, np.nan)
    assert sparse_columns(Record(t=t, tau=every_tenth, q=q)) == {"rows_of": "q", "placed": ["tau"]}
    own = np.arange(n) % 5 == 1                     # the position's own rows, the torque's empty there
    assert sparse_columns(Record(t=t, tau=np.where(own, np.nan, tau), q=np.where(own, q, np.nan))) == \
        {"rows_of": "tau", "placed": ["q"]}
    # two 1 kHz loggers, the encoder's a little denser: the torque's rows are kept
    own = np.arange(n) % 2 == 1
    own[::50] = True
    assert sparse_columns(Record(t=t, tau=np.where(own, np.nan, tau), q=np.where(own, q, np.nan))) == \
        {"rows_of": "tau", "placed": ["q"]}
    lost = np.where(rng.uniform(size=n) < 0.01, np.nan, tau)
    dead = tau.copy()
    dead[n // 5: 4 * n // 5] = np.nan
    for x in (lost, dead):
        assert sparse_columns(Record(t=t, tau=x, q=q)) is None


def test_a_torque_read_slower_with_empty_cells_between_keeps_the_faster_rows():
    """A slower torque written every tenth row of the encoder's logger.  Those rows were
    dropped as lost samples and the rotary motor analysed at 100 Hz: every value but sigma2
    undetermined, Fc -67 % (tuning seed 1651).  Now each reading is placed at its row's time
    on the encoder's rows and read between: within 5 %, nothing named or left."""
    spec = PRESETS["rotary"]
    rec, _ = independent_record(spec, duration=20.0, seed=9732, disturbance=0.01 * spec.friction.Fc,
                                jitter=0.3, drop=0.005)
    text = _csv((a, b if i % 10 == 3 else None, c) for i, (a, b, c) in enumerate(zip(rec.t, rec.tau, rec.q)))
    read = read_record(text, name="joined.csv", inertia=spec.inertia, joint_type=spec.joint_type)
    assert len(read.t) > 0.9 * len(rec.t)           # the faster rows kept
    doc = analyze_record(read).report()
    ff = doc["resampling"]["filled_forward"]["tau"]
    assert ff["read_as"] == "readings, interpolated between" and ff["clock"].startswith("the file's")
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)


@pytest.mark.parametrize("joint,seed,period,pid", [("j1", 9741, 5.37e-3, False), ("linear", 9742, 4e-3, False),
                                                   ("rotary", 9743, 1e-3, True), ("linear", 9748, 5e-3, True)])
def test_a_position_on_rows_of_its_own_is_read_at_its_own_times(joint, seed, period, pid):
    """An encoder logged on its own clock, its rows between the torque logger's (an outer join
    on time, each stream's other cells empty): no row held both, and the file was refused.
    Now each position is placed at its own time on the torque's rows and interpolated between:
    nothing named or left, Fc, Fs, sigma2 within 5 %, the torque's rows kept, and the report
    says how the position was read.  The rotary motor under a PID loop with a 1 kHz encoder
    (as dense as the torque): its torque placed on the encoder's rows read as a command held,
    Fc -63 % (tuning seed 1710); the torque's rows are kept.  The linear stage under that loop
    with a 200 Hz encoder: its band was widened to 100 Hz, the encoder's Nyquist, and the
    splines between its readings named a 94-95 Hz gear spring (on this seed and 9749); the
    band now stops at a fifth of the readings' rate (``bench.wide_band``)."""
    spec = PRESETS[joint]
    dt, n_sub = 1e-3, 40
    loop = {}
    if pid:       # a 6 Hz PID tracking half the sine test's travel
        sine, _ = independent_record(spec, duration=4.0, seed=1)
        loop = dict(pd=(6.0, 0.5 * float(sine.q.max() - sine.q.min()), 1.5))
    rec, path = independent_record(spec, duration=20.0, seed=seed, disturbance=0.01 * spec.friction.Fc,
                                   jitter=0.3, drop=0.005, dt=dt, n_sub=n_sub, **loop)
    clock = np.arange(np.random.default_rng(seed).uniform(0, period), rec.t[-1], period)
    encoder = path[np.round(clock / (dt / n_sub)).astype(int), 0]       # the motor's angle then
    rows = [(a, b, None) for a, b in zip(rec.t, rec.tau)] + [(a, None, c) for a, c in zip(clock, encoder)]
    read = read_record(_csv(rows), name="outer_join.csv", inertia=spec.inertia, joint_type=spec.joint_type)
    assert len(read.t) > 0.99 * len(rec.t)
    doc = analyze_record(read).report()
    ff = doc["resampling"]["filled_forward"]
    assert doc["resampling"]["joined_streams"] == {"rows_of": "tau", "placed": ["q"]}
    assert list(ff) == ["q"] and abs(ff["q"]["rate_hz"] * period - 1) < 1e-3, ff
    assert any("position column holds readings on rows of its own" in w for w in doc["warnings"]), doc["warnings"]
    named, left, worst, errors = _outcome(doc, spec)
    assert not named and not left and worst < 0.05, (named, left, errors)


def test_streams_of_their_own_too_short_to_place_are_refused_with_what_to_do():
    """Two streams on rows of their own, one with fewer readings than a stream needs (20):
    no row holds both, and the one-line error says so and how to put them together."""
    rows = "".join(f"{i / 1000:.3f},{'' if i % 10 else 1.5 + i / 1e4},{'' if i % 10 == 0 else i / 1e5}\n"
                   for i in range(150))
    with pytest.raises(InputError) as err:
        read_record(("t,tau,q\n" + rows).encode(), name="joined.csv", inertia=1.0)
    assert "no row holds a number in every one of t, tau, q" in str(err.value)
    assert "merge_asof" in str(err.value) and "\n" not in str(err.value)


def test_streams_of_their_own_with_time_going_back_name_where():
    """The readings are looked up by time: a join whose time goes back is the error it always
    was, one line naming where."""
    t = 1e-3 * np.arange(400)
    t[300:] -= 0.05
    rows = "".join(f"{a:.4f},{'' if i % 5 else 1.5 + i / 1e4},{'' if i % 5 == 0 else i / 1e5}\n"
                   for i, a in enumerate(t))
    with pytest.raises(InputError) as err:
        read_record(("t,tau,q\n" + rows).encode(), name="joined.csv", inertia=1.0)
    assert "time is not increasing: it goes back" in str(err.value) and "\n" not in str(err.value)
