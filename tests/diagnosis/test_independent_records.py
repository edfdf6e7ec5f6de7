"""Records from a simulator written apart from ours (``tests/independent_joint.py``: Runge-Kutta,
an underdamped contact between the teeth, the disturbance inside the integration, jittered
sampling), so that the diagnosis is not right only on its own generator.

While building the load-side friction, seeds 3, 4, 11 and 12 were looked at, and 7000-7056
while building the two-gain thermal drift; the seeds here (9100+, 9200+) were not."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from independent_joint import independent_record, two_tones
from virtual_drives.presets import PRESETS


def _report(rec):
    return analyze_record(rec).report()


def _within(doc, spec, tol=0.05):
    """Fc, Fs and sigma2 off by more than 5 %, unless the report says so itself: not
    identifiable, or within two of its standard errors (as tests/diagnosis/test_conditions.py
    accepts: the rotary motor's sine test barely enters the Stribeck decay)."""
    p, f, ok, se = doc["parameters"], spec.friction, doc["identifiable"], doc["uncertainty"]
    return {k: round(p[k] / getattr(f, k) - 1, 4) for k in ("Fc", "Fs", "sigma2")
            if abs(p[k] / getattr(f, k) - 1) > tol and ok[k]
            and not (se[k] is not None and abs(p[k] - getattr(f, k)) <= 2.0 * se[k])}


@pytest.mark.parametrize("joint,seed", [(j, 9100 + i) for i, j in enumerate(PRESETS)])
def test_clean_joints_with_a_felt_disturbance_and_a_jittered_logger(joint, seed):
    """A disturbance the record does not hold (2 % of Fc, 10 ms), 40 % jitter, 1 % lost
    samples: nothing named, nothing left, the friction identified."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, disturbance=0.02 * spec.friction.Fc,
                                jitter=0.4, drop=0.01)
    doc = _report(rec)
    assert not [d["effect"] for d in doc["diagnosis"] if d["significant"]], doc["diagnosis"][:2]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)


GEARS = [
    # (joint, seed, gear, the parameter the report must give back, its true value)
    ("j1", 9111, dict(backlash=0.003), "bl_width", 0.003),
    ("j2", 9112, dict(backlash=0.0025, load_share=0.6), "bl_width", 0.0025),
    ("j3", 9113, dict(backlash=0.004, contact_hz=80.0, contact_damping=0.3), "bl_width", 0.004),
    ("j1", 9121, dict(flex_hz=7.0), "flex_frequency", 7.0),
    ("j3", 9122, dict(flex_hz=5.0, flex_damping=0.08), "flex_frequency", 5.0),
    ("linear", 9123, dict(flex_hz=18.0, load_share=0.3), "flex_frequency", 18.0),
    # all the friction beyond the gear (the output bearing and the mesh), and half of it
    ("j1", 9131, dict(backlash=0.003, friction_on_load=1.0), "bl_width", 0.003),
    ("j2", 9132, dict(backlash=0.002, friction_on_load=1.0, load_share=0.6), "bl_width", 0.002),
    ("j3", 9133, dict(backlash=0.0035, friction_on_load=0.5), "bl_width", 0.0035),
    # ... and a share of it (what a first pass tells as cogging: bench.analysis)
    ("j1", 9134, dict(backlash=0.003, friction_on_load=0.3), "bl_width", 0.003),
    ("j3", 9135, dict(backlash=0.0025, friction_on_load=0.2), "bl_width", 0.0025),
    # seen from the load's encoder (bench.load_side.gap_slip), the contact unlike the fit's
    ("j2", 9141, dict(backlash=0.003, encoder="load"), "bl_width", 0.003),
    ("j4", 9142, dict(backlash=0.002, contact_hz=80.0, contact_damping=0.3, load_share=0.4,
                      encoder="load"), "bl_width", 0.002),
]


@pytest.mark.parametrize("joint,seed,gear,key,true", GEARS)
def test_gears_of_another_simulator_are_named_and_measured(joint, seed, gear, key, true):
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, **gear)
    doc = _report(rec)
    effect = "backlash" if key.startswith("bl_") else "joint_flexibility"
    top = doc["diagnosis"][0]
    assert top["effect"] == effect and top["significant"], (gear, doc["diagnosis"][:3])
    assert doc["final"]["effects"] == [effect], (gear, doc["diagnosis"][:3])
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert abs(doc["final"]["parameters"][key] / true - 1) < 0.10, doc["final"]["parameters"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)
    if gear.get("friction_on_load"):
        assert "of the friction acts beyond the gear" in top["evidence"], top["evidence"]


COMPLIANT_GEARS = [
    # (joint, seed, width, the gear's spring in Hz, its damping ratio): the teeth meet through
    # the spring, the friction on the motor
    ("j1", 9151, 0.003, 10.0, 0.05),
    ("j2", 9152, 0.002, 7.0, 0.1),
    ("j3", 9153, 0.0035, 14.0, 0.05),
    ("j4", 9154, 0.0025, 9.0, 0.08),
]


@pytest.mark.parametrize("joint,seed,width,hz,damping", COMPLIANT_GEARS)
def test_a_gear_both_loose_and_compliant_is_named_and_measured(joint, seed, width, hz, damping):
    """Backlash whose flanks meet through a gear spring (a spur or planetary stage): named
    first and alone as backlash whose evidence says the gear is compliant too, the held-out
    error down by 30 % or more, the width and the spring within 10 %, nothing left."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, backlash=width, flex_hz=hz, flex_damping=damping)
    doc = _report(rec)
    top, p = doc["diagnosis"][0], doc["final"]["parameters"]
    assert doc["final"]["effects"] == ["backlash"] and top["effect"] == "backlash", doc["diagnosis"][:3]
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert abs(p["bl_width"] / width - 1) < 0.10, p
    assert abs(p.get("bl_contact", 0.0) / hz - 1) < 0.10, p
    assert "compliant as well" in top["evidence"], top["evidence"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)


ABOVE_BAND = [
    # (joint, seed, the gear's spring in Hz, the share of the inertia beyond it): springs above
    # the default comparison band (10-12 Hz for the Table II joints' sines, 40 Hz for the
    # linear stage's), which bent LuGre unseen before bench.wide_band
    ("j1", 9161, 12.0, 0.7),
    ("j3", 9162, 15.0, 0.5),
    ("j2", 9163, 14.0, 0.6),
    ("linear", 9165, 55.0, 0.5),
]


@pytest.mark.parametrize("joint,seed,hz,load_share", ABOVE_BAND)
def test_a_gear_spring_above_the_comparison_band_is_named_and_measured(joint, seed, hz, load_share):
    """Named first and alone at the wider band the report states, the frequency within 10 %,
    the held-out error down by 30 % or more, nothing left, the friction within 5 %."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, flex_hz=hz, load_share=load_share)
    doc = _report(rec)
    top, p = doc["diagnosis"][0], doc["final"]["parameters"]
    assert doc["final"]["effects"] == ["joint_flexibility"] and top["effect"] == "joint_flexibility", doc["diagnosis"][:3]
    assert abs(p["flex_frequency"] / hz - 1) < 0.10, p
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert any("above the default comparison band" in w for w in doc["warnings"]), doc["warnings"]
    assert doc["fit"]["cutoff_hz"] > hz
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)


SPRINGS_WITH_FRICTION_BEYOND = [
    # (joint, seed, the spring in Hz, the share of the inertia beyond it, of the friction, the
    # damping ratio): under one sine such a spring passes for an inertia error or gravity
    # (sigma2 beyond a spring k acts as an inertia of -sigma2^2 / k), and was told so with
    # nothing left
    ("j2", 9185, 11.0, 0.5, 0.3, 0.05),    # inside j2's 12 Hz band
    ("j1", 9186, 12.0, 0.6, 0.4, 0.05),    # above j1's 10 Hz band
    ("j3", 9187, 14.0, 0.6, 0.3, 0.05),
    ("j4", 9188, 11.0, 0.6, 0.4, 0.05),
    # a third of the inertia beyond: at the wider band still an inertia error until that
    # story competed with the friction-beyond pass (bench.analysis._wider_if_resonant)
    ("j1", 5535, 14.0, 0.3, 0.35, 0.07),
    ("j3", 5538, 13.5, 0.3, 0.33, 0.09),
    # ...where the spring's held-out error was 18 % under the inertia error's and the round's
    # criterion could not tell them apart (bench.rounds.CRITERION_TIE)
    ("j3", 5548, 15.0, 0.3, 0.33, 0.07),
    # above j2's 12 Hz band with a fifth of the inertia beyond: at the default band told as
    # play (0.06 mrad through a 26 Hz contact; 3.4 mrad beside an inertia error) with nothing
    # left, until a named backlash with friction beyond it was still probed
    # (bench.wide_band.gear_settled)
    ("j2", 5626, 16.9, 0.2, 0.37, 0.05),
    ("j2", 5627, 17.0, 0.18, 0.35, 0.05),
]


@pytest.mark.parametrize("joint,seed,hz,load_share,beyond,damping", SPRINGS_WITH_FRICTION_BEYOND)
def test_a_gear_spring_with_friction_beyond_it_is_named_not_an_inertia_error(joint, seed, hz, load_share, beyond,
                                                                             damping):
    """Named first and alone, the frequency within 10 %, the friction's share beyond it within
    0.1, the held-out error down by 30 % or more, nothing left, the friction within 5 %."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, flex_hz=hz, flex_damping=damping, load_share=load_share,
                                friction_on_load=beyond)
    doc = _report(rec)
    top, p = doc["diagnosis"][0], doc["final"]["parameters"]
    assert doc["final"]["effects"] == ["joint_flexibility"] and top["effect"] == "joint_flexibility", doc["diagnosis"][:3]
    assert abs(p["flex_frequency"] / hz - 1) < 0.10, p
    assert abs(p["flex_kappa"] * p["flex_load"] - beyond) < 0.1, p
    assert "of the friction acts beyond the gear" in top["evidence"], top["evidence"]
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)
    # a close call is said, and its runners-up left more held out
    assert ("a close call" in top["evidence"]) == bool(top["close_call"]), top
    assert all(c["rms_after"] > top["rms_after"] for c in top["close_call"]), top["close_call"]
    if seed == 5548:
        assert [c["effect"] for c in top["close_call"]] == ["inertia_error"], top["close_call"]


def test_a_spring_above_the_band_too_small_to_matter_tells_no_story():
    """j4's 14 Hz spring with 80 % of the inertia beyond it moves the torque by less than the
    verdict's floor: nothing is named, and the friction is still identified within 5 %."""
    spec = PRESETS["j4"]
    rec, _ = independent_record(spec, seed=9164, flex_hz=14.0, load_share=0.8)
    doc = _report(rec)
    assert not [d["effect"] for d in doc["diagnosis"] if d["significant"]], doc["diagnosis"][:2]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)


def _travel(spec) -> float:
    rec, _ = independent_record(spec, duration=4.0, seed=1)
    return float(rec.q.max() - rec.q.min())


# the library's effects as another simulator writes them (tests/independent_joint.py: a link's
# weight -mgl sin(q + q0), a first-order current loop instead of a delay, two detent harmonics,
# the friction levels rippling along the travel, a warm-up that thins the oil only, a constant
# torque, a larger level going negative); magnitudes relative to the joint (Fc, travel)
FOREIGN = [
    ("j2", 9201, "gravity", lambda s, tr: dict(mgl=0.1 * s.friction.Fc, q0=0.8)),
    ("j4", 9202, "gravity", lambda s, tr: dict(mgl=0.07 * s.friction.Fc, q0=4.0)),
    ("j1", 9203, "torque_lag", lambda s, tr: dict(lag=0.005)),
    ("linear", 9204, "torque_lag", lambda s, tr: dict(lag=0.004)),
    ("j3", 9205, "cogging", lambda s, tr: dict(detent=0.06 * s.friction.Fc, detent_pitch=tr / 7, detent_h2=0.5)),
    ("linear", 9206, "cogging", lambda s, tr: dict(detent=0.05 * s.friction.Fc, detent_pitch=tr / 10, detent_h2=0.3)),
    ("j4", 9207, "position_dependent_friction", lambda s, tr: dict(ripple=0.1, ripple_pitch=tr / 3)),
    ("j2", 9208, "position_dependent_friction", lambda s, tr: dict(ripple=0.08, ripple_pitch=tr / 4)),
    ("j1", 9209, "thermal_drift", lambda s, tr: dict(warm=0.25, warm_tau=6.0)),
    ("j3", 9210, "thermal_drift", lambda s, tr: dict(warm=0.3, warm_tau=9.0)),
    ("linear", 9211, "thermal_drift", lambda s, tr: dict(warm=0.2, warm_tau=12.0)),
    ("j4", 9212, "torque_offset", lambda s, tr: dict(constant=-0.05 * s.friction.Fc)),
    ("rotary", 9213, "torque_offset", lambda s, tr: dict(constant=0.06 * s.friction.Fc)),
    ("j3", 9214, "direction_asymmetry", lambda s, tr: dict(asym=0.12)),
    ("linear", 9215, "direction_asymmetry", lambda s, tr: dict(asym=-0.1)),
]


@pytest.mark.parametrize("joint,seed,effect,physics", FOREIGN)
def test_library_physics_written_by_another_simulator_is_named(joint, seed, effect, physics):
    """Named first, alone, the held-out error down by 30 % or more, nothing left; Fc, Fs, sigma2
    within 5 % where the conventions agree (a direction asymmetry's Fc is the two directions'
    mean here, the larger level going negative there)."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, disturbance=0.01 * spec.friction.Fc, jitter=0.3,
                                drop=0.005, physics=physics(spec, _travel(spec)))
    doc = _report(rec)
    top = doc["diagnosis"][0]
    assert top["effect"] == effect and top["significant"], doc["diagnosis"][:3]
    assert doc["final"]["effects"] == [effect], doc["diagnosis"][:3]
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    if effect != "direction_asymmetry":
        assert not _within(doc, spec), _within(doc, spec)
    if effect == "thermal_drift":
        assert "viscous friction by" in top["evidence"], top["evidence"]


def test_a_sudden_friction_change_is_unexplained_and_not_credited_to_a_drift():
    """Both friction levels step by 6-12 % somewhere in the middle of the record: no library
    effect describes it (thermal_drift is one exponential from the start), so nothing may be
    credited and the verdict must say the level changes.  Seeds 1400-1405 and 9301-9306 were
    looked at while building the level test; these (9401+) were not.  At most one wrong."""
    wrong = []
    for i, joint in enumerate(PRESETS):
        spec = PRESETS[joint]
        step = (-1) ** i * (0.06 + 0.012 * i)
        rec, _ = independent_record(spec, seed=9401 + i, disturbance=0.01 * spec.friction.Fc,
                                    jitter=0.3, drop=0.005, physics=dict(jump=step, jump_t=7.0 + i))
        doc = _report(rec)
        credited = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
        u = doc["unexplained"]
        if credited or not u["structured"] or "friction level changes" not in u["evidence"]:
            wrong.append((joint, step, credited, u["evidence"][:200]))
    assert len(wrong) <= 1, wrong


def _stepped_two_tones(i: int, joint: str, seed: int) -> tuple:
    spec = PRESETS[joint]
    step = (-1) ** i * (0.06 + 0.012 * i)
    rec, _ = independent_record(spec, seed=seed, torque=two_tones(spec), disturbance=0.01 * spec.friction.Fc,
                                drop=0.01, physics=dict(jump=step, jump_t=7.0 + i))
    doc = _report(rec)
    u = doc["unexplained"]
    return (joint, step, [d["effect"] for d in doc["diagnosis"] if d["significant"]], u["structured"],
            u["evidence"][:200])


def test_a_sudden_friction_change_under_two_tones_is_not_taken_for_a_warm_up():
    """Under two tones a Table II joint's 20 s has 8-9 uneven motion segments, too few and too
    noisy for the neighbours to follow the levels better than a drift: a step was credited as a
    warm-up (tuning seeds 1603, 1605; fresh 10065).  One step of the levels must not follow them
    better than the drift either (``thermal_drift.STEP_RATIO``).  Fresh seeds 10080-10085 were
    checked when it was written (six of six unexplained, nothing credited); these were not."""
    from tests.record_pool import map_records
    got = map_records(_stepped_two_tones, [(i, j, 10100 + i) for i, j in enumerate(("j1", "j2", "j3", "j4"))])
    wrong = [g for g in got if g[2] or not g[3]]
    assert len(wrong) <= 1, wrong


PD_CASES = [
    # (joint, seed, gear, the parameter the report must give back, its true value)
    ("j2", 9501, {}, None, None),
    ("j4", 9502, {}, None, None),
    ("linear", 9503, {}, None, None),
    ("j1", 9511, dict(backlash=0.003), "bl_width", 0.003),
    ("j2", 9512, dict(backlash=0.0025, load_share=0.6), "bl_width", 0.0025),
    ("j1", 9513, dict(flex_hz=7.0), "flex_frequency", 7.0),
    ("linear", 9514, dict(flex_hz=18.0, load_share=0.3), "flex_frequency", 18.0),
]


@pytest.mark.parametrize("joint,seed,gear,key,true", PD_CASES)
def test_closed_loop_records_of_another_simulator(joint, seed, gear, key, true):
    """The joint tracks a sine under another simulator's PD controller (4 Hz bandwidth, on
    the quantised motor encoder), the log holding the controller's torque: clean joints name
    nothing; a gear is named first, alone, and measured within 10 %."""
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, disturbance=0.01 * spec.friction.Fc, jitter=0.3,
                                drop=0.005, pd=(4.0, 0.5 * _travel(spec)), **gear)
    doc = _report(rec)
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
    assert not _within(doc, spec), _within(doc, spec)
    if key is None:
        assert not [d["effect"] for d in doc["diagnosis"] if d["significant"]], doc["diagnosis"][:2]
        return
    effect = "backlash" if key.startswith("bl_") else "joint_flexibility"
    assert doc["final"]["effects"] == [effect], doc["diagnosis"][:3]
    # the loop holds the joint, so the gear shows less than under a torque sine: j1's 7 Hz
    # spring left 10.9 N·m against a noise of 8.8 (a clean record's); the fit ends at the noise
    assert doc["final"]["rms_error"] <= 0.85 * doc["baseline"]["rms_error"]
    assert abs(doc["final"]["parameters"][key] / true - 1) < 0.10, doc["final"]["parameters"]


def _loaded_mesh(joint: str, excitation: str, mu: float, seed: int) -> tuple:
    spec = PRESETS[joint]
    kw = dict(torque=two_tones(spec)) if excitation == "two tones" else dict(pd=(6.0, 0.4 * _travel(spec), 1.5))
    rec, _ = independent_record(spec, seed=seed, disturbance=0.01 * spec.friction.Fc, disturbance_tau=0.05,
                                drop=0.01, physics=dict(load_mu=mu), **kw)
    doc = _report(rec)
    u = doc["unexplained"]
    return (joint, excitation, mu, [d["effect"] for d in doc["diagnosis"] if d["significant"]], u["structured"],
            "grows with the torque the joint carries" in u["evidence"], u["load"], u["evidence"][:160])


def test_friction_that_grows_with_the_carried_torque_is_unexplained_under_two_tones():
    """The other simulator's loaded mesh (the levels grow by mu |torque| / Fc) under two tones:
    LuGre took it as a higher Fc (6-32 %) and "nothing left" (fresh seeds 10130-10141, before
    ``bench.load_torque``, which regresses the level error on the carried torque within the
    motion segments; tuned on 1650-1687 and 1700-1961).  Fresh seeds 10142-10147 missed 3 of 6
    under its first t (over per-segment slopes) and so shaped the jackknife t; 10148-10153, fresh
    for it: two tones 3 of 3 flagged, PID tracking 1 of 3 (README known limits: not asserted).
    These seeds were not looked at.  Nothing may be credited, and the verdict must name the load.
    At most one wrong."""
    from tests.record_pool import map_records
    jobs = [(j, "two tones", mu, 10154 + i) for i, (j, mu) in enumerate(
        [("j1", 0.1), ("j2", 0.15), ("j3", 0.1), ("j1", 0.15), ("j2", 0.1), ("j3", 0.15)])]
    got = map_records(_loaded_mesh, jobs)
    wrong = [g for g in got if g[3] or not g[4] or not g[5]]
    assert len(wrong) <= 1, wrong


def test_friction_that_grows_with_the_carried_torque_under_pid_tracking_credits_no_library_effect():
    """The same loaded mesh under PID tracking, where the recorded torque is the loop's: a gear
    spring and a torque lag were credited for it (tuning seeds 1825, 1827, mu 0.15: the spring
    refitted beside the lag ended at damping 0.8, a low-pass; ``JointFlexibility.fails_at_end``
    now drops it), as were a fading damping and a lag on fresh seed 10148's j1.  Tuning, PID at
    mu 0.05-0.15 on j1-j3 (1809-1829): nothing credited on 21 of 21, structure left on 14 (12 of
    the 15 at mu >= 0.1).  Fresh seeds 10160-10165, bars set before they ran: at most one credits
    a library effect, and at least four of six leave structure (the verdict "unexplained")."""
    from tests.record_pool import map_records
    jobs = [(j, "pid", mu, 10160 + i) for i, (j, mu) in enumerate(
        [("j1", 0.15), ("j2", 0.1), ("j3", 0.15), ("j1", 0.1), ("j2", 0.15), ("j3", 0.1)])]
    got = map_records(_loaded_mesh, jobs)
    assert len([g for g in got if g[3]]) <= 1, got
    assert len([g for g in got if g[4]]) >= 4, got


@pytest.mark.parametrize("joint,seed,gear,key,true", [
    ("j4", 10380, dict(flex_hz=5.5, load_share=0.6), "flex_frequency", 5.5),
    ("j2", 10381, dict(flex_hz=8.0, load_share=0.5), "flex_frequency", 8.0),
    ("j3", 10382, dict(backlash=0.003), "bl_width", 0.003),
])
def test_a_gear_across_a_loggers_gap_in_motion_is_named_and_measured(joint, seed, gear, key, true):
    """The logger lost 20 ms of the motion mid-record (no jitter): the segment after the gap
    starts in motion, and its load must start with the motor.  Started at rest, the load rang
    through the segment: a 5.3 Hz gear on j4 went unnamed (soak seed 30089), its fit worse
    held out than LuGre alone."""
    from bench.records import Record
    spec = PRESETS[joint]
    rec, _ = independent_record(spec, seed=seed, torque=two_tones(spec), disturbance=0.005 * spec.friction.Fc,
                                **gear)
    v = np.gradient(rec.q, rec.t)
    middle = np.flatnonzero((rec.t > 9.0) & (rec.t < 11.0))
    k0 = middle[np.argmax(np.abs(v[middle]))]                     # at speed
    keep = np.ones(len(rec.t), dtype=bool)
    keep[k0:k0 + 20] = False
    cut = Record(t=rec.t[keep], tau=rec.tau[keep], q=rec.q[keep], meta=dict(rec.meta))
    doc = _report(cut)
    assert doc["resampling"]["gaps"] == 1, doc["resampling"]
    effect = "backlash" if key.startswith("bl_") else "joint_flexibility"
    top = doc["diagnosis"][0]
    assert top["effect"] == effect and top["significant"], doc["diagnosis"][:3]
    assert doc["final"]["rms_error"] <= 0.7 * doc["baseline"]["rms_error"]
    assert abs(doc["final"]["parameters"][key] / true - 1) < 0.10, doc["final"]["parameters"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]["evidence"]
