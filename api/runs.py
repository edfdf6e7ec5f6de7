"""Run manager: one control process per run, joint locks, cancel, progress, live samples.

A run takes its joints when it is created (``start`` answers 409 when one is busy or the
e-stop is latched), so a run never waits in a queue behind another: ``queued`` only lasts
until its process has claimed it.  The process (``api.run_process`` / ``api.run_child``) owns
the run's rig and writes the run's record; a reader thread per run applies its status
messages to the in-memory ``RunHandle`` (progress, newest samples, host overruns), which is
all request handlers read besides the store, so they never block a control loop, and the
server's GIL cannot stall one.

A run ends in three steps: its process closes the drives and says "finishing" (the joints
are released here, then acknowledged), it ends the record, and it exits (the handle goes).
A process that dies without ending its record gets it ended here: ``interrupted`` when it
was killed, ``failed`` when it exited otherwise.
"""
from __future__ import annotations

import logging
import signal
import threading
import time
from dataclasses import dataclass, field

from bench.errors import BenchError, InputError
from bench.store import FINAL, Store, pid_alive
from procedures.config import BenchConfig
from procedures.events import Emitter

from api import procedures as P
from api.run_process import RunProcess, context
from api.safety import EStop, EStopActive

log = logging.getLogger(__name__)


class Conflict(BenchError):
    """The request is valid but the bench cannot do it now (busy joint, e-stop): 409."""


class NotFound(BenchError):
    """Unknown run or joint: 404."""


@dataclass
class RunHandle:
    """The server's view of an active run; its control process (``proc``) feeds it."""
    run_id: str
    procedure: str
    joints: list[str]            # the run's joints
    options: dict
    held: list[str]              # joints it holds (a calibration: every joint of the bench)
    proc: RunProcess | None = None
    progress: float = 0.0
    live: dict = field(default_factory=dict)     # joint -> newest sample, from the process
    open_joints: list = field(default_factory=list)
    overruns: int = 0            # host overruns of the run's control loop so far
    estopped: str | None = None
    released: bool = False       # drives closed, joints free; the process is ending its record
    done: threading.Event = field(default_factory=threading.Event)

    def samples(self) -> dict:
        return dict(self.live)

    def drive_sample(self, jid: str) -> dict | None:
        """The newest sample of a drive the run has open now, else None."""
        return self.live.get(jid) if jid in self.open_joints else None


class RunManager:
    def __init__(self, store: Store, bench_spec: str, cfg: BenchConfig, transport: str, estop: EStop,
                 control_cpus: set[int] | None = None, rt_priority: int = 0):
        self.store = store
        self.control_cpus = control_cpus            # CPUs of the run processes (api.cpus), None: any
        self.rt_priority = rt_priority              # their SCHED_FIFO priority, 0: normal
        self.bench_spec = bench_spec
        self.cfg = cfg
        self.transport = transport
        self.estop = estop
        self.busy: dict[str, str] = {}              # joint -> run id
        self.handles: dict[str, RunHandle] = {}     # active runs (until their process exits)
        self.finished_progress: dict[str, float] = {}
        self.last_drive: dict[str, dict] = {}       # joint -> last sample/state after its run
        self._overruns_ended = 0                    # host overruns of the runs that have ended
        self._lock = threading.Lock()
        # the overrun tally's own lock: /health reads it on the event loop, and start() holds
        # _lock across store writes
        self._tally = threading.Lock()
        self._closing = False
        estop.on_trigger(self._on_estop)
        self._recover()
        context()                                   # the forkserver starts loading now

    def _recover(self) -> None:
        """Runs a previous server left running are interrupted; queued ones never started."""
        self.store.recover()
        for r in self.store.list_runs(state="queued", limit=1000):
            if not pid_alive(r["owner_pid"]):
                self.store.finish_run(r["id"], "interrupted", error="server stopped before the run started")

    # --- start ----------------------------------------------------------------------------------
    def start(self, procedure: str, joints: list[str] | None, options: dict) -> RunHandle:
        ids = self._joints_for(procedure, joints)
        if procedure == "tracking":
            for jid in ids:            # a missing model is the caller's mistake: 4xx before starting
                P.tracking_models(self.store, jid, options)
        held = self.cfg.ids if procedure == "calibrate" else ids
        with self._lock:
            if self._closing:
                raise Conflict("the service is shutting down")
            if self.estop.active:
                raise Conflict(f"e-stop is active ({self.estop.reason}); an admin must reset it")
            taken = [f"{j} (run {self.busy[j]})" for j in held if j in self.busy]
            if taken:
                raise Conflict(f"joint busy: {', '.join(taken)}")
            seed = int(options.get("seed", 0))
            if procedure == "calibrate":
                from procedures.calibration import STAGES, start_calibration
                run_id = start_calibration(self.store, self.bench_spec, ids, seed, options=options,
                                           transport=self.transport)
                total = len(ids) * len(STAGES)
            else:
                run_id = self.store.create_run(P.KINDS[procedure], seed=seed, state="queued",
                                               config={"procedure": procedure, "joints": ids, "options": options,
                                                       "bench": self.bench_spec, "transport": self.transport})
                total = len(ids) * (2 if procedure == "identify" else 1)
            h = RunHandle(run_id, procedure, ids, dict(options), list(held))
            spec = {"run_id": run_id, "procedure": procedure, "joints": ids, "held": list(held),
                    "options": dict(options), "stages_total": total, "cfg": self.cfg,
                    "transport": self.transport, "data_dir": str(self.store.dir.resolve()),
                    "cpus": sorted(self.control_cpus) if self.control_cpus else None,
                    "rt_priority": self.rt_priority}
            h.proc = RunProcess(spec, lambda msg: self._on_message(h, msg))
            try:       # an e-stop from now on reaches the process (its pipe exists already)
                self.estop.add_target(h.proc)
            except EStopActive as e:
                self.store.finish_run(run_id, "failed", error=str(e))
                raise Conflict(str(e)) from None
            for j in held:
                self.busy[j] = run_id
            self.handles[run_id] = h
        try:        # outside the lock: the first start waits for the forkserver's imports
            h.proc.start()
        except Exception as e:
            log.exception("run %s: cannot start its control process", run_id)
            self._release(h, {})
            with self._lock:
                self.handles.pop(run_id, None)
            self.store.finish_run(run_id, "failed", error=f"cannot start the run's control process: {e}")
            h.done.set()
            raise
        return h

    def _joints_for(self, procedure: str, joints: list[str] | None) -> list[str]:
        if joints is None or procedure == "calibrate" and not joints:
            return self.cfg.ids
        if not joints:
            raise InputError("joints: give at least one joint id")
        if len(set(joints)) != len(joints):
            raise InputError("joints: a joint appears twice")
        for j in joints:
            if j not in self.cfg.ids:
                raise NotFound(f"bench {self.cfg.name!r} has no joint {j!r}; joints: {', '.join(self.cfg.ids)}")
        return list(joints)

    # --- cancel, e-stop, shutdown ------------------------------------------------------------
    def cancel(self, run_id: str, reason: str = "cancelled by request") -> bool:
        """Ask an active run to ramp down and end ``cancelled``; False if it is not active."""
        h = self.handles.get(run_id)
        if h is None or h.proc is None:
            return False
        h.proc.cancel(reason)
        return True

    def _on_estop(self, reason: str) -> None:
        # the processes were told by EStop.trigger itself; this marks the runs as stopping
        for h in list(self.handles.values()):
            if not h.released:
                h.estopped = reason

    def shutdown(self, timeout: float = 20.0) -> None:
        """Cancel every run (ramp-down), wait up to ``timeout``, then kill what is left."""
        with self._lock:
            self._closing = True
            handles = list(self.handles.values())
        for h in handles:
            h.proc.cancel("the service is shutting down")
        deadline = time.monotonic() + timeout
        for h in handles:
            h.done.wait(max(0.0, deadline - time.monotonic()))
        for h in handles:
            if not h.done.is_set():
                log.error("run %s did not stop within %.0f s of the shutdown; killing its process", h.run_id, timeout)
                h.proc.kill(f"it did not stop within {timeout:g} s of the service shutting down")
        for h in handles:
            h.done.wait(15.0)

    def active(self) -> list[RunHandle]:
        """Runs still holding their joints."""
        return [h for h in self.handles.values() if not h.released]

    def progress(self, run: dict) -> float:
        h = self.handles.get(run["id"])
        if h is not None:
            return h.progress
        if run["state"] == "succeeded":
            return 1.0
        return self.finished_progress.get(run["id"], ((run.get("result") or {}).get("progress") or 0.0))

    def host_overruns(self) -> int:
        """Control periods missed since the server started: ended runs plus the live counts of
        the active ones (each run's process has its own pacer)."""
        with self._tally:
            return self._overruns_ended + sum(h.overruns for h in list(self.handles.values()))

    # --- messages from the run processes (their reader threads) ------------------------------
    def _on_message(self, h: RunHandle, msg: dict) -> None:
        kind = msg["t"]
        if "progress" in msg:
            h.progress = msg["progress"]
        if "overruns" in msg:
            h.overruns = msg["overruns"]
        if kind == "status":
            h.live, h.open_joints = msg["samples"], msg["open"]
        elif kind == "finishing":
            self._release(h, msg["last_drive"])
            h.proc.ack()
        elif kind == "exit":
            self._ended(h, msg["exitcode"], msg["killed"])

    def _release(self, h: RunHandle, last_drive: dict) -> None:
        """The run's drives are closed: its joints are free."""
        with self._lock:
            if h.released:
                return
            h.released = True
            h.open_joints = []
            self.last_drive.update(last_drive)
            for j, rid in list(self.busy.items()):
                if rid == h.run_id:
                    del self.busy[j]
        self.estop.remove_target(h.proc)

    def _ended(self, h: RunHandle, exitcode: int | None, killed: str | None) -> None:
        """The process has exited: end the record if it could not, forget the run."""
        if not h.released:      # first, as in a normal end: whoever sees the run ended may go on
            gone = {j: {"state": None, **{k: (h.live.get(j) or {}).get(k) for k in ("t", "position")},
                        "velocity": None, "torque": None} for j in h.open_joints}
            self._release(h, gone)
        try:
            run = self.store.get_run(h.run_id)
            if run["state"] not in FINAL:
                self._end_record(h, run, exitcode, killed)
        except Exception:
            log.exception("could not record the end of run %s", h.run_id)
        with self._lock, self._tally:
            self.handles.pop(h.run_id, None)
            self._overruns_ended += h.overruns
            self.finished_progress[h.run_id] = h.progress
            if len(self.finished_progress) > 1000:
                self.finished_progress.pop(next(iter(self.finished_progress)))
        h.done.set()

    def _end_record(self, h: RunHandle, run: dict, exitcode: int | None, killed: str | None) -> None:
        if exitcode is not None and exitcode < 0:
            try:
                how = signal.Signals(-exitcode).name
            except ValueError:
                how = f"signal {-exitcode}"
            what = f"the run's control process (pid {h.proc.pid}) was killed by {how}"
        else:
            what = f"the run's control process (pid {h.proc.pid}) exited with code {exitcode}"
        what += f" ({'by the service: ' + killed if killed else 'not by the service'}) before ending the run"
        # latched now: the run was stopped by it (its process may be the one the e-stop
        # killed, before the trigger got to mark the runs)
        estopped = h.estopped or (self.estop.reason if self.estop.active else None)
        if estopped is not None:
            state, error = "failed", f"emergency stop: {estopped}; {what}"
        elif exitcode is not None and exitcode < 0:
            state, error = "interrupted", what
        else:
            state, error = "failed", what
        result = dict(run.get("result") or {})          # a calibration's plan stays resumable
        result.update(progress=h.progress, control={"clock": self.cfg.clock, "host_overruns": h.overruns})
        for child in self.store.list_runs(parent_id=h.run_id, state="running", limit=1000):
            self.store.finish_run(child["id"], "interrupted", error=what)
        self.store.finish_run(h.run_id, state, result=result, error=error)
        Emitter(h.run_id, [self.store.emit], first_seq=self.store.last_seq(h.run_id) + 1).stop(state, error=error)
