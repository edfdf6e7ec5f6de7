"""The analysis's refusals and hints in the words of ``POST /analyze``: its query parameters,
not the command line's options.

``bench.readers`` and ``bench.analysis`` speak to ``bench analyze`` ("choose one with --joint
N", "give --time-unit ns"); a technician posting a file has no ``--joint``, so the service
says ``?joint=N``.  One translation here keeps one wording in the domain core.  Only options
``POST /analyze`` has are translated (``--residuals``, ``bench simulate --excitation`` stay:
there is nothing else to say), and an option is read as taking a value only where what
follows looks like that option's value (the hints name options in prose too: "give
--time-unit if it counts another unit").
"""
from __future__ import annotations

import re
from functools import lru_cache

# CLI option -> (query parameter, a value of it as messages write one: a placeholder or a real one)
_NUMBER = r"[-+]?\d[\d.eE+-]*"
_UNIT = r"\S*\*\S+|rad|deg|rev|m|mm|um|N|mN|kN"     # K*UNIT covers N*m and its kin
PARAMETERS = {
    "columns": ("columns", r"[a-z]+=.+"),
    "joint": ("joint", r"N|NAME|<joint>|'[^']*'|\d+"),
    "time-unit": ("time_unit", r"s|ms|us|ns"),
    "sample-rate": ("sample_rate", rf"HZ|{_NUMBER}"),
    "position-unit": ("position_unit", _UNIT),
    "torque-unit": ("torque_unit", _UNIT),
    "inertia": ("inertia", rf"estimate|M|{_NUMBER}"),
    "window": ("window", rf"START:END|{_NUMBER}:{_NUMBER}"),
    "joint-type": ("joint_type", r"revolute|prismatic"),
    "torque-hold": ("torque_hold", r"zoh|sample|auto"),
    "add": ("add", None),                    # an effect's name: the library's, looked up below
}
_OPTION = re.compile(r"(?P<cmd>bench analyze )?--(?P<name>[a-z][a-z-]*)(?P<gap> (?P<tok>'[^']*'|\S+))?")
_TRAILING = ",;:.)"


@lru_cache(maxsize=1)
def _effects() -> frozenset:
    from bench.effects import EFFECTS
    return frozenset(EFFECTS)


def _is_value(option: str, core: str, tail: str) -> bool:
    if option == "add":
        return core in _effects()
    if option == "joint" and tail[:1] in (":", ","):     # "--joint elbow: no column names that joint"
        return re.fullmatch(r"[A-Za-z0-9_.\-]+", core) is not None
    return re.fullmatch(PARAMETERS[option][1], core) is not None


def _say(m: re.Match) -> str:
    option, cmd = m["name"], m["cmd"] or ""
    if option == "no-diagnosis":
        return ("POST /analyze" if cmd else "") + "?diagnose=false" + (m["gap"] or "")
    if option not in PARAMETERS:
        return m[0]
    param = PARAMETERS[option][0]
    where = "POST /analyze" if cmd else ""
    if m["tok"] is not None:
        tok = m["tok"]
        core = tok.rstrip(_TRAILING) if not tok.startswith("'") else tok
        tail = tok[len(core):]
        if _is_value(option, core, tail):
            return f"{where}?{param}={core}{tail}"
    rest = m.string[m.end("name"):m.end("name") + 1]
    if rest == ":" and not cmd:          # the option as a message's subject: "--columns: ..."
        return param + (m["gap"] or "")
    return f"{where}?{param}=" + (m["gap"] or "")


def in_api_words(text: str) -> str:
    """``text`` with each of ``bench analyze``'s options said as ``POST /analyze``'s parameter."""
    return _OPTION.sub(_say, text) if "--" in text else text


def report_in_api_words(doc):
    """Every string of a report (warnings, verdicts, hints), translated; numbers and keys kept."""
    if isinstance(doc, str):
        return in_api_words(doc)
    if isinstance(doc, dict):
        return {k: report_in_api_words(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [report_in_api_words(v) for v in doc]
    return doc
