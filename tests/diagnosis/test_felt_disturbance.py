"""An inertia error under a disturbance the joint felt (independent simulator, process noise the
record does not hold).  A model whose inertia is lower shows less of such a disturbance, so an
inertia error, a torque lag and gravity, which differ in little else under a torque sine, can
swap (``bench.rounds.hidden_calls``): the report must then say it was a close call, and an
inertia error that only makes the model lighter than the error it removed must say it may only
hide the disturbance (``bench.rounds.lighter_text``), and one that made it over 40 % lighter
is not credited at all (``bench.rounds.far_lighter``, 2026-12-01).

Measured on tuning seeds 1970-1999 (2026-11-29): heavier joints were told as a torque lag or
gravity on 7 of 7, the inertia error a close call on 6 of them; lighter ones named on 6 of 6,
within 4 % of the truth, none with the note; both spurious inertia errors beside a true torque
lag carried the note.  The seeds here (5671-5678) were not looked at while building it; run
once: the lighter ones named within 3.5 %, two heavier ones torque lags with the inertia error
their close call, and j2's 15 % at 2 % of Fc (5672) unnamed with nothing left, the miss the bar
allows.  The notes' arithmetic is held in test_rounds.py."""
import dataclasses

from bench.analysis import analyze_record
from bench.rounds import CHECK_INERTIA
from independent_joint import independent_record
from virtual_drives.presets import PRESETS

NOTE = "lighter and the held-out error fell by less"


def _analysis(joint, seed, *, ratio=1.0, dist=0.015, lag=0.0):
    spec = PRESETS[joint]
    felt = dataclasses.replace(spec, inertia=spec.inertia * ratio)
    rec, _ = independent_record(felt, seed=seed, disturbance=dist * spec.friction.Fc,
                                physics=dict(lag=lag) if lag else None)
    rec.meta["inertia"] = spec.inertia        # the joint is declared at its nominal inertia
    return spec, analyze_record(rec).report()


CASES = [("j1", 5671, 1.2, 0.015), ("j2", 5672, 1.15, 0.02), ("j3", 5673, 1.25, 0.01),
         ("j1", 5674, 0.85, 0.015), ("j2", 5675, 0.8, 0.01), ("j3", 5676, 0.8, 0.02)]


def test_an_inertia_error_under_a_felt_disturbance_is_named_or_said_to_be_a_close_call():
    """Nothing left; the inertia error named (within 10 %, without the note) or the named
    effect's close call, on 5 of 6."""
    missed = []
    for joint, seed, ratio, dist in CASES:
        spec, doc = _analysis(joint, seed, ratio=ratio, dist=dist)
        top = doc["diagnosis"][0]
        left = doc["unexplained"]
        # structure left only with the carried-torque hint, which names the inertia
        # (``bench.load_torque``: within a motion M q'' follows the torque as mu |tau| does)
        assert not left["structured"] or CHECK_INERTIA in " ".join(left["look_for"]), (seed, left["evidence"])
        if top["effect"] == "inertia_error" and top["significant"]:
            truth = spec.inertia * (ratio - 1.0)
            assert abs(doc["final"]["parameters"]["inertia_error"] / truth - 1) < 0.10, (seed, doc["final"])
            assert NOTE not in top["evidence"], (seed, top["evidence"])
        elif "inertia_error" not in [c["effect"] for c in top["close_call"]]:
            missed.append((seed, top["effect"], top["close_call"]))
        else:
            assert "differs from this one's" in top["evidence"] and "check the declared inertia" in top["evidence"]
    assert len(missed) <= 1, missed


def test_a_true_torque_lag_under_a_felt_disturbance_is_named_first():
    """The lag named first, and no inertia error credited beside it: one that made the model
    over 40 % lighter while its held-out error fell by less than that ratio only hid the
    disturbance (``bench.rounds.far_lighter``).  Before, it was credited with a note on 3 of 4
    tuning records (1970-1973) and on j1 and j4 of the fresh seeds 9764-9767 (-55 % and -69 %
    of the declared inertia)."""
    for joint, seed in (("j1", 5677), ("j4", 5678), ("j1", 9764), ("j2", 9765), ("j3", 9766), ("j4", 9767)):
        _, doc = _analysis(joint, seed, lag=0.005)
        credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        assert doc["diagnosis"][0]["effect"] == "torque_lag", (seed, doc["diagnosis"][:2])
        assert "inertia_error" not in credited, (seed, doc["final"])
        assert not doc["unexplained"]["structured"], (seed, doc["unexplained"]["evidence"])
