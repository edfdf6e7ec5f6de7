"""The host's control-period grid, shared by every drive with the same clock and period.

``cycle`` on each joint in turn is one round: the first drive of a round waits for the next
period boundary (real time) and opens a new tick, the others join that tick.  A round that
starts more than one whole period after its boundary skips the missed boundaries and counts
them as overruns; it never bursts to catch up.  Lock-step ticks open at once.

At normal priority the wait sleeps most of the way and yield-spins the last 0.2 ms (a plain
sleep overshoots by 50-100 us plus scheduler noise, too much of a 1 ms period).  A thread at a
real-time priority (``drivers.realtime``) sleeps the whole way instead: its timers have no
slack and its wake-up preempts normal tasks, while a spin would starve the kernel workers
that move pty and socket data to the drives.

When a real-time grid (re)starts, the heap is collected once and frozen (``gc.freeze``): a
full collection of this process's ~200k objects (numpy, scipy, numba, FastAPI) stops every
thread for ~120 ms, i.e. a hundred missed periods; frozen objects are never scanned again.
"""
from __future__ import annotations

import gc
import threading
import time

from drivers import realtime

_PACERS: dict[tuple, "Pacer"] = {}
_LOCK = threading.Lock()


class Pacer:
    @classmethod
    def shared(cls, clock: str, period: float) -> "Pacer":
        with _LOCK:
            key = (clock, float(period))
            if key not in _PACERS:
                _PACERS[key] = cls(clock == "realtime", float(period))
            return _PACERS[key]

    def __init__(self, realtime: bool, period: float):
        self.realtime = realtime
        self.dt = period
        self.tick = 0
        self.overruns = 0
        self.due: float | None = None
        self.lock = threading.Lock()
        self.record: list[float] | None = None   # tick times, when a benchmark asks
        self.spin = 2e-4                          # s of yield-spin before a boundary

    def next_tick(self, consumed: int) -> int:
        """The tick a drive that last used tick ``consumed`` must use now."""
        with self.lock:
            if consumed >= self.tick:
                if self.realtime:
                    self._wait_boundary()
                self.tick += 1
                if self.record is not None:
                    self.record.append(time.perf_counter())
            return self.tick

    def _wait_boundary(self) -> None:
        now = time.perf_counter()
        if self.due is None or now - self.due > 1.0:   # first round, or after a pause
            gc.collect()
            gc.freeze()
            self.spin = 0.0 if realtime.policy() in ("fifo", "rr") else 2e-4
            self.due = time.perf_counter()
            return
        self.due += self.dt
        late = now - self.due
        if late > self.dt:
            missed = int(late / self.dt)
            self.overruns += missed
            self.due += missed * self.dt
        spin = self.spin
        while True:
            left = self.due - time.perf_counter()
            if left <= 0:
                return
            if spin and left <= spin + 1e-4:
                time.sleep(0)             # yield-spin the last stretch
            else:
                time.sleep(left - spin)
