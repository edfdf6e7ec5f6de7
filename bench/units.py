"""The units a record can be in, and its conversion to SI (``bench.readers``): time s, ms, us,
ns; revolute rad, deg, rev and N*m, mN*m, kN*m, N*mm; prismatic m, mm, um and N, mN, kN; the
usual other spellings of each (``normalise``); any of them with a scale, K*UNIT
(``factor_of``).  What was converted is kept in ``Record.reading['units']`` for the report."""
from __future__ import annotations

import math
import re
import time

import numpy as np

from bench.errors import InputError
from bench.records import JOINT_TYPES, Record

POSITION_UNITS = {"revolute": {"rad": 1.0, "deg": math.pi / 180.0, "rev": 2.0 * math.pi},
                  "prismatic": {"m": 1.0, "mm": 1e-3, "um": 1e-6}}
TORQUE_UNITS = {"revolute": {"N*m": 1.0, "mN*m": 1e-3, "kN*m": 1e3, "N*mm": 1e-3},
                "prismatic": {"N": 1.0, "mN": 1e-3, "kN": 1e3}}
SI = {"revolute": ("rad", "N*m"), "prismatic": ("m", "N")}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
# {role: its table}; position and torque by joint type
TABLES = {"t": TIME_UNITS, "q": POSITION_UNITS, "tau": TORQUE_UNITS}
KNOWN = set(TIME_UNITS).union(*POSITION_UNITS.values(), *TORQUE_UNITS.values())
# how units are written, to the tables' spelling
ALIASES = {"sec": "s", "second": "s", "seconds": "s", "msec": "ms", "µs": "us", "usec": "us",
           "°": "deg", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad",
           "revolutions": "rev", "Nm": "N*m", "N.m": "N*m", "mNm": "mN*m", "kNm": "kN*m",
           "Nmm": "N*mm", "µm": "um"}
_SCALED = re.compile(r"^([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\*(.+)$")


def normalise(unit: str) -> str:
    u = unit.strip().replace(" ", "").replace("·", "*")
    return ALIASES.get(u, u)


def factor_of(unit: str, known: dict) -> tuple[float, str] | None:
    """(factor to SI, unit as spelled) for a unit of ``known`` ({unit: factor}), also written
    with a scale: "0.12*N*m" (a current in A with a torque constant of 0.12 N·m/A),
    "0.0015339808*rad" (encoder counts, 4096 a turn), "25*ns" (a 40 MHz tick); None if not
    a unit of ``known``."""
    u = normalise(unit)
    if u in known:
        return known[u], u
    m = _SCALED.match(u)
    if m and normalise(m.group(2)) in known and float(m.group(1)) > 0:
        return float(m.group(1)) * known[normalise(m.group(2))], u
    return None


# Seconds since 1970 a log can hold: from 2001-09-09 (1e9 s) to a day from now.  Counted in ms,
# us or ns the windows lie 1e3 apart and never overlap, and read in seconds such a count would
# lie millennia ahead: the magnitude names the unit (ROS's and rostopic's ns stamps, a ms
# logger's).  A counter since boot can land in a window too (us for 12-20 days read as ms since
# 1970), but then its step reads 1000x too long: only 20 Hz to 10 MHz is taken for a logger's
EPOCH_FROM = 1e9
EPOCH_STEP = (1e-7, 0.05)


def epoch_unit(t, now: float | None = None) -> str | None:
    """"ms", "us" or "ns" when every time in ``t`` is that unit counted since 1970 up to
    ``now`` (seconds since 1970; the clock's by default) and the median step in it is a
    logger's (``EPOCH_STEP``); else None."""
    t = np.asarray(t, dtype=float)
    if len(t) < 2 or not np.all(np.isfinite(t)):
        return None
    until = (time.time() if now is None else now) + 86400.0
    for unit in ("ms", "us", "ns"):
        k = TIME_UNITS[unit]
        if EPOCH_FROM <= t.min() * k and t.max() * k <= until:
            lo, hi = EPOCH_STEP
            return unit if lo <= float(np.median(np.diff(t))) * k <= hi else None
    return None


def to_si(rec: Record, name: str) -> None:
    jt = str(rec.meta.get("joint_type", "revolute"))
    if jt not in JOINT_TYPES:
        raise InputError(f"{name}: joint_type must be prismatic or revolute, not {jt!r}")
    conv = {}
    unit = rec.meta.get("time_unit")
    if unit is None and not rec.reading.get("clock_time") and (unit := epoch_unit(rec.t)):
        # ns since 1970 (ROS), say: told with the first sample's date
        rec.reading["epoch_time"] = {"unit": unit, "start": float(rec.t[0]) * TIME_UNITS[unit]}
    if unit is not None:
        found = factor_of(str(unit), TIME_UNITS)
        if found is None:
            raise InputError(f"{name}: time_unit {rec.meta['time_unit']!r} is not one of {', '.join(TIME_UNITS)} "
                             f"(or K*UNIT, e.g. 25*ns)")
        factor, unit = found
        rec.meta["time_unit"] = "s"
        # clock times (ISO 8601, Parquet timestamps) are read in seconds whatever the option
        if factor != 1.0 and not rec.reading.get("clock_time"):
            conv["time"] = {"from": unit, "to": "s", "factor": factor}
            rec.t = np.asarray(rec.t, dtype=float) * factor
    own = rec.reading.get("velocity_unit")     # a velocity column stating its own unit
    for key, table, role in (("position_unit", POSITION_UNITS, "position"), ("torque_unit", TORQUE_UNITS, "torque")):
        unit = rec.meta.get(key)
        if unit is None:
            continue
        known = table[jt]
        found = factor_of(str(unit), known)
        if found is None:
            raise InputError(f"{name}: {key} {rec.meta[key]!r} is not one for a {jt} joint "
                             f"(known: {', '.join(known)}, or K*UNIT such as 0.12*{SI[jt][1 if role == 'torque' else 0]})"
                             + _other_type(str(unit), table, jt))
        factor, unit = found
        if factor != 1.0:
            si = SI[jt][0 if role == "position" else 1]
            conv[role] = {"from": unit, "to": si, "factor": factor}
            rec.meta[key] = si
            if role == "position":
                rec.q = rec.q * factor
                if rec.qd is not None and not own:
                    rec.qd = rec.qd * factor
            else:
                rec.tau = rec.tau * factor
    if own and rec.qd is not None and not factor_of(own[0], VELOCITY_BY_TYPE[jt]):
        # a motor's rpm beside a ball screw's mm: no factor makes it this joint's velocity
        by_name = rec.reading.get("columns_by_name", {}).get("qd")
        if by_name is None or rec.reading.get("position_from") == "qd":
            # (a linear speed with nothing else stated made the joint prismatic: bench.header_units)
            raise InputError(f"{name}: the velocity column is in {own[0]}, not a unit for a {jt} joint "
                             f"(known: {', '.join(VELOCITY_BY_TYPE[jt])}); give it in one of them, or leave qd out")
        rec.reading["velocity_set_aside"] = f"the column {by_name!r} is in {own[0]}, not a {jt} joint's velocity unit"
        rec.qd, own = None, None
    if own and rec.qd is not None:
        unit, factor = own
        if factor != 1.0:
            conv["velocity"] = {"from": unit, "to": f"{SI[jt][0]}/s", "factor": factor}
            rec.qd = rec.qd * factor
    rec.reading["units"] = conv


# A velocity column's own unit, stated in its header ("speed [rpm]", "dq [deg/s]", "v_mm_s"):
# it was scaled by the position's factor, so a drive's rpm beside its degrees was refused
# by joint type, as the position's and torque's (a motor's rpm is no carriage's velocity)
VELOCITY_BY_TYPE = {"revolute": {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": math.pi / 30.0, "rev/s": 2.0 * math.pi},
                    "prismatic": {"m/s": 1.0, "mm/s": 1e-3, "um/s": 1e-6}}
VELOCITY_UNITS = {**VELOCITY_BY_TYPE["revolute"], **VELOCITY_BY_TYPE["prismatic"]}


def _other_type(unit: str, table: dict, jt: str) -> str:
    """The hint when a unit belongs to the other joint type: the joint type is what is wrong
    (a linear axis read as the default revolute one), not the unit."""
    other = next(t for t in JOINT_TYPES if t != jt)
    return f"; it is one for a {other} joint: give --joint-type {other} if the joint is one" \
        if factor_of(unit, table[other]) else ""


_VELOCITY_ALIASES = {"°/s": "deg/s", "1/min": "rpm", "r/min": "rpm", "rev/min": "rpm", "min^-1": "rpm",
                     "µm/s": "um/s"}


def velocity_factor(unit: str | None) -> tuple[str, float] | None:
    """(unit, factor to SI) for a velocity unit as headers write it ("deg/s", "rad_s",
    "deg_per_s", "RPM", "K*rad/s"); None if it is not one."""
    if not unit:
        return None
    u = str(unit).strip().replace(" ", "").replace("_per_", "/")
    u = re.sub(r"^(rad|deg|rev|m|mm|um)_s$", r"\1/s", u)
    u = _VELOCITY_ALIASES.get(u, u)
    u = u.lower() if u.lower() == "rpm" else u
    found = factor_of(u, VELOCITY_UNITS)
    return (found[1], found[0]) if found else None


# A position of whole numbers only, over this many of them, with no unit stated: no encoder
# resolves one radian or one metre, so these are counts (a drive's "Position actual value").
# Read as radians, j3's sine test in 4096-a-turn counts was refused as a clock or inertia
# error (M q'' 0.98x the friction at top speed), which sends a technician the wrong way.
WHOLE_COUNTS = 20


def whole_number_position(rec: Record) -> tuple[float, float] | None:
    """(lowest, highest) when ``rec.q`` holds whole numbers only, spanning at least
    ``WHOLE_COUNTS``, and no position unit is stated; else None."""
    if rec.meta.get("position_unit") is not None or rec.reading.get("position_from") == "qd":
        return None
    q = np.asarray(rec.q, dtype=float)
    q = q[np.isfinite(q)]
    if len(q) == 0 or np.ptp(q) < WHOLE_COUNTS or not np.all(q == np.round(q)):
        return None
    return float(q.min()), float(q.max())
