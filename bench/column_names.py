"""A column's role told by the name loggers give it, when no ``--columns`` maps it.

Without a mapping only ``t``, ``tau``, ``q`` and ``qd`` (with or without a unit: "q [deg]")
were read, and a ROS ``joint_states`` export (position, velocity, effort), a drive's CiA 402
names ("Position actual value") or a plain "time,position,torque" log was refused until the
user mapped every column.  A role's own name still wins; otherwise a column whose whole name,
in any case and with blanks, dots or dashes as underscores, is one of the names below takes
the role.  Only exact names, and only one column a role: a log with both "torque" and
"effort", or a "torque_cmd" beside a "torque_measured", keeps asking for a mapping, since a
command read as the reading is a wrong answer, not a refusal.  What was taken by name is said
in the report (``reading.columns_by_name``) so that a wrong guess is seen.  A unit after an
underscore, "q_deg" or "time_ms", is read as "q [deg]" is, mapped or not (``suffix_unit``).
"""
from __future__ import annotations

import re

from bench.header_units import split_unit
from bench.units import TABLES, factor_of

# names in logs users have sent or that their tools write: ROS joint_states (position,
# velocity, effort), Franka (dq, tau_J), CiA 402 object names, data-acquisition exports, UR's
# RTDE recorder (actual_q, actual_qd; not actual_current, in amperes, nor target_*, commands)
NAMES = {
    "t": ("time", "timestamp", "time_stamp", "stamp", "times", "elapsed_time"),
    "q": ("position", "pos", "angle", "theta", "joint_position", "joint_angle", "actual_position",
          "position_actual_value", "measured_position", "q_measured", "q_meas", "actual_q"),
    "qd": ("velocity", "vel", "speed", "dq", "qdot", "q_dot", "omega", "joint_velocity",
           "actual_velocity", "velocity_actual_value", "measured_velocity", "angular_velocity", "actual_qd"),
    "tau": ("torque", "effort", "force", "tau_j", "tau_meas", "tau_measured", "measured_torque",
            "joint_torque", "actual_torque", "torque_actual_value", "friction", "friction_torque",
            "tau_f", "actual_current_as_torque"),
}
_SEPARATORS = re.compile(r"[\s.\-]+")
_CAMEL = re.compile(r"(?<=[a-z])(?=[A-Z])")
# "q_m" is a motor's position as often as one in metres, so a bare "_m" says no unit
_NOT_A_SUFFIX = {"q": {"m"}}


def normalised(name: str) -> str:
    """"Position actual value [inc]" -> "position_actual_value"; a path's last part
    ("/joint_states/joint3/effort", PlotJuggler's) and without a logger's leading marks
    ("%time" of rostopic, "__time" of PlotJuggler)."""
    bare = split_unit(str(name))[0].strip()
    parts = [p for p in bare.split("/") if p.strip()]
    bare = parts[-1] if parts else bare
    bare = _CAMEL.sub("_", bare.strip(" %_"))       # "MeasuredTorque", KUKA's and LabVIEW's
    return _SEPARATORS.sub("_", bare).lower()


def _forms(name: str) -> tuple[str, ...]:
    """The names a column answers to: its own, and its last dotted part ("field.position"
    of rostopic is a position, "field.header.stamp" a stamp)."""
    full = normalised(name)
    bare = split_unit(str(name))[0].strip()
    last = normalised(bare.rsplit(".", 1)[1]) if "." in bare.split("/")[-1] else full
    return (full, last) if last != full else (full,)


# a velocity's unit after an underscore ("dq_rad_s", "velocity_deg_per_s", "speed_rpm"): only
# to find the column; qd is read in the position's unit per second (bench.signals checks it)
_VELOCITY_SUFFIX = re.compile(r"_(?:(?:rad|deg|rev|m|mm|um)_?(?:per_)?s|rpm)$", re.IGNORECASE)


def suffix_unit(name: str, role: str) -> str | None:
    """The unit a column's name ends with after an underscore, "q_deg", "time_ms", "tau_Nm",
    when it is one of ``role``'s units (of any joint type); else None.  Lab scripts name their
    columns so, and read as SI an angle in degrees is 57x off without a word."""
    if role == "qd":
        m = _VELOCITY_SUFFIX.search(str(name))
        return m.group(0)[1:] if m else None
    base, sep, unit = str(name).rpartition("_")
    if not sep or not base or role not in TABLES or unit in _NOT_A_SUFFIX.get(role, ()):
        return None
    table = TABLES[role]
    known = table if role == "t" else {k: v for by_type in table.values() for k, v in by_type.items()}
    return unit if factor_of(unit, known) else None


_MEAN = re.compile(r"^(?:mean|avg|average)_(.+)$|^(.+?)_(?:mean|avg|average)$")


def _mean_of(name: str) -> str | None:
    """"torque_mean", "Mean torque", "avg_velocity" -> the quantity averaged; else None.  A
    friction-velocity map is a table of such means, often beside their spread ("torque_std"),
    which names no role and is left alone."""
    m = _MEAN.match(normalised(name))
    return (m.group(1) or m.group(2)) if m else None


def by_bare_name(col, names: list):
    """A mapped name without the unit its column states: "velocity" for "velocity [rad/s]",
    when that is the one such column (typed so, the exact name was refused as not there)."""
    if not isinstance(col, str) or col in names or "@" in col:
        return col
    hits = [n for n in names if split_unit(str(n))[1] and split_unit(str(n))[0].strip() == col.strip()]
    return hits[0] if len(hits) == 1 else col


def _stamp_first(names: list[str], taken: set) -> list[str]:
    # rostopic writes when it received a message (%time) beside when it was sampled
    # (field.header.stamp): the sample's own time is the one to resample on
    return [n for n in names if n not in taken and normalised(n).endswith("header_stamp")]


def find_roles(names: list[str], roles, taken: set) -> tuple[dict, dict]:
    """Each role's column among ``names``: by its own name or its name with a unit ("t [s]",
    "q (deg)"), else by the one column named as loggers name it (``NAMES``).  Returns the
    roles found and those of them found by a logger's name."""
    out, guessed = {}, {}
    split = {n: split_unit(n) for n in names}
    for role in roles:
        hits = [n for n, (bare, unit) in split.items() if n not in taken and (n == role or (unit and bare == role))]
        if hits:
            out[role] = role if role in hits else hits[0]
            taken.add(out[role])
    for role in roles:
        if role in out:
            continue
        known = set(NAMES.get(role, ()))
        hits = [n for n in names if n not in taken and _forms(n)[0] in known]
        if not hits:        # by a dotted name's last part ("field.position"), when none by its whole
            hits = [n for n in names if n not in taken and _forms(n)[-1] in known]
        if role == "t" and len(stamps := _stamp_first(names, taken)) == 1:
            hits = stamps
        if not hits:        # "q_rad", "time_s": a name and its unit after an underscore
            hits = [n for n in names if n not in taken and (u := suffix_unit(n, role))
                    and normalised(n[:-len(u) - 1]) in (role, *NAMES.get(role, ()))]
        if not hits and role != "t":       # a map's per-speed means: "torque_mean", "avg_velocity"
            hits = [n for n in names if n not in taken and _mean_of(n) in (role, *NAMES.get(role, ()))]
        if len(hits) == 1:
            out[role] = guessed[role] = hits[0]
            taken.add(hits[0])
        elif hits:
            taken.update(hits)      # not one column: left to the user, not to a wider search
    return out, guessed


def default_mapping(names: list[str], roles, required, joint: str | None = None) -> tuple[dict, dict, dict]:
    """With no --columns: each role's column (``find_roles``).  With ``joint``, a log of several
    joints: among that joint's columns first (``bench.joint_columns``), then among the rest
    for the roles they lack (the shared time).  A required role with no column keeps its name
    (the reader says it is missing).  Returns the mapping, the roles taken by a logger's name
    among the shared columns {role: column}, and the roles taken from the joint's columns."""
    out, guessed, of_joint = {}, {}, {}
    taken: set = set()
    if joint is not None:
        from bench.joint_columns import joint_columns
        renamed = joint_columns(names, joint)
        found, _ = find_roles(list(renamed), roles, set())
        out = of_joint = {r: renamed[c] for r, c in found.items()}
        taken = set(renamed.values())
        names = [n for n in names if n not in taken]
    found, guessed = find_roles(names, [r for r in roles if r not in out], taken)
    out = {**out, **found}
    for role in required:
        out.setdefault(role, role)
    return {r: out[r] for r in roles if r in out}, guessed, dict(of_joint)
