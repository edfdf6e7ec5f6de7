"""Virtual joint physics: deterministic, converged in its sub-steps, stable when stiff."""
import numpy as np
import pytest

from bench.lugre import LuGreParams
from virtual_drives import physics
from virtual_drives.joint import VirtualJoint, simulate_record
from virtual_drives.presets import PRESETS


def test_same_seed_same_record_other_seed_other_noise():
    spec = PRESETS["j3"]
    a = simulate_record(spec, *spec.excitation, duration=4.0, seed=5).record
    b = simulate_record(spec, *spec.excitation, duration=4.0, seed=5).record
    c = simulate_record(spec, *spec.excitation, duration=4.0, seed=6).record
    assert np.array_equal(a.tau, b.tau) and np.array_equal(a.q, b.q)
    assert not np.array_equal(a.tau, c.tau)


@pytest.mark.parametrize("name", ["linear", "rotary", "j1"])
def test_substeps_converge(name, monkeypatch):
    spec = PRESETS[name]
    runs = {}
    for n in (1, 16):
        monkeypatch.setattr("virtual_drives.joint.substeps_for", lambda *a, n=n, **k: n)
        runs[n] = simulate_record(spec, *spec.excitation, duration=3.0, seed=0, torque_noise=0.0).true_q
    span = np.ptp(runs[16])
    assert np.max(np.abs(runs[1] - runs[16])) < 0.01 * span


def test_below_stiction_the_joint_only_deflects():
    spec = PRESETS["j1"]
    sim = simulate_record(spec, 0.8 * spec.friction.Fs, 0.25, duration=8.0, seed=0, torque_noise=0.0)
    # presliding: displacement of the order of Fs/sigma0, not sliding travel
    assert np.ptp(sim.true_q) < 3 * spec.friction.Fs / spec.friction.sigma0


def test_stiff_contact_stays_stable_with_large_steps():
    p = LuGreParams(Fc=1500, Fs=1614, alpha=18, sigma0=1e6, sigma1=0.0, sigma2=11262)
    tau = 3000 * np.sin(np.linspace(0, 6 * np.pi, 3000))
    q, v, z, *_ = physics.simulate(tau, 1e-3, 1, 1.0, p.vector(), np.zeros(18), 0.0, 0.0, 0.0, 0.0)
    assert np.all(np.isfinite(q)) and np.max(np.abs(v)) < 1.0


def test_virtual_joint_advances_like_the_batch_simulation():
    spec = PRESETS["j4"]
    sim = simulate_record(spec, 1900.0, 0.3, duration=0.5, seed=0, torque_noise=0.0,
                          encoder_resolution=0.0)
    joint = VirtualJoint(spec, dt=1e-3, seed=0)
    joint.ev[:] = 0.0  # the batch record is gravity-compensated
    from virtual_drives.joint import sine_torque
    tau = sine_torque(1900.0, 0.3, np.arange(500) * 1e-3)
    qs = []
    for x in tau:
        qs.append(joint.state.q)
        joint.advance(x)
    assert np.allclose(qs, sim.true_q, atol=1e-12)
