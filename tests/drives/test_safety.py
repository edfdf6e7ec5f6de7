"""Interlocks and fault injection through the real protocol stacks: every failure ends in a
typed DriveError, and the caller can always bring the joint to a safe stop."""
from __future__ import annotations

import threading
import time

import pytest

from bench.errors import InputError
from drivers.protocols import (CommunicationTimeout, DriveError, DriveFault, DriveState,
                               LimitViolation, ProtocolViolation, WatchdogExpired)
from drivers.registry import open_drive

TRANSPORTS = ["canopen", "serial"]


def rotary(transport, **kw):
    return {"id": "rot", "preset": "rotary", "transport": transport, "checksum": True,
            "reply_timeout": 1.0, **kw}


def run_until_error(drive, torque, limit_s=10.0):
    samples = []
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        try:
            samples.append(drive.cycle(torque))
        except DriveError as exc:
            return exc, samples
    raise AssertionError("no DriveError raised")


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_software_limit_breach_quick_stops_in_the_same_cycle(rig, transport):
    vb, (drive,) = rig([rotary(transport, hold=6.2)])      # limits +-2 pi
    drive.enable()
    exc, samples = run_until_error(drive, 0.5)
    assert isinstance(exc, LimitViolation), exc
    hi = vb.joints[0]["position_limits"][1]
    assert all(s.position <= hi for s in samples)
    snap = vb.drive("rot").snapshot()
    # the breach happened in the period just run, and the drive is already stopping
    assert snap["steps"] == len(samples) + 1 and snap["q"] > hi
    assert snap["state"] in ("quick_stop", "disabled")
    # the caller keeps cycling (torque ignored) and watches the brake bring it to rest
    for _ in range(400):
        s = drive.cycle(0.5)
    assert s.state != DriveState.ENABLED     # serial: the ODrive endstop error stays latched
    assert vb.drive("rot").snapshot()["state"] == "disabled"
    assert abs(vb.drive("rot").snapshot()["v"]) < 1e-3


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_velocity_limit_and_torque_limit_stop_the_drive(rig, transport, wait_for):
    vb, (drive,) = rig([rotary(transport, velocity_limit=0.5)])
    drive.enable()
    exc, _ = run_until_error(drive, 0.4)
    assert isinstance(exc, LimitViolation) and "velocity" in str(exc)
    assert vb.drive("rot").snapshot()["state"] != "enabled"
    drive.enable()
    steps = vb.drive("rot").snapshot()["steps"]
    with pytest.raises(LimitViolation, match="torque command"):
        drive.cycle(1e3)                         # refused before anything is sent
    assert vb.drive("rot").snapshot()["steps"] == steps
    wait_for(lambda: vb.drive("rot").snapshot()["state"] != "enabled", what="quick stop")


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_silent_host_turns_the_drive_torque_off(rig, transport, wait_for):
    vb, (drive,) = rig([rotary(transport)])
    drive.enable()
    for _ in range(20):
        drive.cycle(0.05)
    assert vb.drive("rot").snapshot()["powered"]
    if transport == "canopen":
        drive._go_silent()       # no heartbeat, no SYNC, no frames: a dead host
    # (serial: the host simply stops sending; nothing feeds the ODrive watchdog)
    snap = wait_for(lambda: (lambda s: s if s["state"] == "fault" else None)(
        vb.drive("rot").snapshot()), what="drive watchdog")
    assert not snap["powered"] and snap["applied_torque"] == 0.0
    assert "host silent" in snap["fault_text"]
    assert snap["watchdog_gap"] >= vb.joints[0]["watchdog_s"]     # never early


FAULTS = [
    ("canopen", "drop_heartbeats", {}, WatchdogExpired),
    ("canopen", "emcy", {"code": 0x2310}, DriveFault),
    ("canopen", "freeze_status", {}, ProtocolViolation),
    ("canopen", "mute", {}, CommunicationTimeout),
    ("canopen", "late", {"delay": 3.0}, CommunicationTimeout),
    ("canopen", "glitch", {}, ProtocolViolation),
    ("serial", "mute", {}, CommunicationTimeout),
    ("serial", "corrupt_checksum", {}, ProtocolViolation),
    ("serial", "late", {"delay": 3.0}, CommunicationTimeout),
    ("serial", "glitch", {}, ProtocolViolation),
    ("serial", "fault", {"code": 0x40}, DriveFault),
]


@pytest.mark.parametrize("transport,fault,args,expected", FAULTS,
                         ids=[f"{t}-{f}" for t, f, _, _ in FAULTS])
def test_injected_fault_raises_typed_error_and_stops_safely(rig, transport, fault, args,
                                                            expected, wait_for):
    vb, (drive,) = rig([rotary(transport)])
    drive.enable()
    for _ in range(20):
        drive.cycle(0.05)
    vb.drive("rot").inject(fault, **args)
    exc, _ = run_until_error(drive, 0.05)
    assert type(exc) is expected, repr(exc)
    assert str(exc).startswith("rot: ") and "\n" not in str(exc)
    if expected is DriveFault:
        assert exc.code == args["code"]
    drive.quick_stop()           # never raises, whatever the drive is doing
    drive.disable()
    # safe: not following torque commands any more (a mute drive gets there by its own
    # watchdog, the others by our quick stop / disable)
    wait_for(lambda: vb.drive("rot").snapshot()["state"] != "enabled", what="safe stop")


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_recovers_from_one_bad_reply_or_garbage(rig, transport):
    vb, (drive,) = rig([rotary(transport)])
    drive.enable()
    drive.cycle(0.05)
    if transport == "serial":
        vb.drive("rot").inject("corrupt_checksum", count=1)
        drive.cycle(0.05)
        vb.drive("rot").inject("garbage", count=1)
        drive.cycle(0.05)
    vb.drive("rot").inject("emcy" if transport == "canopen" else "fault")
    with pytest.raises(DriveFault):
        drive.cycle(0.05)
    drive.enable()               # fault reset, re-armed
    assert drive.cycle(0.05).state == DriveState.ENABLED


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_quick_stop_never_raises_when_the_drive_is_gone(rig, transport):
    vb, (drive,) = rig([rotary(transport, reply_timeout=0.2)])
    drive.enable()
    vb.close()
    drive.quick_stop()
    drive.disable()
    with pytest.raises(DriveError):
        drive.cycle(0.0)


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_estop_confirms_torque_off_while_the_run_disables_the_drive(rig, transport):
    """The e-stop's torque_off and confirm_off from another thread while the control thread
    disables the drive (what a run does when it sees the stop): the drive's own state says
    torque off, and it never enables again."""
    vb, (drive,) = rig([rotary(transport)])
    drive.enable()
    for _ in range(20):
        drive.cycle(0.05)
    drive.torque_off()
    closing = threading.Thread(target=drive.disable)
    closing.start()
    state = drive.confirm_off(0.5)
    closing.join(5)
    assert state in (DriveState.QUICK_STOP, DriveState.DISABLED), state
    assert vb.drive("rot").snapshot()["state"] != "enabled"
    with pytest.raises(DriveError):
        drive.enable()


@pytest.mark.parametrize("joint,needle", [
    ({"id": "x", "preset": "rotary", "transport": "carrier-pigeon"}, "transport"),
    ({"id": "x", "preset": "rotary", "transport": "serial"}, "port"),
    ({"id": "x", "preset": "nope", "transport": "simulated"}, "preset"),
    ({"id": "x", "preset": "rotary", "transport": "canopen", "node_id": 0}, "node_id"),
    ({"id": "x", "preset": "rotary", "position_limits": [1, -1]}, "position_limits"),
    ({"id": "x", "preset": "rotary", "hold": 99.0}, "hold"),
    ({"preset": "rotary"}, "id"),
])
def test_bad_configuration_is_one_clear_line(joint, needle):
    with pytest.raises(InputError) as info:
        open_drive(joint)
    assert needle in str(info.value) and "\n" not in str(info.value)


def test_socketcand_server_stays_on_loopback():
    from virtual_drives.socketcand_server import SocketcandServer
    with pytest.raises(ValueError, match="loopback"):
        SocketcandServer("x", host="0.0.0.0")
