"""The effect library: physical terms that extend the LuGre joint, each in its own module.

To add an effect, write a module with an ``Effect`` subclass (see ``base.py``) and list it
here; the diagnosis, ``bench analyze --add`` and ``bench simulate --effect`` pick it up.
"""
from __future__ import annotations

from bench.effects.backlash import Backlash
from bench.effects.base import Context, Effect
from bench.effects.cogging import Cogging
from bench.effects.damping_fade import DampingFade
from bench.effects.direction_asymmetry import DirectionAsymmetry
from bench.effects.gravity import Gravity
from bench.effects.inertia_error import InertiaError
from bench.effects.joint_flexibility import JointFlexibility
from bench.effects.position_dependent_friction import PositionDependentFriction
from bench.effects.stribeck_shape import StribeckShape
from bench.effects.thermal_drift import ThermalDrift
from bench.effects.torque_lag import TorqueLag
from bench.effects.torque_offset import TorqueOffset
from bench.errors import InputError

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    InertiaError(), DirectionAsymmetry(), Cogging(), PositionDependentFriction(),
    Gravity(), TorqueOffset(), ThermalDrift(), StribeckShape(), TorqueLag(), Backlash(),
    JointFlexibility(), DampingFade(),
)}


def get(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except KeyError:
        raise InputError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None


__all__ = ["EFFECTS", "Context", "Effect", "get"]
