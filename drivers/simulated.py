"""In-process simulated drive: ``TorqueDrive`` implemented directly on a ``VirtualJoint``.

Lock-step: each ``cycle`` advances the physics by exactly one control period, so procedures
can be unit-tested fast and deterministically.  It behaves like the real plugs where a
procedure can notice: it starts disabled, refuses torque until enabled, clamps torque at the
drive's limit (current limit), stops itself with ``LimitViolation`` when a position or velocity
limit is crossed, brakes to standstill on quick stop and holds there (holding brake) while
disabled, and reports the torque applied during the period that ``cycle`` just ran.

Faults can be injected (``inject_fault``) to test a procedure's reaction to drive errors.
"""
from __future__ import annotations

import time

from drivers.protocols import (DriveError, DriveFault, DriveState, DriveStatus, LimitViolation,
                               Sample)
from virtual_drives.joint import VirtualJoint
from virtual_drives.presets import preset
from virtual_drives.truth import joint_truth

_BRAKE_MAX_S = 30.0  # a quick stop that has not stopped the axis by then leaves it braked


class SimulatedDrive:
    def __init__(self, joint: dict, control_period: float | None = None, seed: int | None = None):
        self.name = str(joint["id"])
        self.joint = joint
        truth = joint_truth(joint) if joint.get("physics") is not None else None
        spec = truth.spec if truth else preset(joint.get("preset", self.name))
        self.dt = float(control_period or joint.get("control_period", 0.001))
        lo, hi = joint.get("position_limits", spec.position_limits)
        self.limits = (float(lo), float(hi))
        self.velocity_limit = float(joint.get("velocity_limit", spec.velocity_limit))
        self.torque_limit = float(joint.get("torque_limit", spec.torque_limit))
        start = joint.get("start", joint.get("hold"))
        self.vj = VirtualJoint(spec, dt=self.dt, seed=int(joint.get("seed", 0) if seed is None else seed),
                               q0=None if start is None else float(start),
                               extra=truth.extra if truth else None)
        self.state = DriveState.DISABLED
        self.faults: list[str] = []
        self.cycles = 0
        self._fault_at: tuple[int, DriveError] | None = None
        self._braked_t = 0.0  # simulated time spent with the holding brake engaged

    # --- Checkable -------------------------------------------------------------------------
    def enable(self) -> None:
        if self.state == DriveState.FAULT:
            raise DriveFault(f"{self.name}: drive in fault ({'; '.join(self.faults)}); reset it first")
        self.state = DriveState.ENABLED

    def status(self) -> DriveStatus:
        return DriveStatus(self.state, list(self.faults))

    def reset_fault(self) -> None:
        self.faults.clear()
        self.state = DriveState.DISABLED

    # --- Movable ---------------------------------------------------------------------------
    def cycle(self, torque: float) -> Sample:
        self.cycles += 1
        if self._fault_at is not None and self.cycles >= self._fault_at[0]:
            exc = self._fault_at[1]
            self._fault_at = None
            self._fault(str(exc))
            raise exc
        if self.state != DriveState.ENABLED:
            self._hold_braked()
            return self._sample()
        tau = max(-self.torque_limit, min(self.torque_limit, float(torque)))
        s = self.vj.advance(tau)
        lo, hi = self.limits
        if not (lo <= s.q <= hi) or abs(s.v) > self.velocity_limit:
            what = (f"position {s.q:.6g} outside [{lo:.6g}, {hi:.6g}]" if not lo <= s.q <= hi
                    else f"velocity {s.v:.6g} beyond ±{self.velocity_limit:.6g}")
            self.quick_stop()
            self.faults.append(what)
            self.state = DriveState.FAULT
            raise LimitViolation(f"{self.name}: {what}; drive stopped")
        return self._sample()

    # --- Stoppable -------------------------------------------------------------------------
    def quick_stop(self) -> None:
        """Brake with full torque against the motion until standstill, then hold."""
        try:
            steps = int(_BRAKE_MAX_S / self.dt)
            for _ in range(steps):
                v = self.vj.state.v
                if abs(v) < 1e-6:
                    break
                # full torque against the motion, never so much that it reverses it in one step
                stop = self.vj.spec.inertia * abs(v) / self.dt
                self.vj.advance(-min(self.torque_limit, stop) * (1 if v > 0 else -1))
            self._engage_brake()
        except Exception:  # never raises: a quick stop must always succeed
            pass
        if self.state != DriveState.FAULT:
            self.state = DriveState.QUICK_STOP

    def disable(self) -> None:
        self._engage_brake()
        if self.state != DriveState.FAULT:
            self.state = DriveState.DISABLED

    def close(self) -> None:
        self.disable()

    # --- test hooks ------------------------------------------------------------------------
    def inject_fault(self, after_cycles: int, exc: DriveError | None = None) -> None:
        """Raise ``exc`` (default: a DriveFault) on the ``after_cycles``-th next cycle."""
        self._fault_at = (self.cycles + int(after_cycles),
                          exc or DriveFault(f"{self.name}: injected fault", code=0x5530))

    @property
    def true_state(self):
        return self.vj.state

    # --- internals -------------------------------------------------------------------------
    def _fault(self, what: str) -> None:
        self.quick_stop()
        self.faults.append(what)
        self.state = DriveState.FAULT

    def _engage_brake(self) -> None:
        s = self.vj.state
        s.v = 0.0
        self.vj.applied_torque = 0.0

    def _hold_braked(self) -> None:
        # holding brake: the axis does not move, time still passes
        self.vj.state.t += self.dt
        self.vj.state.v = 0.0
        self.vj.applied_torque = 0.0

    def _sample(self) -> Sample:
        return Sample(t=self.vj.state.t, position=float(self.vj.measured_position()),
                      velocity=float(self.vj.measured_velocity()),
                      torque=float(self.vj.measured_torque()), state=self.state,
                      host_time=time.monotonic())


def open_simulated(joint: dict) -> SimulatedDrive:
    """Plug factory for transport = "simulated" (the driver registry dispatches here)."""
    return SimulatedDrive(joint)
