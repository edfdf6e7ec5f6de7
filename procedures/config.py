"""Bench configuration: a TOML file listing the joints of one bench.

A joint is a plain dict with the shared schema (id, preset, transport, node_id, interface,
channel, bitrate, host, port, baudrate, axis, checksum, counts_per_unit, rated_torque,
inertia, gravity, position_limits, velocity_limit, torque_limit, hold, heartbeat_ms,
watchdog_s) so that the driver registry, the virtual bench and the procedures all read the
same thing.  A virtual joint may carry ``physics``, its own truth instead of a ``preset``
(``[joints.physics]`` after its ``[[joints]]``; see ``virtual_drives.truth``).  ``load_bench``
validates it and raises ``InputError`` with one line naming the problem.  Built-in benches (``micro2``, ``macro4``) ship as package data next to this module.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from bench.errors import InputError
from bench.validate import config_number

TRANSPORTS = ("canopen", "serial", "simulated")
BUILTIN = ("micro2", "macro4")
_NUMBER = (int, float)


@dataclass
class BenchConfig:
    name: str
    joints: list[dict]
    control_period: float = 0.001
    clock: str = "lockstep"
    description: str = ""
    source: str = ""
    raw: dict = field(default_factory=dict)
    # lock-step only: a held joint at rest is cycled once per idle_period (procedures.rig)
    idle_period: float = 0.02
    # not errors: e.g. a [joints.physics] friction that is not passive (Section II)
    warnings: list[str] = field(default_factory=list)

    def joint(self, joint_id: str) -> dict:
        for j in self.joints:
            if j["id"] == joint_id:
                return j
        raise InputError(f"bench {self.name!r} has no joint {joint_id!r}; "
                         f"joints: {', '.join(self.ids)}")

    @property
    def ids(self) -> list[str]:
        return [j["id"] for j in self.joints]

    def select(self, ids: list[str] | None) -> list[str]:
        if not ids:
            return self.ids
        for i in ids:
            self.joint(i)
        return list(ids)


def load_bench(spec: str | Path) -> BenchConfig:
    """A built-in bench name (``micro2``, ``macro4``) or a path to a TOML file."""
    text, source = _read(spec)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{source}: not valid TOML ({e})") from None
    return parse_bench(raw, source)


def _read(spec: str | Path) -> tuple[str, str]:
    s = str(spec)
    if s in BUILTIN:
        return resources.files("procedures.benches").joinpath(f"{s}.toml").read_text(), f"preset {s}"
    p = Path(s)
    if not p.exists():
        raise InputError(f"{s}: no such bench file and not a built-in bench ({', '.join(BUILTIN)})")
    try:
        return p.read_text(), s
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{s}: cannot read ({e.__class__.__name__})") from None


def parse_bench(raw: dict, source: str = "bench") -> BenchConfig:
    joints = raw.get("joints")
    if not isinstance(joints, list) or not joints:
        raise InputError(f"{source}: no [[joints]] tables")
    period = raw.get("control_period", 0.001)
    if not isinstance(period, _NUMBER) or not (0 < period <= 0.1):
        raise InputError(f"{source}: control_period must be a number in (0, 0.1] s, got {period!r}")
    clock = raw.get("clock", "lockstep")
    if clock not in ("lockstep", "realtime"):
        raise InputError(f"{source}: clock must be lockstep or realtime, got {clock!r}")
    idle = raw.get("idle_period", max(0.02, float(period)))
    if isinstance(idle, bool) or not isinstance(idle, _NUMBER) or not (period <= idle <= 0.1):
        raise InputError(f"{source}: idle_period must be a number in [control_period, 0.1] s, got {idle!r}")
    seen: set[str] = set()
    out, warnings = [], []
    for n, j in enumerate(joints, start=1):
        jj = _validate_joint(j, f"{source}: joint #{n}", warnings)
        if jj["id"] in seen:
            raise InputError(f"{source}: duplicate joint id {jj['id']!r}")
        seen.add(jj["id"])
        out.append(jj)
    for j in out:  # an inertia table may be keyed on another joint of the bench
        key = j["inertia"].get("joint") if isinstance(j["inertia"], dict) else None
        if key is not None and key not in seen:
            raise InputError(f"{source}: joint {j['id']!r}: inertia table refers to unknown joint {key!r}")
    return BenchConfig(name=str(raw.get("name", Path(source).stem)), joints=out,
                       control_period=float(period), clock=clock,
                       description=str(raw.get("description", "")), source=source, raw=raw,
                       idle_period=float(idle), warnings=warnings)


def _num(j: dict, key: str, where: str, positive: bool = True, default=None) -> float:
    if key not in j:
        if default is not None:
            return default
        raise InputError(f"{where}: missing {key}")
    return config_number(j[key], f"{where}: {key}", positive)


def _pair(j: dict, key: str, where: str, default=None) -> list[float]:
    v = j.get(key, default)
    if v is None:
        raise InputError(f"{where}: missing {key}")
    if (not isinstance(v, list) or len(v) != 2
            or not all(isinstance(x, _NUMBER) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
        raise InputError(f"{where}: {key} must be a list of two numbers, got {v!r}")
    return [float(v[0]), float(v[1])]


def _validate_joint(j, where: str, warnings: list[str]) -> dict:
    if not isinstance(j, dict):
        raise InputError(f"{where}: must be a table")
    jid = j.get("id")
    if not isinstance(jid, str) or not jid or any(c in jid for c in " ,/\\"):
        raise InputError(f"{where}: id must be a non-empty name without spaces, commas or slashes, got {jid!r}")
    where = f"{where.rsplit(': ', 1)[0]}: joint {jid!r}"
    out = dict(j)
    transport = j.get("transport")
    if transport not in TRANSPORTS:
        raise InputError(f"{where}: transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
    if "preset" in j and not isinstance(j["preset"], str):
        raise InputError(f"{where}: preset must be a virtual joint preset name")
    if "preset" in j and "physics" in j:
        raise InputError(f"{where}: give either preset or [joints.physics] (the emulated joint's "
                         f"truth), not both")
    jt = j.get("joint_type", "revolute")
    if jt not in ("revolute", "prismatic"):
        raise InputError(f"{where}: joint_type must be revolute or prismatic, got {jt!r}")
    out["joint_type"] = jt
    lo, hi = _pair(j, "position_limits", where)
    if not lo < hi:
        raise InputError(f"{where}: position_limits must be [lo, hi] with lo < hi, got {[lo, hi]}")
    out["position_limits"] = [lo, hi]
    out["velocity_limit"] = _num(j, "velocity_limit", where)
    out["torque_limit"] = _num(j, "torque_limit", where)
    out["gravity"] = _pair(j, "gravity", where, default=[0.0, 0.0])
    out["inertia"] = _validate_inertia(j.get("inertia"), where)
    hold = _num(j, "hold", where, positive=False, default=0.5 * (lo + hi))
    if not lo < hold < hi:
        raise InputError(f"{where}: hold position {hold} is outside position_limits [{lo}, {hi}]")
    out["hold"] = hold
    for key in ("heartbeat_ms", "watchdog_s", "rated_torque", "counts_per_unit", "baudrate", "bitrate"):
        if key in j:
            out[key] = _num(j, key, where)
    if "physics" in j:
        from virtual_drives.truth import check_physics   # the emulated joint's own truth
        out["physics"], warns = check_physics(j["physics"], out, where)
        warnings.extend(warns)
    return out


def _validate_inertia(v, where: str):
    if v is None:
        raise InputError(f"{where}: missing inertia (the declared M_jj)")
    if isinstance(v, _NUMBER) and not isinstance(v, bool):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{where}: inertia must be positive, got {v!r}")
        return float(v)
    if isinstance(v, dict):
        q, val = v.get("q"), v.get("value")
        ok = (isinstance(q, list) and isinstance(val, list) and len(q) == len(val) >= 1
              and all(isinstance(x, _NUMBER) for x in q + val))
        if not ok:
            raise InputError(f"{where}: inertia table needs equal-length number lists q and value")
        if any(b <= a for a, b in zip(q, q[1:])) or any(x <= 0 for x in val):
            raise InputError(f"{where}: inertia table q must increase and every value be positive")
        return {"joint": v.get("joint"), "q": [float(x) for x in q], "value": [float(x) for x in val]}
    raise InputError(f"{where}: inertia must be a number or a table {{joint, q, value}}, got {v!r}")


def declared_inertia(joint: dict, positions: dict[str, float]) -> float:
    """M_jj for the configuration ``positions`` (joint id -> position).  A table is
    interpolated linearly on the position of its key joint (the joint itself by default)."""
    m = joint["inertia"]
    if not isinstance(m, dict):
        return float(m)
    key = m.get("joint") or joint["id"]
    x = positions.get(key, joint["hold"] if key == joint["id"] else 0.0)
    return float(np.interp(x, m["q"], m["value"]))


def gravity_torque(joint: dict, q: float) -> float:
    """The host's gravity model a sin q + b cos q."""
    a, b = joint["gravity"]
    return a * math.sin(q) + b * math.cos(q) if (a or b) else 0.0
