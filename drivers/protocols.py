"""What a procedure may ask of a drive.  Procedures import only this module, never a
concrete transport: a CANopen drive, an ODrive-ASCII drive and an in-process simulated
drive are interchangeable plugs.

The control primitive is ``cycle``: command the torque for the next control period and get
the newest timestamped sample back.  Real-time drives pace themselves on the wall clock;
lock-step virtual drives advance simulated time by one period per cycle.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable


class DriveState(str, enum.Enum):
    DISABLED = "disabled"        # power stage off, no torque
    ENABLED = "enabled"          # operation enabled, following torque commands
    QUICK_STOP = "quick_stop"    # braking to standstill, torque commands ignored
    FAULT = "fault"              # torque off until the fault is reset


@dataclass(frozen=True)
class Sample:
    """One measurement of an axis.  ``t`` is the drive's time base in seconds (simulated time
    for virtual drives), ``host_time`` the host's monotonic clock when it was received."""
    t: float
    position: float      # rad or m
    velocity: float      # rad/s or m/s
    torque: float        # N·m or N, the torque the drive reports applying
    state: DriveState = DriveState.ENABLED
    host_time: float = 0.0


@dataclass
class DriveStatus:
    state: DriveState
    faults: list[str] = field(default_factory=list)


# --- typed errors a caller can act on -----------------------------------------------------
class DriveError(Exception):
    """Base of every drive-side or transport error; the caller should bring the joint to a
    safe stop (``quick_stop`` / ``disable``) and report."""


class CommunicationTimeout(DriveError):
    """The drive did not answer within its deadline."""


class WatchdogExpired(DriveError):
    """Heartbeat or watchdog lost: one side considers the other dead."""


class DriveFault(DriveError):
    """The drive reported a fault (EMCY, error flags); ``code`` is the drive's code."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message)
        self.code = code


class ProtocolViolation(DriveError):
    """Garbled, out-of-sequence or checksum-failing data, or a status that stopped updating."""


class LimitViolation(DriveError):
    """A position, velocity or torque limit was reached; the drive has been stopped."""


# --- protocols (Bluesky/ophyd style: small, structural) -------------------------------------
@runtime_checkable
class Movable(Protocol):
    def cycle(self, torque: float) -> Sample:
        """Command ``torque`` for the next control period; return the newest sample."""


@runtime_checkable
class Stoppable(Protocol):
    def quick_stop(self) -> None:
        """Stop now: torque off / brake, whatever state the drive is in.  Never raises."""

    def disable(self) -> None:
        """Power stage off."""


@runtime_checkable
class Checkable(Protocol):
    def enable(self) -> None:
        """Bring the drive to operation enabled (torque 0), or raise ``DriveError``."""

    def status(self) -> DriveStatus:
        ...


@runtime_checkable
class TorqueDrive(Movable, Stoppable, Checkable, Protocol):
    """A torque-controlled axis with an encoder.  ``name`` identifies the joint."""
    name: str

    def close(self) -> None:
        ...
