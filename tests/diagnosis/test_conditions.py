"""Users' recording conditions: noise entering as a disturbance or on the reading, coarse
encoders, other rates, jittered loggers, friction-torque records, closed-loop motion, two tones.

"Nothing left to explain" and "this effect is missing" must both hold under every one of them.
Seeds here (5000+) were never used while tuning (tools/tune_noise_floor.py: 1000-1999)."""
import pytest

from bench.analysis import analyze_record
from bench.effects import EFFECTS
from virtual_drives.conditions import CONDITIONS, make_record
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import random_effects

from tests.record_pool import map_records

JOINTS = list(PRESETS)
CONDITION_NAMES = list(CONDITIONS)


def _within(doc, spec, tol=0.05):
    """Fc, Fs and sigma2 within 5 %, or honestly uncertain: reported not identifiable, or within
    two of their reported standard errors.  j3's sine test barely enters the Stribeck decay
    (alpha v <= 1.3): under coloured process noise Fc and alpha trade off and Fc lands 6 % off
    in some seeds (the issue's 5 % is not met there: see the README's known limits)."""
    p, f, ok, se = doc["parameters"], spec.friction, doc["identifiable"], doc["uncertainty"]
    return all(abs(p[k] / getattr(f, k) - 1.0) <= tol or not ok[k]
               or (se[k] is not None and abs(p[k] - getattr(f, k)) <= 2.0 * se[k])
               for k in ("Fc", "Fs", "sigma2"))


# Known gap, run and reported as an expected failure (README known limits): the rotary motor
# (Table I) on a 3-6 ms PC logger.  Its torque is 27x its friction (inertia-dominated), and at
# that step the chain (torque staircase sampled at the logger's times, positions interpolated
# across 1-13 ms, an 11 Hz comparison band) leaves an estimator bias of several % of Fc: the
# true parameters fit worse than biased ones (tuning seed 1209: 0.040 against 0.033 of Fc).
# Every other joint is held to the bar under that condition.
KNOWN_GAPS = {("jittered timestamps with dropped samples", "rotary")}


def _joints(condition):
    return [j for j in JOINTS if (condition, j) not in KNOWN_GAPS]


@pytest.mark.parametrize("condition", CONDITION_NAMES)
def test_clean_joints_nothing_to_explain_in_19_of_20(condition):
    misses = _misses(condition, _joints(condition))
    assert len(misses) <= 1, misses


@pytest.mark.xfail(reason="known gap, see README known limits", strict=False)
@pytest.mark.parametrize("condition, joint", sorted(KNOWN_GAPS))
def test_known_gap_nothing_to_explain(condition, joint):
    assert len(_misses(condition, [joint], seeds=5)) <= 0


def _misses(condition, joints, seeds=20, first_seed=None):
    first = 6000 + 100 * CONDITION_NAMES.index(condition) if first_seed is None else first_seed
    jobs = [(condition, joints[i % len(joints)], first + i) for i in range(seeds)]
    return [m for m in map_records(_miss, jobs) if m is not None]


def _miss(condition, joint, seed):
    """A clean joint's record under ``condition``: None when nothing is named, nothing left
    and the parameters are within 5 % (``_within``); what went wrong otherwise."""
    spec = PRESETS[joint]
    rec, _ = make_record(spec, condition, seed)
    doc = analyze_record(rec).report()
    significant = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
    if significant or doc["unexplained"]["structured"] or not _within(doc, spec):
        return (spec.name, seed, significant, doc["unexplained"]["evidence"][:120],
                {k: doc["parameters"][k] for k in ("Fc", "Fs", "sigma2")})
    return None


SLOW_LOG = "robot joint log at 100-125 Hz"


def test_robot_logs_at_100_to_125_hz_nothing_to_explain_in_19_of_20():
    """Joint states as robots publish them at 100-125 Hz (ROS, a UR's RTDE stream): PD motion,
    a friction column, a jittered logger.  Probed before this test on tuning seeds 1851-1854 at
    8 and 10 ms steps: nothing credited in 24 of 24; the rotary motor's Fc is off but reported
    not identifiable there, which `_within` accepts as honest."""
    misses = _misses(SLOW_LOG, JOINTS, first_seed=5360)
    assert len(misses) <= 1, misses


@pytest.mark.parametrize("effect, joint, seed", [("cogging", "j4", 5380), ("position_dependent_friction", "j1", 5381),
                                                 ("thermal_drift", "j3", 5382), ("direction_asymmetry", "linear", 5383)])
def test_library_effect_is_named_first_in_a_slow_robot_log(effect, joint, seed):
    _named_first(PRESETS[joint], SLOW_LOG, effect, seed)


@pytest.mark.parametrize("seed", [5384, 5385])
def test_an_inertia_error_on_the_linear_stage_logged_at_250_hz_in_closed_loop_is_named(seed):
    """The inertia-dominated linear stage under PD tracking, logged by a PC logger at ~4 ms:
    its resampled motion leaves errors that follow the motion, and the inertia error's own
    checks (nothing the acceleration's cube or the position adds) read them as physics; the mass
    error went unnamed ("unexplained") on 5 of 5 tuning seeds (1861-1890).  Counted beyond the
    perfect-model replay's error (``signal_adds``), it is named."""
    _named_first(PRESETS["linear"], _pd_logged(0.004), "inertia_error", seed)


def _pd_logged(step):
    """PD tracking, the torque column the controller's output, on a PC logger of median ``step``."""
    from virtual_drives.recording import Logger, Recording
    return Recording(excitation="pd", logger=Logger(step=step, min_step=0.75 * step, max_step=1.6 * step,
                                                    drop=0.01, gaps_per_minute=1.0))


def test_a_clean_linear_stage_logged_at_125_hz_in_closed_loop_gets_no_torque_lag():
    """A drive holds each command for its control period, and a logger samples the staircase:
    the joint moves as if the smooth torque came half a period late.  On tuning seeds 3 of 9
    clean records were given a lag of 0.53-0.60 ms; on these fresh seeds one of eight was
    (5414) before ``torque_lag.HELD_LAG``."""
    spec = PRESETS["linear"]
    credited = []
    for seed in range(5410, 5418):
        rec, _ = make_record(spec, _pd_logged(0.008), seed)
        doc = analyze_record(rec).report()
        credited += [(seed, d["effect"]) for d in doc["diagnosis"] if d["significant"]]
    assert not credited


@pytest.mark.parametrize("seed", range(5420, 5432))
def test_an_inertia_error_on_the_linear_stage_logged_at_125_hz_comes_alone(seed):
    """At 8 ms the inertia error's refit leaves Fc some 20 % low, and a Stribeck exponent
    fitted beside it took Fc to a quarter of the truth, undetermined, and was credited: on
    tuning seeds 4 of 5, on these fresh seeds 2 of 12 (5428, 5431) before an exponent had to
    leave the friction levels as well determined as it found them."""
    _named_first(PRESETS["linear"], _pd_logged(0.008), "inertia_error", seed)


@pytest.mark.parametrize("effect, joint, seed", [("inertia_error", "j1", 5440), ("torque_lag", "j1", 5441),
                                                 ("inertia_error", "j2", 5442), ("torque_lag", "j2", 5443)])
def test_on_a_friction_column_an_inertia_term_and_a_lag_are_one_measurement(effect, joint, seed):
    """A lag d of a friction reading is sigma2 d q'' while sliding and sigma1 - sigma0 d in
    presliding: to first order an inertia term left in the column.  Whichever of the two is
    named (j1's were swapped on 3 of 4 tuning records), it must measure the truth through the
    other, and the evidence must say the two cannot be told apart."""
    spec = PRESETS[joint]
    texts = random_effects(spec, [effect], seed)
    rec, truth = make_record(spec, "robot joint log", seed, effects=texts)
    doc = analyze_record(rec).report()
    top, p = doc["diagnosis"][0], doc["final"]["parameters"]
    assert top["significant"] and doc["final"]["effects"] == [top["effect"]], doc["diagnosis"][:2]
    assert "cannot be told apart" in top["evidence"], top["evidence"]
    inertia_term = p["inertia_error"] if top["effect"] == "inertia_error" else p["sigma2"] * p["torque_lag"]
    if effect == "inertia_error":
        want = spec.inertia - truth.declared_inertia
    else:
        want = p["sigma2"] * truth.torque_lag
    assert inertia_term == pytest.approx(want, rel=0.15), (texts, top["evidence"])


# every library effect under every condition the analysis handles, three effects per
# condition in rotation (so each effect meets about two conditions and a joint each time)
EFFECT_NAMES = [e for e in EFFECTS if EFFECTS[e].auto]   # the ones the diagnosis screens itself
NEW_CONDITIONS = ("jittered timestamps with dropped samples", "friction-torque record")
CASES = [(cond, EFFECT_NAMES[(3 * i + k) % len(EFFECT_NAMES)], JOINTS[(i + k) % len(JOINTS)])
         for i, cond in enumerate(c for c in CONDITION_NAMES if c not in NEW_CONDITIONS) for k in range(3)]
# the conditions handled since, three effects each, continuing the rotation: on a friction-torque
# record (inertia 0) eq. 5 subtracts nothing, so the effects that live in M qdd (an inertia
# error, a torque lag, a gear's load) cannot show there and are skipped
_ROTATION = [(e, j) for e, j in zip(EFFECT_NAMES * 3, JOINTS * 6)][len(CASES):]
for cond in NEW_CONDITIONS:
    picks = [(e, j) for e, j in _ROTATION
             if (cond, j) not in KNOWN_GAPS
             and not (cond == "friction-torque record"
                      and e in ("inertia_error", "torque_lag", "backlash", "joint_flexibility"))][:3]
    CASES += [(cond, e, j) for e, j in picks]
    _ROTATION = [p for p in _ROTATION if p not in picks]


# Known misses on these seeds are reported as expected failures (README known limits).  The
# three listed until 2026-11-24 (gravity on j1's short travel under coloured process noise
# named torque_offset; a torque lag with two tones; j3's inertia error on a 3-6 ms logger
# named torque_lag) are named right since a round's contenders are compared with one sample
# count and an offset must hold on both halves of the travel: they are held to the bar again.
KNOWN_MISSES: set[tuple[str, str]] = set()
CASES = [pytest.param(*c, marks=pytest.mark.xfail(reason="known miss, see README known limits", strict=False))
         if c[:2] in KNOWN_MISSES else c for c in CASES]


@pytest.mark.parametrize("condition,effect,joint", CASES)
def test_library_effect_is_named_first_under_condition(condition, effect, joint):
    spec = PRESETS[joint]
    # the joints the library's own tests use where a joint cannot show the effect (README,
    # known limits): a Stribeck exponent on the deep dip, a torque lag off the rotary motor
    if effect == "gravity" and spec.joint_type != "revolute":
        spec = PRESETS["j2"]
    if effect == "stribeck_shape":
        spec = PRESETS["linear"]
    if effect == "torque_lag" and spec.name == "rotary":
        spec = PRESETS["j3"]
    _named_first(spec, condition, effect, 7000 + 20 * CONDITION_NAMES.index(condition) + EFFECT_NAMES.index(effect))


def _named_first(spec, condition, effect, seed):
    texts = random_effects(spec, [effect], seed)
    rec, _ = make_record(spec, condition, seed, effects=texts)
    doc = analyze_record(rec).report()
    top = doc["diagnosis"][0]
    assert top["effect"] == effect and top["significant"], (texts, doc["diagnosis"][:3])
    assert doc["final"]["effects"] == [effect], (texts, doc["diagnosis"][:3])
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"], texts
    assert not doc["unexplained"]["structured"], (texts, doc["unexplained"]["evidence"])
