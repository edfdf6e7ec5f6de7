"""One joint's columns in a log of several, picked by its label (``--joint 3``, ``--joint
panda_joint4``).

A robot's logger writes every joint in one table: Franka's ``q0..q6, dq0..dq6, tau_J0..tau_J6``,
``rostopic echo -p``'s ``field.position0..``, PlotJuggler's ``/joint_states/joint3/effort``,
MATLAB's ``effort(3)``.  Without this the user mapped four columns by hand.  Here the
columns whose name holds the label are the joint's, renamed with the label taken out
(``tau_J3`` -> ``tau_J``, ``position[3]`` -> ``position``, ``joint_3_position`` ->
``joint_position``), and ``bench.column_names`` finds each role among them first; a role none
of them has (the time, shared by all joints) is then looked for among the other columns.  A
number is the file's own (0- or 1-based as the file counts), matched only as a whole number,
so ``3`` is not found in ``q13``.
"""
from __future__ import annotations

import re

from bench.errors import InputError

# a joint's word left beside its removed number ("J3 torque" -> "J torque"): not part of
# the quantity's name
_JOINT_WORDS = {"j", "joint", "jnt", "axis", "ax"}
_SEPARATOR = r"[\s._\-]"


def _pattern(label: str) -> re.Pattern:
    """Where ``label`` stands in a column's name: a number as a whole number ("q3", "q_3",
    "position[3]", "effort(3)", "joint3/"); a name between non-alphanumerics."""
    lab = re.escape(label)
    if label.isdigit():
        return re.compile(rf"[\[(]{lab}[\])]|{_SEPARATOR}?(?<![0-9]){lab}(?![0-9])")
    return re.compile(rf"{_SEPARATOR}?(?<![A-Za-z0-9]){lab}(?![A-Za-z0-9])", re.IGNORECASE)


def _renamed(name: str, pattern: re.Pattern) -> str | None:
    """``name`` with the label taken out, or None when it does not hold the label."""
    out, n = pattern.subn("", name)
    if not n:
        return None
    words = re.split(r"([\s._\-/]+)", out.strip(" _.-"))
    kept = [w for w in words if w.lower() not in _JOINT_WORDS]
    # keep the joint's word when nothing else is left ("joint" is then the name)
    return "".join(kept).strip(" _.-") if any(w.strip(" _.-/") for w in kept) else out.strip(" _.-")


def joint_columns(names: list[str], label: str) -> dict[str, str]:
    """{renamed: column} for the columns naming joint ``label``; refused, listing the file's
    columns, when none does."""
    label = str(label).strip()
    if not label or not re.fullmatch(r"[A-Za-z0-9_\-.]+", label):
        raise InputError(f"--joint {label!r}: give the joint's number or name as the column names "
                         f"hold it (3, panda_joint4)")
    pattern = _pattern(label)
    out = {}
    for name in names:
        new = _renamed(str(name), pattern)
        if new and new not in out:
            out[new] = name
    if not out:
        raise InputError(f"--joint {label}: no column names that joint (columns: {', '.join(map(str, names))})")
    return out


def labels_in(names: list[str], motion: tuple = ("q", "qd")) -> list[str]:
    """The labels that pick a torque and a position or a velocity (``motion``: any of these; none:
    a torque alone) out of ``names`` as ``--joint`` would: the joints of a log of several, named
    in the refusal of a file read without one.  Numbers ("q3"); where none does, the folders of
    path-like names, a joint named by words alone (PlotJuggler's
    ``/joint_states/shoulder_pan_joint/effort``), leaving out a folder that holds another's
    columns (``joint_states``).  A velocity is enough: a map of several joints ("dq2, tau_J2")
    and a drive's speed-only log were told to map a time column."""
    numbers = dict.fromkeys(m for n in names for m in re.findall(r"(?<![0-9])[0-9]{1,3}(?![0-9])", str(n)))
    out = _picking(names, list(numbers)[:100], motion)
    if len(out) > 1:
        return list(out)
    folders = dict.fromkeys(p for n in names for p in str(n).split("/")[:-1]
                            if re.fullmatch(r"[A-Za-z][A-Za-z0-9_\-.]*", p))
    # one label per set of columns (a joint's own folder is the deeper one), none holding another's
    out = {frozenset(cols): label for label, cols in _picking(names, list(folders)[:100], motion).items()}
    return [label for cols, label in out.items() if not any(other < cols for other in out)]


def _picking(names: list[str], labels: list[str], motion: tuple) -> dict[str, set]:
    """{label: its columns} for the ``labels`` whose columns hold a torque and one of ``motion``."""
    from bench.column_names import find_roles
    out = {}
    for label in labels:
        try:
            renamed = joint_columns(names, label)
        except InputError:      # a number that is a whole name (a headerless file's "1")
            continue
        found, _ = find_roles(list(renamed), ("tau", *motion), set())
        if "tau" in found and (not motion or set(motion) & set(found)):
            out[label] = set(renamed.values())
    return out


def refuse_unfound(mapping: dict, names: list[str], joint: str | None, name: str) -> None:
    """Refuse a mapping with no torque or no position (nor velocity) among ``names`` in the
    words that help: a log of several joints read without ``--joint`` is told its joints; a
    joint whose columns lack one is told which columns it has.  Otherwise the reader's own
    "missing column" refusal follows."""
    what = {"tau": "torque", "q": "position"}
    lacking = [r for r in what if mapping[r] not in names and not (r == "q" and mapping.get("qd") in names)]
    if not lacking:
        return
    if joint is None and len(joints := labels_in(names)) > 1:
        how = "N" if joints[0].isdigit() else "NAME"
        timed = mapping.get("t") in names or mapping.get("q") in names
        raise InputError(f"{name}: a log of several joints ({', '.join(joints)}): choose one with "
                         f"--joint {how}, or map its columns with --columns t=NAME,tau=NAME,q=NAME"
                         + ("" if timed else " (a friction-velocity map, a row per speed: qd=NAME,tau=NAME)"))
    if joint is not None:
        own = ", ".join(map(str, joint_columns(names, joint).values()))
        raise InputError(f"{name}: joint {joint}'s columns ({own}) hold no {' and no '.join(what[r] for r in lacking)} "
                         f"by a name this reader knows; map them with --columns t=NAME,tau=NAME,q=NAME")
