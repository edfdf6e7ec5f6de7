"""The virtual joint against a simulator written apart from it (``tests/independent_joint.py``:
classic Runge-Kutta at a 25 us step, no shared kernel): rigid, geared through backlash or a
spring, with the friction on the motor, on the load or shared, the two agree on the motion to
a few millionths of the travel.  A bug in the shared LuGre kernel, the gear's coupling or the
load's friction would show here and nowhere else: the fit uses the same kernels."""
import numpy as np
import pytest

from bench import terms
from bench.effects.inject import parse_injections
from independent_joint import independent_record
from virtual_drives.joint import simulate_record, sine_torque
from virtual_drives.presets import PRESETS

CONTACT = dict(contact_hz=terms.CONTACT_HZ, contact_damping=terms.CONTACT_DAMPING)


@pytest.mark.parametrize("joint,effect,independent", [
    ("j2", None, {}),
    ("j1", "backlash:width=0.003,load_fraction=0.5", dict(backlash=0.003, **CONTACT)),
    ("j1", "backlash:width=0.003,load_fraction=0.5,load_friction=1", dict(backlash=0.003, friction_on_load=1.0, **CONTACT)),
    ("linear", "backlash:width=8e-5,load_fraction=0.3,load_friction=0.4",
     dict(backlash=8e-5, load_share=0.3, friction_on_load=0.4, **CONTACT)),
    ("j3", "joint_flexibility:frequency=8,damping=0.05,load_fraction=0.5,load_friction=1",
     dict(flex_hz=8.0, flex_damping=0.05, friction_on_load=1.0)),
    ("rotary", "joint_flexibility:frequency=20,damping=0.08,load_fraction=0.3,load_friction=0.5",
     dict(flex_hz=20.0, flex_damping=0.08, load_share=0.3, friction_on_load=0.5)),
    # the bristles' damping fading with speed (one kernel: the fit's and the virtual joint's)
    ("j3", "damping_fade:vd=0.02", dict(physics=dict(sigma1_vd=0.02))),
    ("j1", "damping_fade:vd=0.018", dict(physics=dict(sigma1_vd=0.018))),
])
def test_the_virtual_joint_moves_as_an_independent_integrator_says(joint, effect, independent):
    spec = PRESETS[joint]
    ev = parse_injections([effect], spec)[0] if effect else None
    dt, duration = 1e-3, 8.0
    tau = sine_torque(*spec.excitation, np.arange(int(duration / dt)) * dt)
    ours = simulate_record(spec, *spec.excitation, duration, extra=ev,
                           torque_noise=0.0, encoder_resolution=0.0, tau=tau, q0=0.0)
    _, path = independent_record(spec, duration, torque=tau, torque_noise=0.0, resolution=0.0,
                                 n_sub=40, **independent)
    theirs = path[::40, 0][:len(ours.true_q)]
    travel = np.ptp(ours.true_q)
    assert travel > 1000 * spec.encoder_resolution       # the joint slid, back and forth
    assert np.max(np.abs(ours.true_q - theirs)) < 2e-5 * travel
    if effect:   # the effect changed the motion by far more than the two disagree
        rigid = simulate_record(spec, *spec.excitation, duration, torque_noise=0.0,
                                encoder_resolution=0.0, tau=tau, q0=0.0)
        assert np.max(np.abs(rigid.true_q - ours.true_q)) > 100 * np.max(np.abs(ours.true_q - theirs))
