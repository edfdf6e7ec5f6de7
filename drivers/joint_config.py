"""The joint dict: one joint's configuration, shared by bench configs (TOML), the drivers
and the virtual drives.  ``complete_joint`` checks it and fills every missing key with a
default derived from the joint's preset, so each consumer reads one complete dict.

Keys (units: rad / N·m for revolute joints, m / N for prismatic ones):
  id, preset, transport ("canopen" | "serial" | "simulated")
  physics : the emulated joint's own physics instead of a preset (virtual_drives.truth)
  CANopen : node_id, interface, channel, bitrate, host, port (socketcand), host_node_id
  serial  : port (device path), baudrate, axis, checksum, turns_per_unit
  scaling : counts_per_unit (encoder counts per unit), rated_torque (N·m at 1000 per-mille)
  model   : inertia (declared M_jj: number or table {joint, q, value}), gravity [a, b],
            extra (bench.terms vector, virtual drives only), q0 (virtual start position)
  safety  : position_limits [lo, hi], velocity_limit, torque_limit, hold (lock position),
            brake (holding brake while unpowered), heartbeat_ms, watchdog_s, reply_timeout
  timing  : clock ("realtime" | "lockstep"), control_period (s)
"""
from __future__ import annotations

import math

from bench.errors import InputError
from bench.validate import config_number

TRANSPORTS = ("canopen", "serial", "simulated")
CLOCKS = ("realtime", "lockstep")


def _num(joint: dict, key: str, positive: bool = True) -> float:
    return config_number(joint[key], f"joint {joint.get('id')!r}: {key}", positive)


def _pair(joint: dict, key: str, ordered: bool) -> list[float]:
    value = joint[key]
    try:
        a, b = (float(x) for x in value)
    except (TypeError, ValueError):
        raise InputError(f"joint {joint.get('id')!r}: {key} must be a pair of numbers, "
                         f"got {value!r}") from None
    if ordered and not a < b:
        raise InputError(f"joint {joint.get('id')!r}: {key} must be [lo, hi] with lo < hi, "
                         f"got {value!r}")
    return [a, b]


def complete_joint(joint: dict) -> dict:
    """Return a new, checked joint dict with every key present.  Raises ``InputError``."""
    if not isinstance(joint, dict):
        raise InputError(f"a joint must be a table of settings, got {joint!r}")
    j = dict(joint)
    if not isinstance(j.get("id"), str) or not j["id"]:
        raise InputError(f"every joint needs a non-empty string 'id', got {j.get('id')!r}")
    name = j["id"]
    transport = j.get("transport", "simulated")
    if transport not in TRANSPORTS:
        raise InputError(f"joint {name!r}: transport must be one of {', '.join(TRANSPORTS)}, "
                         f"got {transport!r}")
    j["transport"] = transport

    spec = None
    if j.get("preset") is not None:
        from virtual_drives.presets import preset
        spec = preset(j["preset"])          # InputError for an unknown name
    physics = j.get("physics")
    if spec is None and isinstance(physics, dict) and "encoder_resolution" in physics:
        # a joint described by its own physics: the host's scaling defaults to its encoder
        j.setdefault("counts_per_unit", 1.0 / config_number(
            physics["encoder_resolution"], f"joint {name!r}: physics.encoder_resolution"))
    needed = ("position_limits", "velocity_limit", "torque_limit", "counts_per_unit")
    if spec is None and any(k not in j for k in needed):
        raise InputError(f"joint {name!r}: give a 'preset' or all of {', '.join(needed)}")
    if spec is not None:
        j.setdefault("inertia", spec.inertia)
        j.setdefault("gravity", list(spec.gravity))
        j.setdefault("position_limits", list(spec.position_limits))
        j.setdefault("velocity_limit", spec.velocity_limit)
        j.setdefault("torque_limit", spec.torque_limit)
        j.setdefault("counts_per_unit", 1.0 / spec.encoder_resolution)
        j.setdefault("joint_type", spec.joint_type)
    j.setdefault("inertia", 1.0)
    j.setdefault("gravity", [0.0, 0.0])
    j.setdefault("joint_type", "revolute")
    for key in ("velocity_limit", "torque_limit", "counts_per_unit"):
        j[key] = _num(j, key)
    inertia = j["inertia"]   # the declared M_jj: a number, or a table {joint, q, value}
    if isinstance(inertia, dict) and inertia.get("value"):
        try:
            values = [float(v) for v in inertia["value"]]
        except (TypeError, ValueError):
            raise InputError(f"joint {name!r}: inertia table values must be numbers") from None
        j["drive_inertia"] = sum(values) / len(values)
    else:
        j["drive_inertia"] = _num(j, "inertia")
    j["position_limits"] = _pair(j, "position_limits", ordered=True)
    j["gravity"] = _pair(j, "gravity", ordered=False)
    # 16-bit per-mille torque: a rated torque of torque_limit/30 covers +-torque_limit with
    # a resolution of torque_limit/30000 (0x6072 = 30000 per-mille).  0x6076 is in mN·m.
    j.setdefault("rated_torque", max(round(j["torque_limit"] / 30.0 * 1000.0), 1) / 1000.0)
    j["rated_torque"] = _num(j, "rated_torque")
    if j["torque_limit"] / j["rated_torque"] * 1000.0 > 32767:
        raise InputError(f"joint {name!r}: torque_limit {j['torque_limit']} is more than "
                         f"32.767 x rated_torque {j['rated_torque']}: not representable in 0x6071")
    lo, hi = j["position_limits"]
    j.setdefault("hold", 0.5 * (lo + hi))
    if isinstance(j["hold"], bool):
        raise InputError(f"joint {name!r}: hold is the lock position (a number), got {j['hold']!r}")
    j["hold"] = _num(j, "hold", positive=False)
    if not lo <= j["hold"] <= hi:
        raise InputError(f"joint {name!r}: hold position {j['hold']} is outside "
                         f"position_limits [{lo}, {hi}]")
    # a holding brake locks the joint whenever the power stage is off; gravity-loaded joints
    # have one unless told otherwise
    j["brake"] = bool(j.get("brake", j["gravity"] != [0.0, 0.0]))
    j.setdefault("heartbeat_ms", 50)
    j["heartbeat_ms"] = int(_num(j, "heartbeat_ms"))
    j.setdefault("watchdog_s", max(0.25, 4 * j["heartbeat_ms"] / 1000.0))
    j["watchdog_s"] = _num(j, "watchdog_s")
    if j["transport"] == "canopen" and j["watchdog_s"] * 1000 <= j["heartbeat_ms"]:
        raise InputError(f"joint {name!r}: watchdog_s ({j['watchdog_s']}) must exceed the "
                         f"heartbeat period ({j['heartbeat_ms']} ms)")
    j.setdefault("reply_timeout", 0.1)
    j["reply_timeout"] = _num(j, "reply_timeout")
    j.setdefault("clock", "realtime")
    if j["clock"] not in CLOCKS:
        raise InputError(f"joint {name!r}: clock must be one of {', '.join(CLOCKS)}, "
                         f"got {j['clock']!r}")
    j.setdefault("control_period", 0.001)
    j["control_period"] = _num(j, "control_period")

    if transport == "canopen":
        j.setdefault("node_id", 1)
        j.setdefault("host_node_id", 0x7F)
        for key in ("node_id", "host_node_id"):
            if not isinstance(j[key], int) or not 1 <= j[key] <= 127:
                raise InputError(f"joint {name!r}: {key} must be an integer 1..127, "
                                 f"got {j[key]!r}")
        if j["node_id"] == j["host_node_id"]:
            raise InputError(f"joint {name!r}: node_id equals the host's node id {j['node_id']}")
        j.setdefault("interface", "socketcan")
        j.setdefault("channel", "can0")
        j.setdefault("bitrate", 1_000_000)
        if j["interface"] == "socketcand":
            j.setdefault("host", "127.0.0.1")
            if not isinstance(j.get("port"), int):
                raise InputError(f"joint {name!r}: the socketcand interface needs an integer "
                                 f"'port', got {j.get('port')!r}")
    elif transport == "serial":
        if not isinstance(j.get("port"), str) or not j["port"]:
            raise InputError(f"joint {name!r}: a serial joint needs 'port', the device path "
                             f"(e.g. /dev/ttyACM0), got {j.get('port')!r}")
        j.setdefault("baudrate", 115200)
        j.setdefault("axis", 0)
        if j["axis"] not in (0, 1):
            raise InputError(f"joint {name!r}: axis must be 0 or 1, got {j['axis']!r}")
        j["checksum"] = bool(j.get("checksum", False))
        # ODrive reports turns; a direct-drive revolute joint has 1/(2 pi) turns per rad
        j.setdefault("turns_per_unit", 1.0 / (2.0 * math.pi) if j["joint_type"] == "revolute"
                     else 100.0)
        j["turns_per_unit"] = _num(j, "turns_per_unit")
    return j
