import pytest

from drivers.protocols import DriveFault, DriveState, LimitViolation, TorqueDrive
from drivers.simulated import open_simulated
from procedures.config import load_bench


def joint(jid="j3", **kw):
    return dict(load_bench("macro4").joint(jid), transport="simulated", **kw)


def test_protocol_and_enable_cycle():
    d = open_simulated(joint())
    assert isinstance(d, TorqueDrive)
    q0 = d.cycle(500.0).position
    assert d.status().state == DriveState.DISABLED
    for _ in range(200):  # disabled: brake holds, torque ignored
        s = d.cycle(500.0)
    assert s.position == q0 and s.velocity == 0.0
    d.enable()
    for _ in range(500):
        s = d.cycle(500.0)
    assert s.velocity > 0.01 and s.position > q0 and s.state == DriveState.ENABLED


def test_limit_violation_stops_and_faults():
    d = open_simulated(joint(position_limits=[-0.02, 0.02]))
    d.enable()
    with pytest.raises(LimitViolation):
        for _ in range(20000):
            d.cycle(1400.0)
    assert d.status().state == DriveState.FAULT and d.true_state.v == 0.0
    with pytest.raises(DriveFault):
        d.enable()


def test_quick_stop_brakes_to_rest_and_injected_fault():
    d = open_simulated(joint())
    d.enable()
    for _ in range(1000):
        d.cycle(350.0)
    assert d.true_state.v > 0.05
    d.quick_stop()
    assert d.true_state.v == 0.0 and d.status().state == DriveState.QUICK_STOP
    d.enable()
    d.inject_fault(3)
    with pytest.raises(DriveFault):
        for _ in range(5):
            d.cycle(0.0)
    assert d.status().state == DriveState.FAULT
