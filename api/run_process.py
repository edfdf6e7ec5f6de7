"""The server's side of a run's control process (``api.run_child``): start, relay, cancel,
e-stop, kill.

Why a process: the control loop paces the drives at 1 ms.  In a thread of the server it
shared the GIL with request handling, and HTTP load cost it missed periods; in its own
process nothing the server does can stall it.  Processes come from a forkserver context
(a clean, single-threaded process that has imported the heavy modules once, so a run starts
in milliseconds), or spawn where there is no forkserver; never a plain fork of the threaded
server.

One reader thread per run receives the child's status messages and hands them to the run
manager (``on_message``), so request handlers only read memory.  The e-stop pipe is used by
``api.safety.EStop.trigger`` alone: ``estop_send`` to every process first, then
``estop_collect`` each reply; a process that does not answer by the deadline is killed
(SIGKILL).  A process that has not opened a drive yet (``armed``, a byte of shared memory it
sets first) is not waited for: one just forked may need a second on a loaded machine before
its listener runs, and it reads the latch from its pipe before it enables anything.  Its drives then stop on their own: emulated drives live in that process and die
with it, real drives' heartbeat / watchdog (CiA 402 0x1016 consumer heartbeat, ODrive
watchdog; docs/drives.md) expires within their timeout and they stop.
"""
from __future__ import annotations

import logging
import multiprocessing
import threading
import time
from multiprocessing.connection import wait

from api import run_child

log = logging.getLogger(__name__)
EXIT_WAIT = 10.0       # s: a child that sent "done" (or closed its pipe) must have exited by then
# what the forkserver imports once, so that each run's process starts without importing them
PRELOAD = ["api.run_child", "api.safety", "api.procedures", "bench.store", "bench.analysis",
           "procedures.calibration", "procedures.rig", "drivers.registry", "drivers.canopen_402",
           "drivers.odrive_ascii", "drivers.simulated", "virtual_drives.launch", "virtual_drives.warm"]

_ctx = None
_ctx_lock = threading.Lock()


def context():
    """The multiprocessing context of run processes (forkserver, started at once)."""
    global _ctx
    with _ctx_lock:
        if _ctx is None:
            if "forkserver" in multiprocessing.get_all_start_methods():
                from multiprocessing import forkserver
                ctx = multiprocessing.get_context("forkserver")
                ctx.set_forkserver_preload(["__main__", *PRELOAD])
                # start it now: it imports PRELOAD in the background, not in the first run's start
                forkserver.ensure_running()
            else:
                ctx = multiprocessing.get_context("spawn")
            _ctx = ctx
    return _ctx


class RunProcess:
    """One run's control process.  ``on_message(msg)`` is called in the reader thread with
    each status message, and finally with ``{"t": "exit", "exitcode": ..., "killed": ...}``."""

    def __init__(self, spec: dict, on_message):
        ctx = context()
        self.run_id: str = spec["run_id"]
        self.joints: list[str] = list(spec["held"])   # reported for a process that cannot answer
        self.open_joints: list[str] = []
        self.finishing = False           # drives closed; the process only ends its record now
        self.exitcode: int | None = None
        self.killed: str | None = None   # why we killed it
        self._on_message = on_message
        self._ctrl_child, self._ctrl = ctx.Pipe(duplex=False)        # server -> child
        self._status, self._status_child = ctx.Pipe(duplex=False)    # child -> server
        self._estop, self._estop_child = ctx.Pipe()                  # both ways
        self._ctrl_lock = threading.Lock()
        self._estop_lock = threading.Lock()      # the reader closes the pipe when the process ends
        self._estop_seq = 0
        # set by the process (shared memory, no relay) before it opens its first drive
        self.armed = ctx.RawValue("b", 0)
        self.proc = ctx.Process(target=run_child.main, name=f"run-{self.run_id}", daemon=True,
                                args=(spec, self._ctrl_child, self._status_child, self._estop_child,
                                      self.armed))
        self.reader: threading.Thread | None = None
        self.pid: int | None = None

    def __repr__(self) -> str:
        return f"RunProcess({self.run_id}, pid {self.pid})"

    def start(self) -> None:
        self.proc.start()
        self.pid = self.proc.pid
        for c in (self._ctrl_child, self._status_child, self._estop_child):
            c.close()        # the child has its own copies; ours would hide its death (no EOF)
        self.reader = threading.Thread(target=self._read, name=f"run-{self.run_id}-status", daemon=True)
        self.reader.start()

    # --- server -> child ------------------------------------------------------------------------
    def _tell(self, *msg) -> None:
        with self._ctrl_lock:
            try:
                self._ctrl.send(msg)
            except OSError:      # the process is gone: the reader thread ends the run
                pass

    def cancel(self, reason: str) -> None:
        self._tell("cancel", reason)

    def ack(self) -> None:
        self._tell("ack")

    def kill(self, why: str) -> None:
        """SIGKILL, unless it has already exited (its pid could belong to someone else)."""
        if self.exitcode is None:
            self.killed = self.killed or why
            try:
                self.proc.kill()
            except (OSError, ValueError, AttributeError):
                pass

    # --- e-stop (api.safety.EStop.trigger) ----------------------------------------------------------
    def estop_send(self, reason: str) -> None:
        with self._estop_lock:
            self._estop_seq += 1
            self._estop.send(("estop", self._estop_seq, reason))

    def estop_collect(self, deadline: float) -> list[dict]:
        """The process's drive reports, or (no answer by ``deadline``: killed) one report per
        joint it held, saying so.  A process not started yet has no drive open: it will read
        the e-stop, waiting in its pipe, before anything else (its listener starts first)."""
        if self.pid is None or not self.armed.value:
            # it has not opened a drive yet: the latch waits in its pipe, and the process reads
            # it before it enables any drive (api.safety.EStop.pending); nothing to wait for
            return []
        try:
            with self._estop_lock:
                while self._estop.poll(max(0.0, deadline - time.monotonic())):
                    reply = self._estop.recv()
                    if reply["seq"] == self._estop_seq:    # not a late answer to an earlier one
                        return list(reply["drives"])
            problem = "did not answer the e-stop in time; killed (SIGKILL)"
            self.kill("it did not answer the e-stop")
        except (EOFError, OSError):
            if self.finishing:     # it had closed its drives and ended
                return []
            problem = "had exited"
        return [{"joint": j, "run_id": self.run_id, "state": None, "torque_off": None,
                 "error": f"control process {self.pid} {problem}; the drive stops on its own "
                          f"(emulated: gone with the process; real: heartbeat/watchdog timeout)"}
                for j in (self.open_joints or self.joints)]

    # --- child -> server ------------------------------------------------------------------------------
    def _read(self) -> None:
        conn, sentinel = self._status, self.proc.sentinel
        try:
            while True:
                ready = wait([conn, sentinel])
                if conn not in ready:            # exited with its pipe held elsewhere: drain it
                    while conn.poll(0):
                        self._deliver(conn.recv())
                    break
                self._deliver(conn.recv())
        except (EOFError, OSError):
            pass
        finally:
            self.proc.join(EXIT_WAIT)
            if self.proc.exitcode is None:
                log.error("run %s: control process %s still alive after its pipe closed; killing it",
                          self.run_id, self.pid)
                self.kill("it did not exit after the run")
                self.proc.join(EXIT_WAIT)
            self.exitcode = self.proc.exitcode
            self._deliver({"t": "exit", "exitcode": self.exitcode, "killed": self.killed})
            with self._ctrl_lock, self._estop_lock:
                for c in (self._status, self._ctrl, self._estop):
                    c.close()
            try:
                self.proc.close()        # its sentinel descriptor
            except ValueError:
                pass

    def _deliver(self, msg: dict) -> None:
        kind = msg.get("t")
        if kind == "status":
            self.open_joints = msg["open"]
        elif kind == "finishing":
            self.finishing = True
        try:
            self._on_message(msg)
        except Exception:   # a bug here must not stop the relay (or the run's end)
            log.exception("run %s: status message %r", self.run_id, kind)
