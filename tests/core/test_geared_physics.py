"""The geared joint (motor + load through backlash and/or a gear spring): the coupling
means what its parameters say, and a record of it satisfies eq. 5 with the load term the
fit uses (momentum is conserved between motor and load)."""
import numpy as np
import pytest

from bench import terms
from bench.effects.inject import parse_injections
from bench.fitting import predict
from bench.identify import identify
from bench.grid_math import second_difference
from virtual_drives.joint import Gear, VirtualJoint, simulate_record, sine_torque
from virtual_drives.presets import PRESETS


def _gear(text):
    ev, *_ = parse_injections([text], PRESETS["j1"])
    return ev, terms.coupling(ev)


def test_locked_rotor_resonance_and_damping_are_what_the_injection_says():
    """Motor held after a step: the load rings at the locked-rotor frequency and decays at
    the damping ratio."""
    _, (gap, w2, c2) = _gear("joint_flexibility:frequency=7.5,damping=0.04")
    dt = 1e-3
    qm = np.full(4000, 0.01)
    qm[0] = 0.0
    ql = terms.load_trajectory(qm, dt, 8, gap, w2, c2) - 0.01
    up = np.nonzero((ql[:-1] < 0) & (ql[1:] >= 0))[0]
    period = np.mean(np.diff(up)) * dt
    zeta = 0.04
    assert 1 / period == pytest.approx(7.5 * np.sqrt(1 - zeta ** 2), rel=0.01)
    peaks = [np.max(ql[a:b]) for a, b in zip(up[:-1], up[1:])]
    decay = np.log(peaks[0] / peaks[5]) / 5          # log decrement per period
    assert decay / (2 * np.pi) == pytest.approx(zeta, rel=0.1)


def test_backlash_motor_turns_through_the_gap_before_the_load_follows():
    """Motor driven at constant speed, then reversed: the load stays put (it has no push)
    until the motor has crossed the whole width, then follows on the other flank."""
    width = 0.004
    _, (gap, w2, c2) = _gear(f"backlash:width={width}")
    dt = 1e-3
    t = np.arange(3000) * dt
    qm = np.where(t < 1.0, 0.05 * t, 0.05 - 0.05 * (t - 1.0))
    qm = np.where(t < 0.2, 0.0, qm - 0.01)            # start at rest, then ramp
    ql = terms.load_trajectory(qm, dt, 8, gap, w2, c2)
    # pushed: the motor leads by half the width (plus the contact's small deflection)
    assert qm[900] - ql[900] == pytest.approx(width / 2, rel=0.05)
    # after the reversal: the motor trails by half the width, the gap has been crossed
    assert qm[2900] - ql[2900] == pytest.approx(-width / 2, rel=0.05)


@pytest.mark.parametrize("joint,effect", [("j2", "backlash:width=0.0028"),
                                          ("linear", "joint_flexibility:frequency=15,damping=0.05")])
def test_a_geared_record_satisfies_eq5_with_the_load_term(joint, effect):
    """tau - M qdd_motor = F(v_motor) + M_load (qdd_load - qdd_motor), with q_load run
    through the gear from the motor trajectory alone, as the fit does it: what is left is
    the rigid joint's own discretisation residual, a small fraction of the effect."""
    spec = PRESETS[joint]
    ev, *_ = parse_injections([effect], spec)
    gear = Gear.of(spec, ev, 1e-3)
    kw = dict(duration=10.0, seed=0, torque_noise=0.0, encoder_resolution=0.0)
    geared = simulate_record(spec, *spec.excitation, extra=ev, **kw)
    rigid = simulate_record(spec, *spec.excitation, **kw)
    truth = dict(spec.friction.as_dict())

    def rms(rec, load):
        data = identify(rec).data
        c, m = data.c, data.mask
        r = data.friction - predict(data, truth)
        if load is not None:
            r = r - gear.M_load * c.lowpass(second_difference(load - c.q_full, c.dt))
        return float(np.sqrt(np.mean(r[m] ** 2)))

    ql = terms.load_trajectory(geared.record.q, 1e-3, 8, *terms.coupling(ev))
    without = rms(geared.record, None)
    assert rms(geared.record, ql) < max(0.1 * without, 2.0 * rms(rigid.record, None))


def test_the_encoder_side_is_chosen_and_recorded():
    spec = PRESETS["j3"]
    ev, *_ = parse_injections(["backlash:width=0.004"], spec)
    motor = simulate_record(spec, *spec.excitation, 8.0, extra=ev, torque_noise=0.0)
    load = simulate_record(spec, *spec.excitation, 8.0, extra=ev, torque_noise=0.0, encoder="load")
    assert motor.record.meta["encoder"] == "motor" and load.record.meta["encoder"] == "load"
    offset = motor.true_q - load.true_q
    assert 0.9 * 0.002 < np.max(np.abs(offset)) < 1.5 * 0.002


def test_virtual_joint_steps_like_the_batch_simulation_when_geared():
    spec = PRESETS["rotary"]
    ev, *_ = parse_injections(["backlash:width=0.003", "joint_flexibility:frequency=25"], spec)
    tau = sine_torque(*spec.excitation, np.arange(400) * 1e-3)
    batch = simulate_record(spec, *spec.excitation, 0.4, extra=ev, torque_noise=0.0,
                            encoder_resolution=0.0, tau=tau)
    joint = VirtualJoint(spec, dt=1e-3, extra=ev)
    qs = []
    for x in tau:
        qs.append(joint.state.q)
        joint.advance(x)
    assert np.allclose(qs, batch.true_q, atol=1e-12)
    rigid = simulate_record(spec, *spec.excitation, 0.4, torque_noise=0.0, encoder_resolution=0.0, tau=tau)
    assert np.max(np.abs(batch.true_q - rigid.true_q)) > 1e-3     # the gear changed the motion


def test_a_load_against_a_stiff_friction_law_converges_at_any_sub_step():
    """The load's implicit step under the law a LuGre fit bends to on a sharp static map
    (sigma0 8e12, a 0.4 mrad/s Stribeck rise, as fitted on j4, test seed 5725): the same path at
    7 and 64 sub-steps.  The secant's guard once held the step to the chord's slope (huge
    there), so it crawled its 30 iterations unconverged: paths 0.8 rad apart at 1 and 64
    sub-steps (and this test failed)."""
    _, (gap, w2, c2) = _gear("joint_flexibility:frequency=11,damping=0.05")
    t = np.arange(4000) * 1e-3
    qm = 0.5 * np.sin(2 * np.pi * 0.5 * t)
    p = np.array([600.0, 0.07, 2750.0, 1.0, 8e12, 2100.0, 3300.0])
    (q7, F7), (q64, F64) = (terms.load_trajectory_friction(qm, 1e-3, n, gap, w2, c2, p, 2.0 / 45, 0.0)
                            for n in (7, 64))
    assert np.max(np.abs(q7 - q64)) < 1e-6
    assert np.max(np.abs(F7 - F64)) < 1e-3 * np.std(F64)


def test_a_gear_is_credited_only_with_a_load_that_matters():
    """A backlash or a spring whose load is a sliver of the joint's inertia is a flexible
    shape, not a gear: frictional lag on the rotary motor was fitted as 145 mrad of play
    before 0.7 % of it (bench.effects.gear.MIN_LOAD_SHARE)."""
    from types import SimpleNamespace
    from bench.effects.backlash import Backlash
    from bench.effects.joint_flexibility import JointFlexibility
    ctx = SimpleNamespace(inertia=2.0)
    for effect in (Backlash(), JointFlexibility()):
        key = effect.load_key
        assert not effect.gear_credible({key: 0.007 * 2.0}, ctx)
        assert effect.gear_credible({key: 0.3 * 2.0}, ctx)
        assert not effect.gear_credible({key: 1.2 * 2.0}, ctx)
