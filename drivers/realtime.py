"""Real-time placement of a control process: CPU affinity and SCHED_FIFO priority.

A 1 kHz loop in CPython misses periods for two reasons that no code path inside it can fix:
the scheduler runs something else on its CPU (a busy server, the emulated drives, the
hypervisor's other guests) and, on a 2-core machine, threads of one process that hand the
GIL to each other across cores wake slowly.  Both are placement: pin the control process's
threads to their own CPUs and, where permitted, give them a fixed real-time priority
(``SCHED_FIFO``), as ros2_control and most robot controllers do.  FIFO needs root,
CAP_SYS_NICE or an ``rtprio`` limit (``/etc/security/limits.conf``); without it the loop
runs at normal priority and the caller is told why.  The kernel keeps 5 % of each CPU for
normal tasks (``sched_rt_runtime_us``), so a runaway real-time thread cannot lock a machine.

Linux sets both per thread, and threads started later inherit them from their creator:
apply them early, or to every thread (``pid`` names any process).  Elsewhere: no-ops.
"""
from __future__ import annotations

import os

from bench.errors import InputError

MAX_PRIORITY = 98            # 99 belongs to the kernel's watchdog and migration threads


def check_priority(priority: int, name: str = "real-time priority") -> int:
    """``priority`` if it is 0 (off) to MAX_PRIORITY, else an InputError naming ``name``."""
    if not 0 <= priority <= MAX_PRIORITY:
        raise InputError(f"{name} must be 0 (off) to {MAX_PRIORITY}, got {priority}")
    return priority


def threads(pid: int | None = None) -> list[int]:
    """Thread ids of process ``pid`` (this one by default)."""
    try:
        return [int(t) for t in os.listdir(f"/proc/{pid or 'self'}/task")]
    except OSError:
        return [pid or 0]


def pin(cpus: set[int], pid: int | None = None) -> None:
    """Confine every thread of process ``pid`` to ``cpus``; a thread that just ended, or no
    affinity support, is skipped."""
    for tid in threads(pid):
        try:
            os.sched_setaffinity(tid, cpus)
        except (AttributeError, OSError):
            pass


def set_priority(priority: int, pid: int | None = None) -> str | None:
    """Every thread of process ``pid`` to SCHED_FIFO at ``priority`` (1..98), or back to the
    normal policy with 0.  Returns None when done, else one line saying why not."""
    check_priority(priority)
    if not hasattr(os, "sched_setscheduler"):
        return "real-time scheduling is not available on this system"
    policy = os.SCHED_FIFO if priority else os.SCHED_OTHER
    for tid in threads(pid):
        try:
            os.sched_setscheduler(tid, policy, os.sched_param(priority))
        except PermissionError:
            return (f"SCHED_FIFO priority {priority} not permitted (needs root, CAP_SYS_NICE "
                    f"or an rtprio limit); running at normal priority")
        except (ProcessLookupError, OSError):
            pass                      # a thread that ended meanwhile
    return None


def policy(pid: int | None = None) -> str:
    """Scheduling policy of thread or process ``pid`` (the calling thread by default):
    "fifo", "rr", "normal", or "unknown" where it cannot be read."""
    try:
        return {os.SCHED_FIFO: "fifo", os.SCHED_RR: "rr"}.get(os.sched_getscheduler(pid or 0), "normal")
    except (AttributeError, OSError):
        return "unknown"


def describe(pid: int | None = None) -> dict:
    """Policy, priority and CPUs of process ``pid``'s main thread (for run records)."""
    try:
        return {"policy": policy(pid),
                "priority": os.sched_getparam(pid or 0).sched_priority,
                "cpus": sorted(os.sched_getaffinity(pid or 0))}
    except (AttributeError, OSError):
        return {"policy": "unknown", "priority": 0, "cpus": []}
