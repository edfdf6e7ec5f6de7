"""The one place a procedure gets drives from.

Dispatch is by ``joint["transport"]``: the driver registry (``drivers.registry.open_drive``)
when it is installed, else the in-process simulated plug for every joint (lock-step virtual
bench).  ``force_simulated`` makes every joint simulated whatever its transport: the fast
``--transport simulated`` path and unit tests.  By default ``calibrate`` opens the bench's
emulated CANopen / serial drives (``virtual_drives.launch.VirtualBench``) through the
registry, i.e. through the real protocol stacks.
"""
from __future__ import annotations

import importlib

from bench.errors import InputError
from drivers.protocols import TorqueDrive


def registry_available() -> bool:
    try:
        importlib.import_module("drivers.registry")
        return True
    except ImportError:
        return False


def open_drive(joint: dict, force_simulated: bool = False) -> TorqueDrive:
    if force_simulated or joint.get("transport") == "simulated" or not registry_available():
        factory = importlib.import_module("drivers.simulated").open_simulated
        return factory(dict(joint, transport="simulated"))
    return importlib.import_module("drivers.registry").open_drive(joint)


def open_drives(joints: list[dict], force_simulated: bool = False, seed: int = 0,
                control_period: float = 0.001, clock: str | None = None) -> dict[str, TorqueDrive]:
    """``clock``: the bench's clock, for joints that do not set their own (a lock-step bench's
    drives judge motion by control periods, not by the host's wall time)."""
    drives: dict[str, TorqueDrive] = {}
    try:
        for n, j in enumerate(joints):
            jj = dict(j, seed=seed * 101 + n, control_period=control_period)
            if clock is not None:
                jj.setdefault("clock", clock)
            drives[j["id"]] = open_drive(jj, force_simulated)
    except Exception as e:
        for d in drives.values():
            d.close()
        if isinstance(e, InputError):
            raise
        raise InputError(f"cannot open the drives: {e}") from None
    return drives
