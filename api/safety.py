"""E-stop: torque off on every open drive, from the request thread, never through a queue.

Every drive a run opens is wrapped in a ``GuardedDrive`` and registered with the ``EStop``
while it is open.  The wrapper serialises the control loop's ``cycle`` with the rest of the
run's calls (the serial and CANopen drivers are written for one caller at a time),
remembers the newest sample (live samples for SSE and ``GET /joints``, read without touching
the drive), and refuses to cycle while the e-stop is latched, so a run can never put torque
back on after an e-stop; its rig sees a ``DriveError`` and stops, once the e-stop has
confirmed the drives (``settle``): its stopping must not compete with the confirmations.

``EStop.trigger`` latches, then commands torque off on every registered drive *first and at
once* (``torque_off``: one CAN frame / one serial line per drive, sent from this thread
without waiting for any lock or reply), and only then confirms each drive's state in
parallel (``confirm_off``: the CANopen statusword from a TPDO answering a SYNC of its own,
the ODrive axis state between two of the control thread's exchanges) — never through an
SDO transfer, which the control thread may own and which a dead drive makes wait for its
timeout.  Drivers without these (the in-process simulated plugs) are quick-stopped under
their lock as before.  ``reset`` clears the latch (admin only).

The server's runs execute in control processes (``api.run_process``): each one has its own
``EStop`` and guarded drives, and is registered with the server's ``EStop`` as a *target*.
A trigger tells every target at once over its e-stop pipe (before stopping any local drive)
and collects each process's drive reports; a process that does not answer in time is killed.
The server's latch is written to the run store (``estop`` table) before the answer (a store
locked for longer than ``KEEP_WAIT``: logged, written later): it survives a crash and a restart.
"""
from __future__ import annotations

import logging
import threading
import time

from drivers.protocols import DriveFault, DriveState, Sample

log = logging.getLogger(__name__)
LOCK_WAIT = 0.05        # s: longest a legacy (simulated) stop waits for a cycle in flight
CONFIRM_WAIT = 0.2      # s: longest a drive's torque-off confirmation may take (then: unconfirmed)
STOP_JOIN = 2.0         # s: longest the e-stop handler waits for the stop threads
KEEP_WAIT = 1.0         # s: longest the answer waits for the latch's write (begun with the stop)
REMOTE_WAIT = 0.5       # s: longest it waits for a run process's reply before killing it
SETTLE_WAIT = 0.3       # s: longest a latched cycle waits for the confirmations before raising

TORQUE_OFF_STATES = (DriveState.DISABLED, DriveState.QUICK_STOP, DriveState.FAULT)


class EStopActive(DriveFault):
    """Raised by a guarded drive's cycle while the e-stop is latched."""


class GuardedDrive:
    """A ``TorqueDrive`` seen through the e-stop (same protocol, plus ``last``)."""

    def __init__(self, drive, estop: "EStop", run_id: str):
        self.drive = drive
        self.name = drive.name
        self.run_id = run_id
        self.estop = estop
        self.lock = threading.Lock()
        self.last: Sample | None = None
        self.final_state: str | None = None
        self.closing = False
        self.closed = False
        self.closed_event = threading.Event()

    def cycle(self, torque: float) -> Sample:
        if not self.estop.active:
            with self.lock:
                if not self.estop.active:     # not latched while we waited for the lock
                    s = self.drive.cycle(torque)
                    self.last = s
                    return s
        # latched: the run stops here, once the e-stop has confirmed its drives (bounded), so
        # that its reaction (disable, close) does not compete with the confirmations for the
        # drives' lines, their locks and the GIL
        self.estop.settle()
        raise EStopActive(f"{self.name}: emergency stop active")

    def enable(self) -> None:
        self.estop.honour_pending()
        if self.estop.active:
            raise EStopActive(f"{self.name}: emergency stop active; reset it first")
        with self.lock:
            self.drive.enable()

    def quick_stop(self) -> None:
        got = self.lock.acquire(timeout=LOCK_WAIT)
        try:
            self.drive.quick_stop()
        except Exception:   # the protocol says never raises; a stop must not throw anyway
            log.exception("%s: quick_stop raised", self.name)
        finally:
            if got:
                self.lock.release()

    def disable(self) -> None:
        with self.lock:
            self.drive.disable()

    # --- e-stop ----------------------------------------------------------------------------------
    def torque_off(self) -> None:
        """Torque off now, without the lock (the driver's own ``torque_off`` is safe from any
        thread and waits for nothing).  Drivers without one are stopped in ``confirm``."""
        fn = getattr(self.drive, "torque_off", None)
        if fn is not None:
            try:
                fn()
            except Exception:
                log.exception("%s: torque_off raised", self.name)

    def confirm(self, timeout: float) -> dict:
        """The drive's state after ``torque_off``, as the e-stop reports it."""
        fn = getattr(self.drive, "confirm_off", None)
        if fn is None:             # a legacy driver: quick stop under the lock, then ask it
            self.quick_stop()
            return EStop._report(self)
        try:
            state = fn(timeout)
        except Exception as e:
            state, why = None, f"{e.__class__.__name__}: {e}"
        else:
            why = f"no answer within {timeout * 1e3:.0f} ms after torque off"
        if state is None and self.closing:    # its run is closing it: the state it was left in
            self.closed_event.wait(timeout)
            if self.final_state is not None:
                return self._stop_report(self.final_state)
        if state is None:
            return {"joint": self.name, "run_id": self.run_id, "state": None, "torque_off": None,
                    "error": f"torque off sent; {why}"}
        return self._stop_report(_state_name(state))

    def _stop_report(self, state: str) -> dict:
        return {"joint": self.name, "run_id": self.run_id, "state": state,
                "torque_off": state in {s.value for s in TORQUE_OFF_STATES}, "error": None}

    def status(self):
        with self.lock:
            return self.drive.status()

    def close(self) -> None:
        if self.closed:
            return
        self.closing = True
        try:
            with self.lock:
                try:    # the state the drive was left in, for GET /joints and the e-stop report
                    self.final_state = _state_name(self.drive.status().state)
                except Exception:
                    self.final_state = None
                try:
                    self.drive.close()
                    if self.final_state == DriveState.ENABLED.value:
                        self.final_state = DriveState.DISABLED.value   # close() disables it
                finally:
                    self.closed = True
                    self.closed_event.set()
        finally:
            self.estop.unregister(self)

    def __getattr__(self, name):  # test hooks and extras of the concrete driver
        if name == "drive":
            raise AttributeError(name)
        return getattr(self.drive, name)


def _state_name(state) -> str:
    return state.value if isinstance(state, DriveState) else str(state)


class EStop:
    def __init__(self, pending=None, store=None):
        """``pending()``: True when a trigger is on its way but not handled yet (a run
        process's e-stop pipe holds a message its listener has not read).  ``store``: where
        the latch is kept (``bench.store.Store``); a latch found there is restored now."""
        self._pending = pending
        self._store = store
        self._persist_lock = threading.Lock()
        self._generation = 0           # bumped by reset: a persist of an older trigger is dropped
        self._latched = threading.Event()
        self._settled = threading.Event()      # clear while a trigger confirms the drives
        self._settled.set()
        self.active = False
        self.reason = ""
        self.triggered_at: float | None = None
        self.last_result: list[dict] = []
        self._drives: list[GuardedDrive] = []
        self._targets: list = []       # run processes (api.run_process.RunProcess)
        self._lock = threading.Lock()
        self._trigger_lock = threading.Lock()   # one trigger at a time reads the targets' replies
        self._listeners: list = []     # called with the reason after a trigger (runs cancel)
        latch = store.get_latch() if store is not None else None
        if latch is not None:          # latched before a crash or a restart: still latched
            self.active = True
            self._latched.set()
            self.reason = latch["reason"]
            self.triggered_at = latch["triggered_at"]
            self.last_result = latch["drives"]

    def _persist(self, drives: list | None, generation: int) -> None:
        """Keep the latch.  A reset since the trigger (``generation``) wins: a late write never
        re-latches."""
        with self._persist_lock:
            if generation != self._generation or not self.active:
                return
            try:
                self._store.set_latch(self.reason, self.triggered_at, drives)
            except Exception:      # the stop itself has happened; say loudly that it is not kept
                log.exception("e-stop: could not persist the latch")

    def _persist_later(self, drives: list | None) -> threading.Event | None:
        """Write the latch in a thread of its own (the run processes write to the same SQLite
        file: a trigger must not wait for their write lock while it stops drives); the event
        is set once it is written (or failed, logged)."""
        if self._store is None:
            return None
        done = threading.Event()

        def write(generation: int) -> None:
            try:
                self._persist(drives, generation)
            finally:
                done.set()
        threading.Thread(target=write, args=(self._generation,), name="estop-persist", daemon=True).start()
        return done

    def settle(self) -> None:
        """Wait (up to ``SETTLE_WAIT``) until a trigger in progress has its confirmations."""
        self._settled.wait(SETTLE_WAIT)

    def honour_pending(self, wait: float = 2.0) -> None:
        """Before torque goes on: a trigger on its way is waited for (up to ``wait``)."""
        if not self.active and self._pending is not None and self._pending():
            self._latched.wait(wait)

    # --- drives ------------------------------------------------------------------------------
    def wrap(self, drives: dict, run_id: str) -> dict:
        """Guard and register freshly opened drives; refuse (closing them) while latched.
        Checked under the lock a trigger snapshots the drives with: a drive is either
        stopped by a trigger or refused after it, never missed."""
        self.honour_pending()
        guarded = {jid: GuardedDrive(d, self, run_id) for jid, d in drives.items()}
        with self._lock:
            if not self.active:
                self._drives.extend(guarded.values())
                return guarded
        for d in drives.values():
            try:
                d.close()
            except Exception:
                pass
        raise EStopActive("emergency stop active; reset it before starting motion")

    def unregister(self, drive: GuardedDrive) -> None:
        with self._lock:
            if drive in self._drives:
                self._drives.remove(drive)

    def open_drives(self) -> list[GuardedDrive]:
        with self._lock:
            return list(self._drives)

    def on_trigger(self, callback) -> None:
        self._listeners.append(callback)

    def add_target(self, target) -> None:
        """Register a run process (before it starts), under the lock a trigger snapshots with:
        it is either reached by a trigger or refused (while latched).  The target needs
        ``estop_send(reason)`` and ``estop_collect(deadline) -> list of drive reports``."""
        with self._lock:
            if self.active:
                raise EStopActive(f"e-stop is active ({self.reason}); an admin must reset it")
            self._targets.append(target)

    def remove_target(self, target) -> None:
        with self._lock:
            if target in self._targets:
                self._targets.remove(target)

    # --- the stop -----------------------------------------------------------------------------
    def trigger(self, reason: str) -> dict:
        """Latch, tell every run process, quick-stop every local drive in parallel, then read
        back each drive's state (local ones here, remote ones in their processes' replies)."""
        with self._trigger_lock:
            t0 = time.perf_counter()
            self._settled.clear()
            try:
                kept, result = self._stop(reason)
            finally:
                self._settled.set()
            stop_latency = time.perf_counter() - t0
            if kept is not None and not kept.wait(max(0.0, t0 + KEEP_WAIT - time.perf_counter())):
                log.error("e-stop: the latch is not written after %.1f s (store busy); a crash "
                          "before it is would restart unlatched", KEEP_WAIT)
        for cb in list(self._listeners):
            try:
                cb(reason)
            except Exception:
                log.exception("e-stop listener failed")
        self.last_result = result
        self._persist_later(result)      # with the drives' reports
        return {"active": True, "reason": reason, "stop_latency_ms": 1e3 * stop_latency,
                "drives": result}

    def _stop(self, reason: str) -> tuple[threading.Event | None, list]:
        self.active = True            # first: no cycle may command torque from now on
        self._latched.set()
        self.reason = reason
        self.triggered_at = time.time()
        with self._lock:
            drives, targets = list(self._drives), list(self._targets)
        for tg in targets:            # the processes start stopping while we stop ours
            try:
                tg.estop_send(reason)
            except Exception:         # a dead process: estop_collect reports it
                log.warning("e-stop: could not reach %r", tg, exc_info=True)
        for d in drives:              # torque off everywhere first: frames, no waiting
            d.torque_off()
        # written at once, beside the confirmations (not in their way); the answer waits for
        # it (trigger): a client told "latched" finds it latched after a crash
        kept = self._persist_later(None)
        reports: list = [None] * len(drives)

        def confirm(i: int, d: GuardedDrive) -> None:
            reports[i] = d.confirm(CONFIRM_WAIT)

        threads = [threading.Thread(target=confirm, args=(i, d), name=f"estop-{d.name}", daemon=True)
                   for i, d in enumerate(drives)]
        for t in threads:
            t.start()
        deadline = time.monotonic() + STOP_JOIN
        for t in threads:
            t.join(max(0.0, deadline - time.monotonic()))
        remote_deadline = time.monotonic() + REMOTE_WAIT
        remote = [r for tg in targets for r in tg.estop_collect(remote_deadline)]
        local = [r if r is not None else {"joint": d.name, "run_id": d.run_id, "state": None,
                                          "torque_off": None, "error": "no confirmation in time"}
                 for d, r in zip(drives, reports)]
        return kept, local + remote

    @staticmethod
    def _report(d: GuardedDrive) -> dict:
        # the drive's own answer (CANopen statusword / ODrive axis state) after the stop
        try:
            got = d.lock.acquire(timeout=LOCK_WAIT)
            try:    # the run may have closed it meanwhile: then the state it was closed in
                state = d.final_state if d.closed else _state_name(d.drive.status().state)
            finally:
                if got:
                    d.lock.release()
        except Exception as e:
            if d.final_state is None:   # a drive that cannot answer is reported, never hidden
                return {"joint": d.name, "run_id": d.run_id, "state": None, "torque_off": None,
                        "error": f"{e.__class__.__name__}: {e}"}
            # its run was closing it (no lock for us after LOCK_WAIT): close() read the
            # drive's own state just before taking the bus down
            state = d.final_state
        return {"joint": d.name, "run_id": d.run_id, "state": state,
                "torque_off": state in {s.value for s in TORQUE_OFF_STATES}, "error": None}

    def reset(self) -> None:
        with self._persist_lock:
            self._generation += 1
            if self._store is not None:
                self._store.clear_latch()    # first: a crash during reset leaves it latched
            self._latched.clear()
            self.active = False
        self.reason = ""
        self.triggered_at = None
