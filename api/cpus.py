"""CPU placement of ``bench serve``: the server on its own CPU, run control processes on the
others.

Separate processes keep the server's GIL away from the control loops, but on a small machine
they still share CPUs: a control thread that wakes for its next 1 ms period while the server
runs on every core waits for the scheduler, and misses periods.  With two or more CPUs the
server (request handling, and the analysis process it starts) keeps the last one and the
control processes get the rest; affinity needs no privilege.  Linux only (elsewhere: no-op).
"""
from __future__ import annotations

import os

from drivers.realtime import pin

__all__ = ["pin", "split"]   # pin is drivers.realtime's, re-exported for the server


def split() -> tuple[set[int], set[int]] | None:
    """(server CPUs, control CPUs) out of the CPUs this process may use; None below two."""
    try:
        allowed = os.sched_getaffinity(0)
    except (AttributeError, OSError):
        return None
    if len(allowed) < 2:
        return None
    server = {max(allowed)}
    return server, allowed - server
