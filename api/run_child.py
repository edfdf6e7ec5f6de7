"""The control process of one run: the child side of ``api.run_process``.

Started from a forkserver (or spawn) context, never a plain fork of the threaded server.  It
opens the run's rig exactly as the server's worker thread used to (``api.procedures.open_rig``:
VirtualBench + the real CANopen / serial stacks, or simulated / hardware transports; or
``procedures.calibration.calibrate``), writes the run's documents, trace and result to the
store itself (SQLite in WAL mode and the trace's parquet chunks are safe across processes)
and finishes the run record.  Its pipes to the server:

* ``ctrl`` (server -> child): ``("cancel", reason)``, ``("ack",)``.  End of file means the
  server died: the run is ramped down and ends ``interrupted``.
* ``status`` (child -> server): ``{"t": "status"}`` at most every ``STATUS_PERIOD`` (progress,
  newest sample per joint, open drives, host overruns), ``"finishing"`` once the drives are
  closed (the server releases the joints and acks before the record says the run ended),
  ``"done"`` after it.
* ``estop`` (both ways, its own listener thread): ``("estop", seq, reason)`` latches this
  process's ``EStop`` (``GuardedDrive`` refuses cycle/enable from then on) and quick-stops
  every open drive in parallel; the reply is each drive's state report.

The control loop never writes to a pipe: it only updates counters that the publisher thread
sends, so a slow server can never stall a control period.

Kept light at import (stdlib only until ``run``): with spawn, the e-stop listener is up before
the heavy modules load.
"""
from __future__ import annotations

import gc
import logging
import os
import signal
import sys
import threading
import time

log = logging.getLogger(__name__)
STATUS_PERIOD = 0.02     # s: live samples at up to 50 Hz (the SSE maximum), progress, overruns
PROGRESS_PERIOD = 1.0    # s: progress written to the run record at most this often
ACK_WAIT = 2.0           # s: longest wait for the server to release the joints before finishing
# the GIL is handed between threads every 5 ms by default, longer than a 1 ms control period:
# the e-stop listener and the emulated drives' threads must get in quickly
SWITCH_INTERVAL = float(os.environ.get("BENCH_SWITCH_INTERVAL", "0.0005"))


def main(spec: dict, ctrl, status, estop_conn, armed=None) -> None:
    """Process entry point (``multiprocessing.Process`` target)."""
    # Ctrl-C on `bench serve` reaches the whole process group: the server cancels its runs
    # in order (ramp-down) instead of every control loop dying mid-period
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # what the forkserver imported (numpy, scipy, numba, canopen: ~200k objects) never becomes
    # garbage; unfrozen, every full collection rescanned it with the GIL held for 130-220 ms,
    # and an e-stop arriving meanwhile waited (lock-step runs never reach the pacer's freeze)
    gc.freeze()
    from api.lifeline import die_with_parent
    die_with_parent(signal.SIGTERM)     # the forkserver's death (the server's) is a cancel
    if spec.get("cpus"):     # first, while this is the only thread: the others inherit it
        try:
            os.sched_setaffinity(0, spec["cpus"])
        except (AttributeError, OSError):
            pass
    sys.setswitchinterval(SWITCH_INTERVAL)
    logging.basicConfig(level=logging.WARNING, format=f"%(asctime)s run {spec['run_id']} %(levelname)s: %(message)s")
    # likewise inherited by the threads started later.  Lock-step runs never wait for a
    # clock: at a real-time priority they would only take CPU from everything else
    if spec.get("rt_priority") and spec["cfg"].clock == "realtime":
        from drivers.realtime import set_priority
        why_not = set_priority(int(spec["rt_priority"]))
        if why_not:
            log.warning(why_not)
    child = ChildRun(spec, ctrl, status, estop_conn, armed)
    # a terminate() (the multiprocessing atexit of a server that never shut down) is a cancel
    signal.signal(signal.SIGTERM, lambda *_: child.terminated())
    child.run()


class ChildRun:
    def __init__(self, spec: dict, ctrl, status, estop_conn, armed=None):
        from api.safety import EStop
        from procedures.events import Cancel
        self.armed = armed
        self.spec = spec
        self.run_id: str = spec["run_id"]
        self.procedure: str = spec["procedure"]
        self.cfg = spec["cfg"]
        self.cancel = Cancel()
        # an e-stop still in the pipe (the listener not scheduled yet) counts before any enable
        self.estop = EStop(pending=lambda: _pending(estop_conn))
        self.estop.on_trigger(self._on_estop)
        self.estopped: str | None = None
        self.parent_gone = False
        self._parent = os.getppid()
        self.drives: dict = {}               # joint -> GuardedDrive (the newest one opened)
        self.stages_total = int(spec["stages_total"])
        self.stages_done = 0
        self.partial = 0.0                   # progress inside the running stage, 0..1
        self.store = None
        self._status = status
        self._send_lock = threading.Lock()
        self._acked = threading.Event()
        self._finished = threading.Event()
        self._finishing_sent = False
        for name, target, conn in (("estop", self._estop_listener, estop_conn), ("ctrl", self._ctrl_listener, ctrl)):
            threading.Thread(target=target, args=(conn,), name=f"run-{name}", daemon=True).start()

    # --- the pipes ------------------------------------------------------------------------------
    def _send(self, msg: dict) -> None:
        with self._send_lock:
            try:
                self._status.send(msg)
            except OSError:      # the server is gone; the ctrl listener has cancelled the run
                pass

    def _estop_listener(self, conn) -> None:
        while True:
            try:
                kind, seq, reason = conn.recv()
            except (EOFError, OSError):
                return
            if kind == "estop":
                res = self.estop.trigger(reason)
                try:
                    conn.send({"seq": seq, "drives": res["drives"], "stop_latency_ms": res["stop_latency_ms"]})
                except OSError:
                    return

    def _ctrl_listener(self, conn) -> None:
        while True:
            try:
                kind, *args = conn.recv()
            except (EOFError, OSError):
                # the server died: stop the joints in order; nobody will ack any more
                self.parent_gone = True
                self.cancel.set("the service process ended; the run was stopped")
                self._acked.set()
                return
            if kind == "cancel":
                self.cancel.set(args[0])
            elif kind == "ack":
                self._acked.set()

    def terminated(self) -> None:
        """SIGTERM: the forkserver died with the server (``die_with_parent``; this process is
        re-parented by then), or someone terminated this process.  The first is the service
        ending mid-run whichever of it and the ctrl pipe's end of file comes first: a fit
        stops at once on the cancel (``bench.checkpoint``), maybe before the pipe's listener
        has run, and the run would be recorded 'cancelled' instead of 'interrupted'."""
        if os.getppid() != self._parent:
            self.parent_gone = True
        self.cancel.set("the run's control process was terminated")

    def _on_estop(self, reason: str) -> None:
        self.estopped = reason
        self.cancel.set(f"emergency stop: {reason}")

    # --- what the server shows --------------------------------------------------------------------
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

    def overruns(self) -> int:
        from api.procedures import pacer_overruns
        return pacer_overruns(self.cfg) or 0      # this process's pacer: this run's overruns

    def _status_doc(self) -> dict:
        samples, open_ = {}, []
        for jid, d in list(self.drives.items()):
            s = d.last
            if s is not None:
                samples[jid] = {"t": s.t, "position": s.position, "velocity": s.velocity, "torque": s.torque,
                                "state": getattr(s.state, "value", str(s.state))}
            if not d.closed:
                open_.append(jid)
        return {"t": "status", "progress": self.progress, "samples": samples, "open": open_,
                "overruns": self.overruns()}

    def _publish(self) -> None:
        last, kept, kept_at = None, None, 0.0
        while not self._finished.wait(STATUS_PERIOD):
            doc = self._status_doc()
            if doc != last:
                self._send(doc)
                last = doc
            now = time.monotonic()
            if doc["progress"] != kept and now - kept_at >= PROGRESS_PERIOD:
                kept, kept_at = doc["progress"], now
                try:     # in the record too: a crash of both processes keeps how far it got
                    self.store.set_progress(self.run_id, kept)
                except Exception:
                    log.warning("run %s: could not record progress", self.run_id, exc_info=True)

    def _last_drive(self) -> dict:
        out = {}
        for jid, d in self.drives.items():
            s = d.last
            st = d.final_state or (s.state.value if s is not None else None)
            off = st in ("disabled", "quick_stop", "fault")
            out[jid] = {"state": st, "t": s.t if s else None, "position": s.position if s else None,
                        "velocity": 0.0 if off else (s.velocity if s else None),
                        "torque": 0.0 if off else (s.torque if s else None)}
        return out

    # --- the run ------------------------------------------------------------------------------------
    def run(self) -> None:
        try:
            self.store = _store(self.spec["data_dir"])
            threading.Thread(target=self._publish, name="run-status", daemon=True).start()
            if self.procedure == "calibrate":
                self._calibrate()
            else:
                self._motion()
        except Exception as e:  # a bug must not leave a run 'running' or its joints locked
            log.exception("run %s crashed", self.run_id)
            try:
                self._finish("failed", None, f"internal error: {e.__class__.__name__}: {e}")
            except Exception:
                log.exception("could not record the failure of run %s", self.run_id)
                self._send({"t": "finishing", "progress": self.progress, "last_drive": self._last_drive(),
                            "overruns": self.overruns()})
        finally:
            self._finished.set()
            self._send({"t": "done", "progress": self.progress, "overruns": self.overruns()})

    def _finish(self, state: str, result: dict | None, error: str | None, emit=None) -> None:
        """The drives are closed: let the server release the joints, then end the record (a
        client that sees the run ended can start the next one on the same joints at once)."""
        if not self._finishing_sent:
            self._finishing_sent = True
            self._send({"t": "finishing", "progress": self.progress, "last_drive": self._last_drive(),
                        "overruns": self.overruns()})
            self._acked.wait(ACK_WAIT)
        self.store.finish_run(self.run_id, state, result=result, error=error)
        if emit is not None:
            emit.stop(state, error=error)

    def _final_state(self, state: str, error: str | None) -> tuple[str, str | None]:
        if self.estopped is not None:
            return "failed", f"emergency stop: {self.estopped}"
        if self.parent_gone and state in ("cancelled", "succeeded"):
            # also a run whose last stage (a fit) finished after the server died: nobody was
            # there to see it end, and the docs promise 'interrupted' (its result is kept)
            return "interrupted", "the service process ended mid-run; the joints were brought to rest"
        return state, error

    def _wrap(self, drives: dict) -> dict:
        if self.armed is not None:
            self.armed.value = 1      # from now on the server waits for this process's e-stop reply
        guarded = self.estop.wrap(drives, self.run_id)
        self.drives.update(guarded)
        return guarded

    def _motion(self) -> None:
        from api import procedures as P
        from bench.errors import BenchError
        from drivers.protocols import DriveError
        from procedures.events import Cancelled, Emitter
        store, run_id, ids, options = self.store, self.run_id, self.spec["joints"], self.spec["options"]
        store.claim(run_id)
        emit = Emitter(run_id, [store.emit, self.on_event], first_seq=store.last_seq(run_id) + 1)
        emit.start(kind=P.KINDS[self.procedure], procedure=self.procedure, joints=ids, options=options)
        ctx = P.Context(store=store, bench=self.cfg, transport=self.spec["transport"], run_id=run_id,
                        options=options, cancel=self.cancel, emit=emit, wrap_drives=self._wrap)
        state, error, result, rig, trace = "succeeded", None, {"joints": {}}, None, None
        try:
            self.cancel.check()
            rig = P.open_rig(ctx, ids)
            trace = P.attach_trace(ctx, rig)
            for jid in ids:
                result["joints"][jid] = P.BODIES[self.procedure](ctx, rig, jid)
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
        state, error = self._final_state(state, error)
        result["control"] = {**ctx.control, "scheduling": _scheduling()}
        result["progress"] = 1.0 if state == "succeeded" else self.progress
        self._finish(state, result, error, emit)

    def _calibrate(self) -> None:
        from api import procedures as P
        from bench.errors import BenchError
        from bench.store import FINAL
        from drivers.protocols import DriveError
        from procedures.calibration import CalibrationSettings, calibrate
        options, transport = self.spec["options"], self.spec["transport"]
        st = CalibrationSettings(search=P.search_settings(options), tracking=P.tracking_settings(options),
                                 force_simulated=transport == "simulated", hardware=transport == "hardware",
                                 plots=bool(options.get("plots", True)), wrap_drives=self._wrap)
        start = P.pacer_overruns(self.cfg)
        error = None
        self.store.hold = self.run_id
        try:
            report = calibrate(self.store, self.run_id, on_event=self.on_event, cancel=self.cancel, settings=st)
        except (BenchError, DriveError) as e:   # e.g. the e-stop refused to open the next rig
            report, error = None, str(e)
        end = P.pacer_overruns(self.cfg)
        held_state, held_result, held_error = self.store.held or (None, None, None)
        result = dict(held_result or self.store.get_run(self.run_id)["result"] or {})
        if report is None and result.get("report") is None and result.get("plan"):
            # calibrate() was cut short (the e-stop refused the next rig): each joint's
            # status and reason from the plan it had recorded
            from procedures.calibration import build_report
            try:
                report = build_report(self.store, self.run_id, self.cfg, result["plan"])
            except Exception:
                log.warning("run %s: no report from the recorded plan", self.run_id, exc_info=True)
        result["joints"] = P.calibration_summary(report or result.get("report") or {})
        result["control"] = {"clock": self.cfg.clock, "host_overruns": None if start is None or end is None
                             else end - start, "scheduling": _scheduling()}
        state = held_state if held_state in FINAL and error is None else "failed"
        state, error = self._final_state(state, error or held_error)
        result["progress"] = 1.0 if state == "succeeded" else self.progress
        self.store.hold = None
        self._finish(state, result, error)


def _pending(conn) -> bool:
    try:
        return conn.poll(0)
    except (OSError, EOFError, ValueError):
        return False


def _scheduling() -> dict:
    """This control process's policy, priority and CPUs, kept in the run's result."""
    from drivers.realtime import describe
    return describe()


def _store(data_dir: str):
    from bench.store import Store

    class RunStore(Store):
        """``calibrate`` finishes its own record; the run it is given (``hold``) is held back
        here, so the record ends once, with the service's summary, after the joints are free."""
        hold: str | None = None
        held: tuple | None = None

        def finish_run(self, run_id, state, result=None, error=None):
            if run_id == self.hold:
                self.held = (state, result, error)
                return
            super().finish_run(run_id, state, result=result, error=error)

    return RunStore(data_dir)
