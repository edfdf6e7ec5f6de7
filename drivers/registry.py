"""Open a drive by its joint dict.  Fakes register like real ones (labgrid spirit): each
driver module decorates its class with ``@register("<transport>")``; ``open_drive`` imports
the module of the requested transport lazily, so a bench with only serial drives never
imports python-canopen."""
from __future__ import annotations

import importlib
from typing import Callable

from bench.errors import InputError
from drivers.joint_config import TRANSPORTS, complete_joint
from drivers.protocols import TorqueDrive

DRIVERS: dict[str, Callable[[dict], TorqueDrive]] = {}
_MODULES = {"canopen": "drivers.canopen_402", "serial": "drivers.odrive_ascii",
            "simulated": "drivers.simulated"}


def register(transport: str):
    def decorate(cls):
        DRIVERS[transport] = cls
        return cls
    return decorate


def open_drive(joint: dict) -> TorqueDrive:
    """Connect to and configure the drive of ``joint`` (see ``drivers.joint_config``).
    Raises ``InputError`` for a bad configuration, ``DriveError`` when the drive fails."""
    j = complete_joint(joint)
    transport = j["transport"]
    if transport not in DRIVERS:
        if transport not in _MODULES:
            raise InputError(f"joint {j['id']!r}: no driver for transport {transport!r}; "
                             f"known: {', '.join(TRANSPORTS)}")
        module = importlib.import_module(_MODULES[transport])
        if transport not in DRIVERS:     # a plug module with a factory but no decorator
            factory = getattr(module, f"open_{transport}", None)
            if factory is None:
                raise InputError(f"joint {j['id']!r}: {module.__name__} registers no driver")
            DRIVERS[transport] = factory
    return DRIVERS[transport](j)
