"""Hidden physics in the emulated drives: an effect injected into a virtual joint
(``effects`` in its joint dict) reaches what the host records through
the real CANopen and serial stacks, and serial records carry measured torque noise."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bench.effects.inject import parse_injections
from virtual_drives.joint import VirtualJoint
from virtual_drives.presets import preset

EFFECTS = ["backlash:width=0.003", "torque_lag:delay=0.0025", "cogging:amplitude=0.02,pitch=0.3"]


def reference(joint: dict, effects: list[str]) -> tuple[VirtualJoint, float]:
    """The joint the drive should be: the gear and the cogging in its terms vector;
    returns it and the torque lag."""
    spec = preset(joint["preset"]).with_(gravity=tuple(joint["gravity"]))
    ev, _, _, lag = parse_injections(effects, spec)
    return VirtualJoint(spec, dt=joint["control_period"], extra=ev, q0=joint["hold"]), lag


def run(drive, taus):
    drive.enable()
    out = [drive.cycle(float(tau)) for tau in taus]
    drive.disable()
    return out


@pytest.mark.parametrize("transport", ["canopen", "serial"])
def test_injected_effects_reach_the_record(rig, transport):
    vb, (hidden, plain) = rig([
        {"id": "geared", "preset": "rotary", "transport": transport, "effects": EFFECTS},
        {"id": "rigid", "preset": "rotary", "transport": transport}])
    j = vb.joints[0]
    assert "effects" not in j and "extra" not in j          # hidden from the host
    dt, cpu, rated = j["control_period"], j["counts_per_unit"], j["rated_torque"]
    n = 300
    taus = 0.3 * np.sin(2 * math.pi * 4.0 * np.arange(n) * dt)
    applied = [round(t / rated * 1000) * rated / 1000 for t in taus] if transport == "canopen" \
        else [float(t) for t in taus]
    ref, lag = reference(j, EFFECTS)
    k, frac = int(lag // dt), lag / dt - int(lag // dt)
    expected = []
    for i in range(n):                        # the joint feels the command lag late
        felt = (1 - frac) * (applied[i - k] if i >= k else 0.0) + \
            frac * (applied[i - k - 1] if i >= k + 1 else 0.0)
        expected.append(ref.advance(felt).q)
    got = run(hidden, taus)
    rigid = run(plain, taus)
    q = np.array([s.position for s in got])
    assert np.max(np.abs(q - np.round(np.array(expected) * cpu) / cpu)) <= 0.51 / cpu
    # and the effects matter: far beyond the encoder's resolution
    assert np.max(np.abs(q - np.array([s.position for s in rigid]))) > 100 / cpu


@pytest.mark.parametrize("process", ["inproc"])
def test_serial_records_carry_measured_torque_noise_that_depends_on_the_seed(rig):
    torques = []
    for seed in (11, 12):
        _, (drive,) = rig([{"id": "r", "preset": "rotary", "transport": "serial"}], seed=seed)
        torques.append(np.array([s.torque for s in run(drive, [0.2] * 50)]))
    sigma = preset("rotary").torque_noise
    for tau in torques:
        assert np.all(np.abs(tau - 0.2) < 6 * sigma) and np.std(tau) > 0.3 * sigma
    assert not np.array_equal(torques[0], torques[1])
