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

# "name [unit]", "name (unit)" or "name/unit" at the end of a column name
_BRACKETED = re.compile(r"[\[(]\s*([^\[\]()]+?)\s*[\])]\s*$")
_SLASHED = re.compile(r"^[A-Za-z_][\w .]*/\s*([A-Za-zµ°·*.]+)\s*$")

KEYS = {"t": "time_unit", "q": "position_unit", "tau": "torque_unit"}
ROLE_NAMES = {"t": "time", "q": "position", "tau": "torque or force"}
# how units are written, to the readers' spelling (bench.readers' tables)
ALIASES = {"sec": "s", "second": "s", "seconds": "s", "msec": "ms", "µs": "us", "usec": "us",
           "°": "deg", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad",
           "revolutions": "rev", "Nm": "N*m", "N.m": "N*m", "mNm": "mN*m", "kNm": "kN*m",
           "Nmm": "N*mm", "µm": "um"}


KNOWN = {"s", "ms", "us", "ns", "rad", "deg", "rev", "m", "mm", "um", "N*m", "mN*m", "kN*m", "N*mm",
         "N", "mN", "kN"}


def unit_in_name(name: str) -> str | None:
    """The unit a column's name ends with, or None.  "name/token" only when the token is a
    unit ("joint1/position" is a path, not a unit); a bracketed token also when it looks like
    one (short, no blank: "[A]", "(counts)"), so that a unit we cannot convert is said."""
    m = _BRACKETED.search(name)
    if m and (normalise(m.group(1)) in KNOWN or (len(m.group(1)) <= 6 and " " not in m.group(1))):
        return m.group(1).strip()
    m = _SLASHED.match(name)
    return m.group(1).strip() if m and normalise(m.group(1)) in KNOWN else None


def normalise(unit: str) -> str:
    u = unit.strip().replace(" ", "").replace("·", "*")
    return ALIASES.get(u, u)


_SCALED = re.compile(r"^([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\*(.+)$")


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


def split_units_row(header: list[str], second: list[str]) -> dict | None:
    """{column: unit} when the line under a named header holds units, not numbers: every field
    non-numeric and none empty (a data row with a lost cell has numbers beside it)."""
    if len(second) != len(header) or not all(f.strip() for f in second):
        return None
    for f in second:
        try:
            float(f.replace(",", "."))
            return None
        except ValueError:
            pass
    return {h: f.strip().strip('"').strip("[]()") for h, f in zip(header, second)}


def apply(rec, tables: dict, si_names: dict) -> None:
    """Take the units ``rec.reading['stated_units']`` ({role: unit as written}) states where
    no option or metadata line gave one.  ``tables``: the readers' {role: units} (position
    and torque by joint type); a length or force unit with no joint type stated makes the
    joint prismatic."""
    stated = rec.reading.pop("stated_units", None)
    if not stated:
        return
    units = {role: normalise(u) for role, u in stated.items()}
    taken, warned = {}, {}
    if "joint_type" not in rec.meta and (units.get("q") in tables["q"]["prismatic"]
                                         or units.get("tau") in tables["tau"]["prismatic"]):
        rec.meta["joint_type"] = taken["joint_type"] = "prismatic"
    jt = str(rec.meta.get("joint_type", "revolute"))
    for role, unit in units.items():
        key = KEYS[role]
        if key in rec.meta:               # an option or a metadata line says it, and wins
            if normalise(str(rec.meta[key])) != unit:
                warned[role] = f"{stated[role]!r}, but {key} {rec.meta[key]!r} was given and is used"
            continue
        known = tables[role] if role == "t" else tables[role].get(jt, {})
        if factor_of(unit, known):
            rec.meta[key] = taken[role] = unit
        else:
            si = si_names[jt][role]
            warned[role] = (f"{stated[role]!r} is not a {ROLE_NAMES[role]} unit: taken in {si} "
                            f"(give {key.replace('_', '-')} K*{si}, K in {si} per {stated[role]})")
    rec.reading["header_units"] = {"taken": taken, "ignored": warned}


def default_mapping(names: list[str], roles, required) -> dict:
    """With no --columns: each role's column by its own name, or by its name with a unit
    ("t [s]", "q (deg)"); a required role with no column keeps its name (the reader says
    it is missing)."""
    out = {}
    for role in roles:
        hits = [n for n in names if n == role or (unit_in_name(n) and _bare(n) == role)]
        if hits:
            out[role] = role if role in names else hits[0]
        elif role in required:
            out[role] = role
    return out


def _bare(name: str) -> str:
    m = _BRACKETED.search(name) or _SLASHED.match(name)
    return name[:m.start(1)].rstrip(" [(/") if m else name
