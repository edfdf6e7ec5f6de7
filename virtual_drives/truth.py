"""The physical truth of an emulated joint: its ``preset``, or its own ``physics`` table.

A bench TOML may describe a virtual joint by its physics instead of naming a preset, so a
user can rehearse a robot that does not exist yet and CI can put any joint through the real
stacks::

    [joints.physics]        # the emulated drive's true joint; the host keeps the joint's `inertia`
    inertia = 0.8
    friction = { Fc = 3.0, Fs = 4.0, alpha = 6.0, sigma0 = 2e3, sigma1 = 30.0, sigma2 = 2.0 }
    encoder_resolution = 2.4e-5      # default 1 / counts_per_unit
    torque_noise = 0.01              # default 0
    gravity = [0.0, 12.0]            # default: the joint's own (host) gravity model
    effects = ["cogging:amplitude=0.2,pitch=0.05"]   # bench simulate --effect syntax

Workspace, speed and torque limits are the joint's own keys (``position_limits``,
``velocity_limit``, ``torque_limit``).  ``check_physics`` validates the table (one line naming
the key); ``joint_truth`` is what the emulated drives build their ``VirtualJoint`` from.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bench.errors import InputError
from bench.lugre import PARAMETER_NAMES, LuGreParams
from bench.validate import config_number
from virtual_drives.joint import JointSpec
from virtual_drives.presets import preset

KEYS = ("inertia", "friction", "encoder_resolution", "torque_noise", "gravity", "effects")
FRICTION_KEYS = (*PARAMETER_NAMES, "delta")
# effects that are the physics table's own keys, not hidden terms: the true inertia is
# physics.inertia (the host's is the joint's `inertia`)
NOT_EFFECTS = {"inertia_error": "give the true inertia as physics.inertia (the host keeps the joint's inertia)"}


@dataclass
class Truth:
    spec: JointSpec
    extra: np.ndarray            # bench.terms vector of hidden physics (gravity excluded)
    torque_lag: float = 0.0      # s: the joint feels the command this late


def check_physics(physics, joint: dict, where: str) -> tuple[dict, list[str]]:
    """A validated copy of ``physics`` (numbers as floats, defaults filled) and warnings.
    ``joint`` is the joint's table (its limits and scaling); raises ``InputError``."""
    if not isinstance(physics, dict):
        raise InputError(f"{where}: physics must be a table ([joints.physics]), got {physics!r}")
    unknown = sorted(set(physics) - set(KEYS))
    if unknown:
        raise InputError(f"{where}: unknown key physics.{unknown[0]} (known: {', '.join(KEYS)})")
    out: dict = {"inertia": _number(physics, "inertia", where)}
    fr = physics.get("friction")
    if not isinstance(fr, dict):
        raise InputError(f"{where}: physics.friction must be a table "
                         f"{{Fc, Fs, alpha, sigma0, sigma1, sigma2}}, got {fr!r}")
    bad = sorted(set(fr) - set(FRICTION_KEYS))
    if bad:
        raise InputError(f"{where}: unknown key physics.friction.{bad[0]} (known: {', '.join(FRICTION_KEYS)})")
    friction = {}
    for k in PARAMETER_NAMES:
        if k not in fr:
            raise InputError(f"{where}: missing physics.friction.{k}")
        friction[k] = config_number(fr[k], f"{where}: physics.friction.{k}",
                                    positive=k in ("Fc", "Fs", "sigma0"))
        if friction[k] < 0:
            raise InputError(f"{where}: physics.friction.{k} must not be negative, got {fr[k]!r}")
    if "delta" in fr:
        friction["delta"] = config_number(fr["delta"], f"{where}: physics.friction.delta")
    out["friction"] = friction
    cpu = joint.get("counts_per_unit")
    default_res = 1.0 / cpu if isinstance(cpu, (int, float)) and not isinstance(cpu, bool) and cpu > 0 else None
    if "encoder_resolution" in physics or default_res is None:
        out["encoder_resolution"] = _number(physics, "encoder_resolution", where)
    else:
        out["encoder_resolution"] = default_res
    out["torque_noise"] = (_number(physics, "torque_noise", where, positive=False)
                           if "torque_noise" in physics else 0.0)
    if out["torque_noise"] < 0:
        raise InputError(f"{where}: physics.torque_noise must not be negative, got {physics['torque_noise']!r}")
    if "gravity" in physics:
        g = physics["gravity"]
        if (not isinstance(g, list) or len(g) != 2 or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in g)):
            raise InputError(f"{where}: physics.gravity must be a list of two numbers [a, b], got {g!r}")
        out["gravity"] = [float(g[0]), float(g[1])]
    effects = physics.get("effects", [])
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        raise InputError(f"{where}: physics.effects must be a list of strings like "
                         f"\"cogging:amplitude=0.2,pitch=0.05\", got {effects!r}")
    out["effects"] = list(effects)
    warnings = []
    try:
        params = LuGreParams(**friction)
        spec = _spec(out, {**joint, "id": joint.get("id", "joint")}, params)
        _injected(out["effects"], spec)      # torque_lag: the drive core's delay line
    except InputError as e:
        raise InputError(f"{where}: physics.effects: {e}") from None
    pw = params.passivity_warning()
    if pw:
        warnings.append(f"{where}: physics.friction: {pw}")
    return out, warnings


def _number(p: dict, key: str, where: str, positive: bool = True) -> float:
    if key not in p:
        raise InputError(f"{where}: missing physics.{key}")
    return config_number(p[key], f"{where}: physics.{key}", positive)


def _spec(physics: dict, joint: dict, friction: LuGreParams) -> JointSpec:
    lo, hi = (float(x) for x in joint["position_limits"])
    return JointSpec(
        name=str(joint["id"]), joint_type=joint.get("joint_type", "revolute"),
        inertia=physics["inertia"], friction=friction, position_limits=(lo, hi),
        velocity_limit=float(joint["velocity_limit"]), torque_limit=float(joint["torque_limit"]),
        encoder_resolution=physics["encoder_resolution"], torque_noise=physics["torque_noise"],
        gravity=tuple(physics.get("gravity", joint.get("gravity", (0.0, 0.0)))),
        description=f"joint {joint['id']} described by its physics")


def _injected(effects: list[str], spec: JointSpec):
    from bench.effects.inject import parse_injection, parse_injections
    for text in effects:
        name = parse_injection(text)[0]
        if name in NOT_EFFECTS:
            raise InputError(f"{text!r}: {NOT_EFFECTS[name]}")
    return parse_injections(effects, spec)


def joint_spec(joint: dict) -> JointSpec:
    """The emulated joint's base truth: its preset with the joint's gravity, or its own
    ``physics`` table (hidden effects not applied: ``joint_effects``)."""
    physics = joint.get("physics")
    if physics is None:
        return preset(joint["preset"]).with_(gravity=tuple(joint["gravity"]))
    p, _ = check_physics(physics, joint, f"joint {joint.get('id')!r}")
    return _spec(p, joint, LuGreParams(**p["friction"]))


def joint_effects(joint: dict) -> list[str]:
    """Injection texts hidden in the emulated joint: the joint's ``effects`` and its physics
    table's."""
    return list(joint.get("effects") or []) + list((joint.get("physics") or {}).get("effects", []))


def joint_truth(joint: dict) -> Truth:
    """What the emulated drive of a (completed) joint dict is: ``joint_spec`` with its effects
    (``joint_effects``) and any raw ``extra`` terms vector added."""
    spec = joint_spec(joint)
    ev, _, delta, lag = _injected(joint_effects(joint), spec)
    if delta is not None:
        spec = spec.with_(friction=spec.friction.with_(delta=delta))
    if joint.get("extra") is not None:
        ev = ev + np.asarray(joint["extra"], float)
    return Truth(spec=spec, extra=ev, torque_lag=float(lag))
