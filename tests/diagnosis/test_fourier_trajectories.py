"""Fourier-series excitation trajectories (Swevers et al. 1997), the trajectories robot
makers and labs run to identify rigid-body dynamics, and so the motion of many real joint
logs: a periodic sum of five harmonics with random coefficients over the joint's travel,
tracked by a PID loop, on a jittered lossy logger, from the independent simulator.  Unlike a
torque sine the velocity reverses at many accelerations and the torque is the loop's.

Measured on tuning seeds (2026-11-30, 40 s logs, base frequency 0.08-1.6 Hz for a top speed
of 6/alpha): clean joints 1050-1055, nothing named, none flagged, Fc, Fs, sigma2 within 3 %
on 6 of 6.  Library effects 1060-1080 (j1, j2, j4, linear): gravity, cogging,
position-dependent friction, a direction asymmetry, a warm-up and a current-loop lag named
first on 18 of 18; an offset on 2 of 3 (j4's read as gravity: README known limits, offset vs
gravity).  Fresh seeds here; j3 and the rotary motor, not tuned on, among them."""
import numpy as np

from independent_joint import fourier_trajectory
from tests.diagnosis.test_independent_records import _travel
from tests.diagnosis.tracked_logs import library_physics, tracked_row
from tests.record_pool import map_records
from virtual_drives.presets import PRESETS


def _log(joint, seed, physics=None):
    spec = PRESETS[joint]
    ref, _ = fourier_trajectory(_travel(spec), 6.0 / spec.friction.alpha, 40.0, np.random.default_rng([seed, 5]))
    return tracked_row(spec, seed, ref, bool(seed % 2), physics)


def test_clean_joints_on_fourier_trajectories_name_nothing_and_identify_the_map():
    rows = map_records(_log, [(j, 8420 + i) for i, j in enumerate(("j1", "j2", "j3", "j4", "linear", "rotary"))])
    assert sum(not r[3] and not r[4] for r in rows) >= 5, rows
    assert sum(r[5] for r in rows) >= 5, rows


def _library(joint, seed, kind):
    return (kind,) + _log(joint, seed, library_physics(PRESETS[joint], kind))


def test_library_effects_on_fourier_trajectories_are_named_first():
    items = [("j3", 8430, "gravity"), ("j2", 8431, "cogging"), ("rotary", 8432, "position_dependent_friction"),
             ("j2", 8433, "direction_asymmetry"), ("j3", 8434, "thermal_drift"), ("j2", 8435, "torque_lag")]
    rows = map_records(_library, items)
    assert sum(bool(r[4]) and r[4][0] == r[0] and not r[5] for r in rows) >= 5, rows


def _gapped(joint, seed, width, dt):
    """The independent simulator's gap (its teeth meet through a 60 Hz contact) on the linear
    stage, a PID tracking a Fourier trajectory, logged at 1/dt with jitter and lost rows."""
    from bench.analysis import analyze_record
    from independent_joint import independent_record
    spec = PRESETS[joint]
    travel, Fc = _travel(spec), spec.friction.Fc
    ref, _ = fourier_trajectory(travel, 6.0 / spec.friction.alpha, 30.0, np.random.default_rng([seed, 5]), dt=dt)
    rec, _ = independent_record(spec, duration=30.0, seed=seed, dt=dt, backlash=width, torque_noise=0.02 * Fc,
                                jitter=0.2, drop=0.005, pd=(6.0, 0.5 * travel, 1.5), reference=ref)
    doc = analyze_record(rec).report()
    return seed, [d["effect"] for d in doc["diagnosis"] if d["significant"]], \
        doc["final"]["rms_error"] / doc["baseline"]["rms_error"]


def test_a_gap_ringing_on_its_contact_under_fourier_moves_is_analysed_not_refused():
    """At the top speeds of these moves the gap's contact rings, and the map there scatters
    about Coulomb plus viscous friction (R^2 0.5-0.7) while its sign still follows the motion:
    the linear stage's 2.2-3.5 mm gaps were refused as "a lag between the torque and the motion
    or an inertia error" (soak seed 30243; these fresh seeds too, before
    ``bench.identify.SCATTERED_R2``).  Analysed, the gap is named first and its fit takes
    most of the residual (what the contact's spring leaves may still be flagged: the
    independent simulator's gap is not rigid)."""
    rows = map_records(_gapped, [("linear", 10383, 0.003, 5e-4), ("linear", 10385, 0.0035, 5e-4)])
    for seed, named, ratio in rows:
        assert named and named[0] == "backlash", (seed, named)
        assert ratio <= 0.7, (seed, ratio)


def _level(joint, seed, kind, moves):
    """An offset or a direction asymmetry of 11 % of Fc on a joint under a PID tracking
    Fourier or point-to-point moves, with a felt disturbance (1.5 % of Fc, 50 ms); 1 ms logger."""
    from bench.analysis import analyze_record
    from independent_joint import independent_record, point_to_point
    spec = PRESETS[joint]
    travel, Fc = _travel(spec), spec.friction.Fc
    rng = np.random.default_rng([seed, 5])
    ref = (fourier_trajectory(travel, 6.0 / spec.friction.alpha, 30.0, rng)[0] if moves == "fourier"
           else point_to_point(travel, 0.5 / spec.excitation[1], 30.0, rng))
    sign = 1.0 if seed % 2 else -1.0
    physics = dict(constant=0.11 * sign * Fc) if kind == "torque_offset" else dict(asym=0.11 * sign)
    rec, _ = independent_record(spec, duration=30.0, seed=seed, physics=physics, disturbance=0.015 * Fc,
                                disturbance_tau=0.05, pd=(6.0, 0.5 * travel, 1.5), reference=ref)
    doc = analyze_record(rec).report()
    return kind, seed, [d["effect"] for d in doc["diagnosis"] if d["significant"]], doc["unexplained"]["structured"]


def test_a_level_the_friction_fit_bent_under_a_loop_is_named():
    """Under a loop an offset or a direction's extra friction is taken in part by LuGre's own
    fit, differently where the motion differs along the travel: what the baseline leaves then
    differs between the travel's halves, and the level was refused as "not one level" though
    its refit left nothing (soak seed 30388: an offset, 0.33 to 0.03; 30323: an asymmetry told
    as an offset).  It is now judged on what its refit leaves
    (``bench.effects.base.level_left_along_travel``).  These fresh seeds, measured before the
    rule: 7 of 8 (j4's offset, 10387, read as gravity); with it 8 of 8."""
    items = [("linear", 10386, "torque_offset", "fourier"), ("j4", 10387, "torque_offset", "fourier"),
             ("j3", 10388, "torque_offset", "p2p"), ("j1", 10389, "torque_offset", "p2p"),
             ("j2", 10390, "direction_asymmetry", "fourier"), ("linear", 10391, "direction_asymmetry", "fourier"),
             ("linear", 10392, "direction_asymmetry", "p2p"), ("j4", 10393, "direction_asymmetry", "p2p")]
    rows = map_records(_level, items)
    wrong = [r for r in rows if not (r[2] and r[2][0] == r[0] and not r[3])]
    assert not wrong, wrong
