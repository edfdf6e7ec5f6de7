"""Units a file states in its header: in a column's name ("angle [deg]", "torque (Nm)", "t/ms")
or in a units row under the header ("s;Nm;rad", as data-acquisition exports write it).

Left unread, an angle logged in degrees was analysed as radians without a word (σ0, σ2 and α
off by 57x, every parameter in the wrong unit).  A stated unit is used when the option or a
``#`` metadata line does not give one (they win), and the report lists what was taken from
the header.  A unit that is not one for the column's role (amperes for a torque, counts for
a position) is left alone and said in a warning: the column is then taken in SI.
"""
from __future__ import annotations

import re

from bench.errors import InputError
from bench.units import KNOWN, SI, TABLES, VELOCITY_BY_TYPE, factor_of, normalise

# "name [unit]", "name (unit)" or "name/unit" at the end of a column name
_BRACKETED = re.compile(r"[\[(]\s*([^\[\]()]+?)\s*[\])]\s*$")
_SLASHED = re.compile(r"^[A-Za-z_][\w .]*/\s*([\wµ°·*.+-]+)\s*$")

KEYS = {"t": "time_unit", "q": "position_unit", "tau": "torque_unit"}
ROLE_NAMES = {"t": "time", "q": "position", "tau": "torque or force"}
_ANY_UNIT = dict.fromkeys(KNOWN, 1.0)     # for factor_of: is it a unit at all, scaled or not


def split_unit(name: str) -> tuple[str, str | None]:
    """A column's name and the unit it ends with (None if it states none).  "name/token" only
    when the token is a unit ("joint1/position" is a path, not a unit); a bracketed token also
    when it looks like one (short, no blank: "[A]", "(counts)"), so that a unit we cannot
    convert is said."""
    m = _BRACKETED.search(name)
    # "q(2)", "position[3]": a matrix's column or a joint's index, not a unit
    if m and not m.group(1).strip().isdigit() and (is_unit(m.group(1)) or (len(m.group(1)) <= 6 and " " not in m.group(1))):
        return name[:m.start(1)].rstrip(" [("), m.group(1).strip()
    m = _SLASHED.match(name)
    if m and is_unit(m.group(1)):
        return name[:m.start(1)].rstrip(" /"), m.group(1).strip()
    return name, None


def unit_in_name(name: str) -> str | None:
    """The unit a column's name ends with, or None (``split_unit``)."""
    return split_unit(name)[1]


def is_unit(text: str) -> bool:
    """Whether ``text`` is a unit this tool converts, bare or with a scale ("K*UNIT")."""
    return factor_of(text, _ANY_UNIT) is not None


def split_units_row(header: list[str], second: list[str]) -> dict | None:
    """What the line under a named header is: None for data (a number in it, or an empty
    field: a data row with a lost cell has numbers beside it); else {column: unit}, empty
    when no field is a unit we know -- a row of descriptions ("Joint angle", "Motor torque"),
    skipped like a units row without each word being warned as a unit it is not."""
    if len(second) != len(header) or not all(f.strip() for f in second):
        return None
    for f in second:
        try:
            float(f.replace(",", "."))
            return None
        except ValueError:
            pass
    units = {h: f.strip().strip('"').strip("[]()") for h, f in zip(header, second)}
    return units if any(is_unit(u) for u in units.values()) else {}


def _joint_types(units: dict, speed: str | None) -> dict:
    """{"q in deg": "revolute", ...}: the joint type each stated unit belongs to alone.  The
    velocity's counts only when neither the position nor the torque states one: a ball
    screw's motor speed in rpm beside its carriage's mm is a log of a prismatic joint."""
    out = {}
    for role in ("q", "tau"):
        kinds = [jt for jt, known in TABLES[role].items() if factor_of(units.get(role) or "", known)]
        if len(kinds) == 1:
            out[f"{role} in {units[role]}"] = kinds[0]
    if not out and speed and factor_of(speed, VELOCITY_BY_TYPE["prismatic"]):
        out[f"qd in {speed}"] = "prismatic"
    return out


def apply(rec, name: str) -> None:
    """Take the units ``rec.reading['stated_units']`` ({role: unit as written}) states where
    no option or metadata line gave one; a length or force unit with no joint type stated
    makes the joint prismatic (a velocity column's mm/s too)."""
    stated = rec.reading.pop("stated_units", None) or {}
    speed = rec.reading.get("velocity_unit")
    if not stated and not speed:
        return
    units = {role: normalise(u) for role, u in stated.items()}
    taken, warned = {}, {}
    if "joint_type" not in rec.meta:
        # a unit an option or a metadata line overrides says nothing of the joint
        implied = _joint_types({r: u for r, u in units.items() if KEYS.get(r) not in rec.meta},
                               speed[0] if speed else None)
        if len(set(implied.values())) > 1:
            # degrees beside newtons: which is wrong cannot be told, and either reading
            # puts the other column in a wrong unit, so the user says
            said = "; ".join(f"{what}: {jt}" for what, jt in implied.items())
            raise InputError(f"{name}: the header's units disagree on the joint type ({said}): give "
                             f"--joint-type revolute or prismatic")
        if "prismatic" in implied.values():
            rec.meta["joint_type"] = taken["joint_type"] = "prismatic"
    jt = str(rec.meta.get("joint_type", "revolute"))
    for role, unit in units.items():
        key = KEYS[role]
        if key in rec.meta:               # an option or a metadata line says it, and wins
            if normalise(str(rec.meta[key])) != unit:
                warned[role] = f"{stated[role]!r}, but {key} {rec.meta[key]!r} was given and is used"
            continue
        known = TABLES[role] if role == "t" else TABLES[role].get(jt, {})
        if factor_of(unit, known):
            rec.meta[key] = taken[role] = unit
        else:
            si = "s" if role == "t" else SI.get(jt, SI["revolute"])[0 if role == "q" else 1]
            warned[role] = (f"{stated[role]!r} is not a {ROLE_NAMES[role]} unit: taken in {si} "
                            f"(give --{key.replace('_', '-')} K*{si}, K in {si} per {stated[role]})")
    rec.reading["header_units"] = {"taken": taken, "ignored": warned}
