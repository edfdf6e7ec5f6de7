"""A friction-velocity map: one row per steady speed and the friction held there.

It is what a velocity-step sweep (the industrial friction test) gives once each plateau is
averaged, what the paper's eqs. 4-5 give per constant-speed pass, and what labs and papers
publish: a table of velocity and torque, with no time and no position.  A file is read as one
when it has a velocity and a torque column and neither a time column, a position column nor a
stated sample rate, and its rows look like points rather than samples in time (sorted by speed,
swept one direction at a time, or in the experiment's order).  A scope's export of samples
without times still needs its rate (``bench.sample_rate``).  The analysis is ``bench.map_fit``."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bench.errors import InputError
from bench.records import JOINT_TYPES, column_index
from bench.units import SI, TORQUE_UNITS, VELOCITY_BY_TYPE, factor_of, velocity_factor
from bench.validate import RECORD_BOUNDS

# [rad/s or m/s]: no joint's friction is mapped beyond this; a speed below the lower bound is rest
SPEED_BOUNDS = (1e-9, 1e6)
# Fewer points than this cannot hold LuGre's four static values and a test of what is left
MIN_POINTS = 8


@dataclass
class FrictionMap:
    v: np.ndarray                        # velocity [rad/s or m/s], rows at rest left out
    F: np.ndarray                        # friction [N*m or N] held at that speed
    meta: dict
    reading: dict = field(default_factory=dict)

    @property
    def revolute(self) -> bool:
        return self.meta.get("joint_type", "revolute") == "revolute"

    @property
    def units(self) -> tuple[str, str]:
        """(velocity, torque) unit names in SI."""
        q, tau = SI["revolute" if self.revolute else "prismatic"]
        return f"{q}/s", tau


# metadata lines stating the rows' rate: rows of samples in time, not map points
RATE_KEYS = ("sample_rate", "sample_period", "dt", "sampling_rate", "sample_interval", "rate_hz")


def is_map(mapping: dict, names: list, meta: dict, rate_given: bool, own_times: bool) -> bool:
    """A velocity and a torque column, no time, no position and no rate: rows are map points."""
    if rate_given or own_times or any(k in meta for k in RATE_KEYS):
        return False
    has = _present(mapping, names)
    return has["qd"] and has["tau"] and not has["t"] and not has["q"]


def _present(mapping: dict, names: list) -> dict:
    """Which of the roles the mapping names a column of the file for."""
    return {r: column_index(mapping.get(r), names) is not None for r in ("t", "q", "qd", "tau")}


def refuse_torqueless(mapping: dict, names: list, meta: dict, rate_given: bool, own_times: bool,
                      name: str) -> None:
    """A velocity column, no time, no position and no torque found: a map whose friction column
    is named otherwise ("current [A]", "Reibmoment").  Asked for a time column, its user could
    not help; asked for the torque, one can."""
    has = _present(mapping, names)
    if rate_given or own_times or has["t"] or has["q"] or has["tau"] or not has["qd"] or any(k in meta for k in RATE_KEYS):
        return
    from bench.header_units import split_unit
    from bench.joint_columns import labels_in
    if len(joints := labels_in(names, motion=())) > 1:     # "velocity, friction_joint1, friction_joint2"
        how = "N" if joints[0].isdigit() else "NAME"
        raise InputError(f"{name}: a map of several joints' friction ({', '.join(joints)}) beside one velocity "
                         f"({mapping['qd']}): choose one with --joint {how}")
    shown = ", ".join(map(str, names[:40])) + (" ..." if len(names) > 40 else "")
    qd = split_unit(str(mapping["qd"]))[0]      # a mapping may leave out the unit (column_names.by_bare_name)
    raise InputError(f"{name}: a velocity column ({mapping['qd']}) and no time or position, but no column "
                     f"is named as the friction or torque (header is: {shown}); as a friction-velocity map "
                     f"(a row per steady speed) map it, --columns qd={qd},tau=NAME (a motor current: "
                     f"also --torque-unit K*N*m, K its torque constant); as samples in time, "
                     f"--columns t=NAME,tau=NAME,q=NAME")


def rows_are_points(v: np.ndarray) -> bool:
    """Sorted by speed, swept one direction at a time, or in the experiment's order (+v1, -v1,
    +v2, ...); never samples in time, whose every pass from one direction to the other runs
    smoothly through zero with many rows on each side."""
    v = v[np.isfinite(v)]
    d = np.diff(v)
    if np.all(d >= 0) or np.all(d <= 0):
        return True
    start = 0
    for k in range(1, len(d) + 1):      # the monotone runs
        if k == len(d) or np.sign(d[k]) * np.sign(d[k - 1]) < 0:
            run = v[start:k + 1]
            if min(np.sum(run > 0), np.sum(run < 0)) > 2:
                return False
            start = k
    return True


def build(v, F, units: dict, columns: dict, meta: dict, opts: dict, name: str, fmt: str,
          wrapped: dict | None = None) -> FrictionMap:
    """The map in SI from the file's velocity and torque columns; ``units`` the units they
    state ({role: unit or None}); ``opts`` the command's options (joint_type, torque_unit)."""
    v, F = np.asarray(v, dtype=float), np.asarray(F, dtype=float)
    if not rows_are_points(v):
        raise InputError(f"{name}: no time column, and the velocity runs smoothly back and forth like samples "
                         f"in time: give the rows' rate (--sample-rate HZ); a friction-velocity map (a row per "
                         f"steady speed) is read as one when its rows are sorted by velocity")
    warnings, conv = [], {}
    jt = _joint_type(opts, meta, units, name)
    v_unit = velocity_factor(units.get("qd"))
    if v_unit is None:
        if units.get("qd"):
            raise InputError(f"{name}: the velocity's unit {units['qd']!r} is not one this tool reads "
                             f"(known: {', '.join(VELOCITY_BY_TYPE[jt])})")
        warnings.append(f"the velocity states no unit: read as {SI[jt][0]}/s")
    elif factor_of(v_unit[0], VELOCITY_BY_TYPE[jt]) is None:
        raise InputError(f"{name}: the velocity is in {v_unit[0]}, not a unit for a {jt} joint "
                         f"(known: {', '.join(VELOCITY_BY_TYPE[jt])})")
    elif v_unit[1] != 1.0:
        conv["velocity"] = {"from": v_unit[0], "to": f"{SI[jt][0]}/s", "factor": v_unit[1]}
        v = v * v_unit[1]
    t_unit = opts.get("torque_unit") or units.get("tau")
    if t_unit:
        found = factor_of(str(t_unit), TORQUE_UNITS[jt])
        if found is None:
            raise InputError(f"{name}: torque unit {t_unit!r} is not one for a {jt} joint "
                             f"(known: {', '.join(TORQUE_UNITS[jt])}, or K*UNIT such as 0.12*{SI[jt][1]})")
        if found[0] != 1.0:
            conv["torque"] = {"from": found[1], "to": SI[jt][1], "factor": found[0]}
            F = F * found[0]
    for opt in ("position_unit", "time_unit", "torque_hold", "window", "encoder"):   # (at a steady speed M q'' = 0)
        if opts.get(opt) is not None:
            warnings.append(f"--{opt.replace('_', '-')} does not apply to a friction-velocity map: ignored")
    keep = np.isfinite(v) & np.isfinite(F)
    lost = int(np.sum(~keep))
    still = np.abs(v) < SPEED_BOUNDS[0]       # no friction test resolves a speed below it
    at_rest = int(np.sum(keep & still))
    keep &= ~still
    v, F = v[keep], F[keep]
    if at_rest:     # at rest the friction is anything within +-Fs: no point of the map
        warnings.append(f"{at_rest} row(s) at zero velocity left out: at rest the friction is anywhere within the breakaway level")
    if lost:
        warnings.append(f"{lost} row(s) with an empty or non-numeric cell left out")
    if len(v) < MIN_POINTS:
        raise InputError(f"{name}: a friction-velocity map needs at least {MIN_POINTS} points at nonzero "
                         f"speed, this one has {len(v)}")
    if np.ptp(np.abs(v)) <= 0:
        raise InputError(f"{name}: every point of the map is at one speed: record several")
    for what, x, (lo, hi) in (("torque", F, RECORD_BOUNDS["tau"]), ("speed", v, SPEED_BOUNDS)):
        peak = float(np.max(np.abs(x)))
        if not lo <= peak <= hi:        # extreme numbers never reach the fit (validate.py's bounds)
            raise InputError(f"{name}: the {what} peaks at {peak:.3g}, outside {lo:g}..{hi:g} (unit mistake?)")
    if np.mean(np.sign(v) * F) < 0:      # friction opposes the motion: this torque counts the other way
        F = -F
        warnings.append("the torque counts against the velocity (friction feeding energy in): analysed with its sign turned")
    reading = {"format": fmt, "record": "friction_map", "columns": {r: str(c) for r, c in columns.items()},
               "points": int(len(v)), "rows_lost": lost, "rows_at_rest": at_rest,
               "units": conv, "warnings": warnings, **(wrapped or {})}
    return FrictionMap(v=v, F=F, meta={**meta, "joint_type": jt}, reading=reading)


def _joint_type(opts: dict, meta: dict, units: dict, name: str) -> str:
    """Given, stated, or told by the units (a speed in mm/s, a force in N); else revolute."""
    given = opts.get("joint_type") or meta.get("joint_type")
    if given is not None:
        if given not in JOINT_TYPES:
            raise InputError(f"{name}: joint_type must be prismatic or revolute, not {given!r}")
        return str(given)
    told = set()
    speed = velocity_factor(units.get("qd"))
    for jt in JOINT_TYPES:
        if speed and factor_of(speed[0], VELOCITY_BY_TYPE[jt]):
            told.add(jt)
        unit = opts.get("torque_unit") or units.get("tau")
        if unit and factor_of(str(unit), TORQUE_UNITS[jt]) and not factor_of(str(unit), TORQUE_UNITS[_other(jt)]):
            told.add(jt)
    if len(told) > 1:
        raise InputError(f"{name}: the units disagree on the joint type (a {units.get('qd')} velocity, a "
                         f"{opts.get('torque_unit') or units.get('tau')} torque): give --joint-type revolute or prismatic")
    return told.pop() if told else "revolute"


def _other(jt: str) -> str:
    return next(t for t in JOINT_TYPES if t != jt)
