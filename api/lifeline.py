"""Children die with their parent: ``PR_SET_PDEATHSIG`` (Linux), through ctypes.

A run's control process gets SIGTERM when its parent (the forkserver, which itself exits
when the server does) dies: the run is cancelled, its joints ramped down, its record ended
``interrupted`` (a run caught fitting, its joints parked, stops the fit at its next
evaluation: ``bench.checkpoint``).  The analysis worker gets SIGKILL:
it holds nothing worth saving.  With every child gone, multiprocessing's resource tracker
sees its pipe close and exits too, so a ``kill -9`` of the server leaves no process behind.
Elsewhere (no prctl) this does nothing; the pipes' end-of-file still ends the run processes.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal

PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies; True if set.
    A parent that died before the call is caught by the check after it."""
    parent = os.getppid()
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    if os.getppid() != parent:      # orphaned already (re-parented before the call)
        os.kill(os.getpid(), sig)
    return True


def analysis_worker_init() -> None:
    """``ProcessPoolExecutor`` initializer of the analysis worker."""
    die_with_parent(signal.SIGKILL)
