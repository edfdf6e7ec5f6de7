"""Run manager: one worker thread per run, joint locks, cancel, progress, live samples.

A run takes its joints when it is created (``start`` answers 409 when one is busy or the
e-stop is latched), so a run never waits in a queue behind another: ``queued`` only lasts
until its worker thread has claimed it.  The worker owns the run's rig; request handlers
only read the store and the in-memory ``RunHandle`` (progress, newest samples), so they
never block the control loop.
"""
from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field

from bench.errors import BenchError, InputError
from bench.store import FINAL, Store, pid_alive
from drivers.protocols import DriveError
from procedures.config import BenchConfig
from procedures.events import Cancel, Cancelled, Emitter

from api import procedures as P
from api.safety import EStop

log = logging.getLogger(__name__)


class Conflict(BenchError):
    """The request is valid but the bench cannot do it now (busy joint, e-stop): 409."""


class NotFound(BenchError):
    """Unknown run or joint: 404."""


@dataclass
class RunHandle:
    run_id: str
    procedure: str
    joints: list[str]            # joints the run holds
    options: dict
    stages_total: int
    cancel: Cancel = field(default_factory=Cancel)
    drives: dict = field(default_factory=dict)      # joint -> GuardedDrive while open
    stages_done: int = 0
    partial: float = 0.0         # progress inside the running stage, 0..1
    estopped: str | None = None
    thread: threading.Thread | None = None
    done: threading.Event = field(default_factory=threading.Event)

    @property
    def progress(self) -> float:
        if self.stages_total <= 0:
            return 0.0
        return min(1.0, (self.stages_done + min(self.partial, 0.99)) / self.stages_total)

    def on_event(self, doc: dict) -> None:
        """Sink of the run's documents, called in the control thread: counters only."""
        name, d = doc.get("name"), doc.get("data") or {}
        if name == "stage":
            if d.get("status") in ("done", "failed", "skipped"):
                self.stages_done += 1
                self.partial = 0.0
        elif name == "trial":             # excitation trials: a geometric approach to 1
            self.partial = 1.0 - 0.75 * (1.0 - self.partial)
        elif name == "tracking":          # one variant finished
            self.partial = min(0.99, self.partial + 0.5)

    def samples(self) -> dict:
        out = {}
        for jid, d in list(self.drives.items()):
            s = getattr(d, "last", None)
            if s is not None:
                out[jid] = {"t": s.t, "position": s.position, "velocity": s.velocity, "torque": s.torque,
                            "state": getattr(s.state, "value", str(s.state))}
        return out


class RunManager:
    def __init__(self, store: Store, bench_spec: str, cfg: BenchConfig, transport: str, estop: EStop):
        self.store = store
        self.bench_spec = bench_spec
        self.cfg = cfg
        self.transport = transport
        self.estop = estop
        self.busy: dict[str, str] = {}              # joint -> run id
        self.handles: dict[str, RunHandle] = {}     # active runs
        self.finished_progress: dict[str, float] = {}
        self.last_drive: dict[str, dict] = {}       # joint -> last sample/state after its run
        self._lock = threading.Lock()
        self._closing = False
        estop.on_trigger(self._on_estop)
        self._recover()

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
                run_id = start_calibration(self.store, self.bench_spec, ids, seed)
                total = len(ids) * len(STAGES)
            else:
                run_id = self.store.create_run(P.KINDS[procedure], seed=seed, state="queued",
                                               config={"procedure": procedure, "joints": ids, "options": options,
                                                       "bench": self.bench_spec, "transport": self.transport})
                total = len(ids) * (2 if procedure == "identify" else 1)
            h = RunHandle(run_id, procedure, ids, dict(options), total)
            for j in held:
                self.busy[j] = run_id
            self.handles[run_id] = h
            h.thread = threading.Thread(target=self._work, args=(h,), name=f"run-{run_id}", daemon=True)
            h.thread.start()
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
        if h is None:
            return False
        h.cancel.set(reason)
        return True

    def _on_estop(self, reason: str) -> None:
        for h in list(self.handles.values()):
            h.estopped = reason
            h.cancel.set(f"emergency stop: {reason}")

    def shutdown(self, timeout: float = 20.0) -> None:
        with self._lock:
            self._closing = True
            handles = list(self.handles.values())
        for h in handles:
            h.cancel.set("the service is shutting down")
        deadline = time.monotonic() + timeout
        for h in handles:
            if h.thread is not None:
                h.thread.join(max(0.0, deadline - time.monotonic()))

    def active(self) -> list[RunHandle]:
        return list(self.handles.values())

    def progress(self, run: dict) -> float:
        h = self.handles.get(run["id"])
        if h is not None:
            return h.progress
        if run["state"] == "succeeded":
            return 1.0
        return self.finished_progress.get(run["id"], ((run.get("result") or {}).get("progress") or 0.0))

    # --- the worker -------------------------------------------------------------------------------
    def _work(self, h: RunHandle) -> None:
        try:
            if h.procedure == "calibrate":
                self._calibrate(h)
            else:
                self._motion(h)
        except Exception as e:  # a bug must not leave a run 'running' or a joint locked
            log.exception("run %s crashed", h.run_id)
            try:
                self.store.finish_run(h.run_id, "failed", error=f"internal error: {e.__class__.__name__}: {e}")
            except Exception:
                log.exception("could not record the failure of run %s", h.run_id)
        finally:
            self._release(h)

    def _release(self, h: RunHandle) -> None:
        with self._lock:
            for jid, d in h.drives.items():
                s = d.last
                st = getattr(d, "final_state", None) or (s.state.value if s is not None else None)
                off = st in ("disabled", "quick_stop", "fault")
                self.last_drive[jid] = {"state": st, "t": s.t if s else None,
                                        "position": s.position if s else None,
                                        "velocity": 0.0 if off else (s.velocity if s else None),
                                        "torque": 0.0 if off else (s.torque if s else None)}
            for j, rid in list(self.busy.items()):
                if rid == h.run_id:
                    del self.busy[j]
            self.handles.pop(h.run_id, None)
            self.finished_progress[h.run_id] = h.progress
            if len(self.finished_progress) > 1000:
                self.finished_progress.pop(next(iter(self.finished_progress)))
        h.done.set()

    def _wrap(self, h: RunHandle):
        def wrap(drives: dict) -> dict:
            guarded = self.estop.wrap(drives, h.run_id)
            h.drives.update(guarded)
            return guarded
        return wrap

    def _motion(self, h: RunHandle) -> None:
        store, run_id = self.store, h.run_id
        store.claim(run_id)
        emit = Emitter(run_id, [store.emit, h.on_event], first_seq=store.last_seq(run_id) + 1)
        emit.start(kind=P.KINDS[h.procedure], procedure=h.procedure, joints=h.joints, options=h.options)
        ctx = P.Context(store=store, bench=self.cfg, transport=self.transport, run_id=run_id,
                        options=h.options, cancel=h.cancel, emit=emit, wrap_drives=self._wrap(h))
        state, error, result, rig, trace = "succeeded", None, {"joints": {}}, None, None
        try:
            h.cancel.check()
            rig = P.open_rig(ctx, h.joints)
            trace = P.attach_trace(ctx, rig)
            for jid in h.joints:
                result["joints"][jid] = P.BODIES[h.procedure](ctx, rig, jid)
        except Cancelled as e:
            state, error = "cancelled", str(e)
            emit.event("cancelled", reason=str(e))
        except (BenchError, DriveError) as e:
            state, error = "failed", str(e)
        finally:
            if rig is not None:
                rig.trace = None
                P.close_rig(ctx, rig)
            if trace is not None:
                trace.close()            # a cancelled or failed run keeps its partial trace
        if h.estopped is not None:
            state, error = "failed", f"emergency stop: {h.estopped}"
        result["control"] = ctx.control
        result["progress"] = 1.0 if state == "succeeded" else h.progress
        store.finish_run(run_id, state, result=result, error=error)
        emit.stop(state, error=error)

    def _calibrate(self, h: RunHandle) -> None:
        from procedures.calibration import CalibrationSettings, calibrate
        st = CalibrationSettings(search=P.search_settings(h.options), tracking=P.tracking_settings(h.options),
                                 force_simulated=self.transport == "simulated",
                                 hardware=self.transport == "hardware",
                                 plots=bool(h.options.get("plots", True)), wrap_drives=self._wrap(h))
        start = P.pacer_overruns(self.cfg)
        error = None
        try:
            report = calibrate(self.store, h.run_id, on_event=h.on_event, cancel=h.cancel, settings=st)
        except (BenchError, DriveError) as e:   # e.g. the e-stop refused to open the next rig
            report, error = None, str(e)
        run = self.store.get_run(h.run_id)
        end = P.pacer_overruns(self.cfg)
        result = dict(run["result"] or {})
        result["joints"] = P.calibration_summary(report or result.get("report") or {})
        result["control"] = {"clock": self.cfg.clock, "host_overruns": None if start is None or end is None
                             else end - start}
        state = run["state"] if run["state"] in FINAL else "failed"
        if h.estopped is not None:
            state, error = "failed", f"emergency stop: {h.estopped}"
        elif error is not None:
            state = "failed"
        result["progress"] = 1.0 if state == "succeeded" else h.progress
        self.store.finish_run(h.run_id, state, result=result, error=error or run.get("error"))
