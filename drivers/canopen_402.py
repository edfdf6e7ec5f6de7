"""A CiA 402 torque drive over CANopen (python-canopen on python-can).

Start-up: NMT pre-operational, SDO configuration (rated torque 0x6076, max torque 0x6072,
software position limits 0x607D, quick stop option 0x605A, heartbeat producer 0x1017 and
the drive's heartbeat consumer 0x1016 watching the host, so the drive stops when the host
dies), PDO mapping, mode of operation (cyclic synchronous torque 10, else profile torque 4,
confirmed by reading 0x6061 because python-canopen's op_mode setter only logs a failure),
then NMT operational.

One owner per SDO channel: python-canopen's SDO client matches replies to requests through a
single queue per node, so two threads transferring at once read each other's answers (or
time out).  Every SDO transfer here holds ``sdo_lock``; the e-stop never uses SDO at all:
``torque_off`` is one RPDO frame (no lock to wait for), and ``confirm_off`` reads the
statusword from the TPDO answering a SYNC of its own.

Cyclic data:  RPDO1 = controlword 0x6040 + target torque 0x6071 (asynchronous, so a quick
stop acts at once; CST latches the target at the SYNC anyway), TPDO1 = statusword 0x6041 +
position 0x6064 + torque 0x6077, TPDO2 = velocity 0x606C (+ the drive time 0x2001 when the
drive has it), both sent on every SYNC.  The hot path packs and unpacks these layouts with
``struct`` rather than through PdoMap objects.

Units: position counts / counts_per_unit -> rad or m; velocity counts/s likewise;
torque per-mille of 0x6076 (read back from the drive, mN·m) -> N·m.
"""
from __future__ import annotations

import struct
import threading
import time
from pathlib import Path

import canopen
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from drivers.canopen_bus import SharedBus
from drivers.protocols import (CommunicationTimeout, DriveError, DriveFault, DriveState,
                               DriveStatus, LimitViolation, ProtocolViolation, Sample,
                               WatchdogExpired)
from drivers.pacing import Pacer
from drivers.registry import register
from drivers.safety import SampleGuard

DEFAULT_EDS = str(Path(__file__).resolve().parent.parent / "virtual_drives" / "od"
                  / "cia402_torque.eds")
CW_SHUTDOWN, CW_SWITCH_ON, CW_ENABLE, CW_QUICK_STOP, CW_FAULT_RESET = 0x06, 0x07, 0x0F, 0x02, 0x80
CW_DISABLE_VOLTAGE = 0x00      # -> switch on disabled from any state, quick stop active included
_TPDO1 = struct.Struct("<Hih")
_RPDO1 = struct.Struct("<Hh")


def state_of(sw: int) -> str:
    """CiA 402 state name from a statusword."""
    if sw & 0x4F == 0x08 or sw & 0x4F == 0x0F:
        return "FAULT"
    if sw & 0x4F == 0x40:
        return "SWITCH ON DISABLED"
    return {0x21: "READY TO SWITCH ON", 0x23: "SWITCHED ON", 0x27: "OPERATION ENABLED",
            0x07: "QUICK STOP ACTIVE"}.get(sw & 0x6F, "NOT READY TO SWITCH ON")


_DRIVE_STATE = {"FAULT": DriveState.FAULT, "OPERATION ENABLED": DriveState.ENABLED,
                "QUICK STOP ACTIVE": DriveState.QUICK_STOP}


@register("canopen")
class Cia402Drive:
    def __init__(self, j: dict):
        self.j = j
        self.name = j["id"]
        self.node_id = j["node_id"]
        self.cpu = float(j["counts_per_unit"])
        self.timeout = float(j["reply_timeout"])
        self.guard = SampleGuard(j)
        self.bus = SharedBus.acquire(j)
        self.net = self.bus.network
        self.cond = threading.Condition()
        self.sdo_lock = threading.RLock()   # the node's SDO channel has one user at a time
        self.send_lock = threading.Lock()   # RPDO: the halted check and the frame, together
        self.halted = False                 # e-stop: never enabled again by this object
        self.stop_acked: DriveState | None = None   # the last stop the drive acknowledged
        self.latched: DriveError | None = None
        self.want = DriveState.DISABLED
        self.cw = CW_SHUTDOWN
        self.emcy: canopen.emcy.EmcyError | None = None
        self.last_heartbeat = time.monotonic()
        self.pacer = Pacer.shared(j["clock"], j["control_period"])
        self.consumed = 0              # pacer tick of the last sample returned
        self.last: Sample | None = None
        self._tp1 = (0, 0, 0)
        self._latest: tuple | None = None   # (seq, Sample)
        self._t_wrap = 0
        self._t_prev_raw = 0
        try:
            self.node = canopen.RemoteNode(self.node_id, j.get("eds", DEFAULT_EDS))
            self.net.add_node(self.node)
            self.node.sdo.RESPONSE_TIMEOUT = max(0.2, self.timeout)
            self.node.emcy.add_callback(self._on_emcy)
            self.net.subscribe(0x700 + self.node_id, self._on_heartbeat)
            self._configure()
        except BaseException:
            self._teardown()
            raise

    # --- configuration ---------------------------------------------------------------------
    def _sdo(self, what: str, fn):
        try:
            with self.sdo_lock:
                return fn()
        except SdoCommunicationError as exc:
            raise CommunicationTimeout(f"{self.name}: CANopen node {self.node_id} on "
                                       f"{self.j['interface']}:{self.j['channel']} did not "
                                       f"answer ({what}): {exc}") from exc
        except SdoAbortedError as exc:
            raise DriveError(f"{self.name}: node {self.node_id} refused {what}: {exc}") from exc

    def _write(self, index: int, sub: int | None, value: int) -> None:
        var = self.node.sdo[index] if sub is None else self.node.sdo[index][sub]
        self._sdo(f"write 0x{index:04X}", lambda: setattr(var, "raw", value))

    def _read(self, index: int, sub: int | None = None) -> int:
        var = self.node.sdo[index] if sub is None else self.node.sdo[index][sub]
        return self._sdo(f"read 0x{index:04X}", lambda: var.raw)

    def _configure(self) -> None:
        j, od = self.j, self.node.object_dictionary
        self.node.nmt.state = "PRE-OPERATIONAL"
        if self._read(0x1000) & 0xFFFF != 402:
            raise DriveError(f"{self.name}: node {self.node_id} is not a CiA 402 drive")
        self._write(0x6076, None, int(round(j["rated_torque"] * 1000)))
        self.rated = self._read(0x6076) / 1000.0
        if self.rated <= 0:
            raise DriveError(f"{self.name}: drive reports a rated torque 0x6076 of 0")
        self._write(0x6072, None, min(int(j["torque_limit"] / self.rated * 1000), 0xFFFF))
        lo, hi = (int(round(x * self.cpu)) for x in j["position_limits"])
        self._write(0x607D, 1, lo)
        self._write(0x607D, 2, hi)
        if 0x605A in od:
            self._write(0x605A, None, 2)   # brake on the quick-stop ramp, then power off
        self._write(0x1017, None, int(j["heartbeat_ms"]))
        self._write(0x1016, 1, (j["host_node_id"] << 16) | int(round(j["watchdog_s"] * 1000)))
        self.bus.beat()                   # the consumer arms on the first heartbeat it sees
        self._map_pdos(0x2001 in od)
        self.mode = None
        for mode in (10, 4):              # cyclic synchronous torque, else profile torque
            self._write(0x6060, None, mode)
            if self._read(0x6061) == mode:
                self.mode = mode
                break
        if self.mode is None:
            raise DriveError(f"{self.name}: drive accepts neither cyclic synchronous torque "
                             f"(10) nor profile torque (4) in 0x6060")
        self.last_heartbeat = time.monotonic()
        self.node.nmt.state = "OPERATIONAL"

    def _map_pdos(self, drive_clock: bool) -> None:
        n = self.node_id
        self.has_clock = drive_clock
        layouts = {
            "r1": (self.node.rpdo[1], 0x200 + n, 255, [0x6040, 0x6071]),
            "t1": (self.node.tpdo[1], 0x180 + n, 1, [0x6041, 0x6064, 0x6077]),
            "t2": (self.node.tpdo[2], 0x280 + n, 1, [0x606C] + ([0x2001] if drive_clock else [])),
        }
        used = {id(m) for m, *_ in layouts.values()}
        for maps in (self.node.rpdo, self.node.tpdo):
            for m in maps.map.values():      # every other PDO off: no stray bus load
                if id(m) not in used and m.predefined_cob_id is not None:
                    m.cob_id, m.enabled = m.predefined_cob_id, False
                    m.clear()
                    self._sdo("PDO configuration", m.save)
        for m, cob, trans, objs in layouts.values():
            m.clear()
            for index in objs:
                m.add_variable(index)
            m.cob_id, m.trans_type, m.enabled = cob, trans, True
            self._sdo("PDO mapping", m.save)
            if m.on_message in self.net.subscribers.get(cob, ()):
                self.net.unsubscribe(cob, m.on_message)   # our own struct decoding below
        self.rpdo_id = 0x200 + n
        self._tpdo2 = struct.Struct("<iI" if drive_clock else "<i")
        self.net.subscribe(0x180 + n, self._on_tpdo1)
        self.net.subscribe(0x280 + n, self._on_tpdo2)

    # --- receive callbacks (python-can notifier thread) ----------------------------------------
    def _on_heartbeat(self, can_id, data, timestamp) -> None:
        self.last_heartbeat = time.monotonic()

    def _on_emcy(self, err) -> None:
        if err.code:
            self.emcy = err

    def _on_tpdo1(self, can_id, data, timestamp) -> None:
        if len(data) >= 8:
            self._tp1 = _TPDO1.unpack_from(data)

    def _on_tpdo2(self, can_id, data, timestamp) -> None:
        if len(data) < self._tpdo2.size:
            return
        sw, pos, tq = self._tp1
        if self.has_clock:
            vel, raw_t = self._tpdo2.unpack_from(data)
            if raw_t < self._t_prev_raw and self._t_prev_raw - raw_t > 1 << 31:
                self._t_wrap += 1 << 32    # 0x2001 wraps after 71 minutes
            self._t_prev_raw = raw_t
            t = (raw_t + self._t_wrap) * 1e-6
        else:
            (vel,) = self._tpdo2.unpack_from(data)
            t = self.bus.last_sync - self.bus.t0
        state = _DRIVE_STATE.get(state_of(sw), DriveState.DISABLED)
        s = Sample(t=t, position=pos / self.cpu, velocity=vel / self.cpu,
                   torque=tq * self.rated / 1000.0, state=state, host_time=time.monotonic())
        with self.cond:
            self._latest = (self.bus.sync_seq, s, sw)
            self.cond.notify_all()

    # --- TorqueDrive -------------------------------------------------------------------------
    def _send(self, cw: int, raw_torque: int) -> None:
        with self.send_lock:      # after torque_off no frame can put torque back on
            if self.halted:
                cw, raw_torque = (CW_QUICK_STOP if cw == CW_ENABLE else cw), 0
            self.net.send_message(self.rpdo_id, _RPDO1.pack(cw, raw_torque))

    def _alive(self) -> None:
        age = time.monotonic() - self.last_heartbeat
        if age > self.j["watchdog_s"]:
            raise WatchdogExpired(f"{self.name}: no heartbeat from node {self.node_id} for "
                                  f"{age:.3f} s (limit {self.j['watchdog_s']:g} s)")

    def _fault(self, sw: int) -> DriveFault:
        err = self.emcy
        if err is None:
            try:
                code = self._read(0x603F)
            except DriveError:
                code = None
            return DriveFault(f"{self.name}: drive in FAULT (statusword 0x{sw:04X}, error code "
                              f"{'?' if code is None else f'0x{code:04X}'})", code)
        return DriveFault(f"{self.name}: EMCY 0x{err.code:04X} {err.get_desc()} "
                          f"(register 0x{err.register:02X})", err.code)

    def cycle(self, torque: float) -> Sample:
        """Enabled: command ``torque`` for the next period.  Otherwise (after ``quick_stop``,
        ``disable`` or an error) command nothing and report the drive's state, so a caller
        can watch the stop; only communication failures raise then."""
        enabled = self.want == DriveState.ENABLED
        try:
            self._alive()
            raw = int(round(self.guard.command(torque) / self.rated * 1000)) if enabled else 0
            self._send(self.cw, raw)
            tick = self.pacer.next_tick(self.consumed)
            target = self.bus.sync_for(tick)
            deadline = time.monotonic() + self.timeout
            with self.cond:
                while self._latest is None or self._latest[0] < target:
                    left = deadline - time.monotonic()
                    if left <= 0 or self.bus.silent:
                        raise CommunicationTimeout(
                            f"{self.name}: no TPDO from node {self.node_id} within "
                            f"{self.timeout * 1e3:.0f} ms of SYNC {target}")
                    self.cond.wait(left)
                _, s, sw = self._latest
            self.consumed = tick
            return self._check(s, sw) if enabled else s
        except DriveError as exc:
            if enabled:
                self.latched = exc
                self.quick_stop()
            raise

    def _check(self, s: Sample, sw: int) -> Sample:
        prev, g = self.last, self.guard
        if self.has_clock:
            g.fresh(s.t, prev)
        if s.state == DriveState.FAULT:
            raise self._fault(sw)
        g.plausible(s, prev)
        self.last = s
        if s.state != DriveState.ENABLED:
            if sw & 0x0800:
                raise LimitViolation(f"{self.name}: drive stopped at its internal limit "
                                     f"(statusword 0x{sw:04X}, position {s.position:.6g})")
            raise DriveError(f"{self.name}: drive left operation enabled: {state_of(sw)}")
        g.limits(s)
        return s

    def _halt_check(self) -> None:
        if self.halted:
            raise DriveError(f"{self.name}: emergency stop: torque off; not enabling")

    def _await_state(self, want: str, cw: int) -> None:
        self._halt_check()        # an e-stop during enable() ends it between two transfers
        self._write(0x6040, None, cw)
        deadline = time.monotonic() + max(10 * self.timeout, 0.5)
        while True:
            sw = self._read(0x6041)
            if state_of(sw) == want:
                return
            if time.monotonic() > deadline:
                raise ProtocolViolation(f"{self.name}: statusword 0x{sw:04X} ({state_of(sw)}) "
                                        f"did not follow controlword 0x{cw:02X} to {want}")
            time.sleep(0.002)

    def enable(self) -> None:
        self._alive()
        self.emcy = None
        sw = self._read(0x6041)
        if state_of(sw) == "FAULT":
            self._write(0x6040, None, 0x00)
            self._await_state("SWITCH ON DISABLED", CW_FAULT_RESET)
        self._write(0x6071, None, 0)
        if state_of(self._read(0x6041)) in ("OPERATION ENABLED", "QUICK STOP ACTIVE"):
            self._await_state("SWITCH ON DISABLED", CW_DISABLE_VOLTAGE)
        if state_of(self._read(0x6041)) == "SWITCH ON DISABLED":
            self._await_state("READY TO SWITCH ON", CW_SHUTDOWN)
        self._await_state("SWITCHED ON", CW_SWITCH_ON)
        with self.cond:
            self._latest, self.last = None, None
        self.consumed = self.pacer.tick
        self.guard.reset()
        self.cw, self.want, self.latched = CW_ENABLE, DriveState.ENABLED, None
        self._send(CW_ENABLE, 0)
        self._await_state("OPERATION ENABLED", CW_ENABLE)
        if self.halted:           # the stop raced the last transfer: stop again, refuse
            self.torque_off()
            self._halt_check()

    def _stop_with(self, cw: int, want: DriveState) -> None:
        # the RPDO acts at once; the SDO write confirms the drive has it.  Never raises.
        self.cw, self.want = cw, want
        try:
            self._send(cw, 0)
        except Exception:
            pass
        sdo = self.node.sdo
        with self.sdo_lock:
            saved, sdo.RESPONSE_TIMEOUT = sdo.RESPONSE_TIMEOUT, min(sdo.RESPONSE_TIMEOUT, 0.1)
            try:
                sdo[0x6040].raw = cw
                self.stop_acked = want    # the drive acknowledged the stop (SDO reply)
            except Exception:
                pass
            finally:
                sdo.RESPONSE_TIMEOUT = saved

    def quick_stop(self) -> None:
        self._stop_with(CW_QUICK_STOP, DriveState.QUICK_STOP)

    def disable(self) -> None:
        self._stop_with(CW_DISABLE_VOLTAGE, DriveState.DISABLED)

    # --- e-stop: from any thread, whatever the control thread is doing ---------------------------
    def torque_off(self) -> None:
        """Quick stop now: one RPDO frame, no SDO, no lock a transfer could hold.  From then
        on this object never commands torque or enables again.  Never raises."""
        self.halted = True
        self.cw, self.want = CW_QUICK_STOP, DriveState.QUICK_STOP
        try:
            self._send(CW_QUICK_STOP, 0)
        except Exception:
            pass

    def confirm_off(self, timeout: float) -> DriveState | None:
        """The drive's own state after ``torque_off``, from the statusword of the TPDO that
        answers a SYNC sent here (never an SDO transfer: the control thread may own the
        channel, and a dead drive would cost the SDO timeout); a drive still enabled (an
        enable in flight crossed the stop) is stopped again.  A drive its run has just closed
        answers with the stop it acknowledged on closing (close() disables it by SDO).  None:
        no answer in time."""
        deadline = time.monotonic() + timeout
        while True:
            bus = self.bus
            if bus is None or bus.silent:     # closed (or closing) by its run meanwhile
                return self.stop_acked
            try:
                target = bus.sync_now()
            except Exception:
                return self.stop_acked
            with self.cond:
                while self._latest is None or self._latest[0] < target:
                    left = deadline - time.monotonic()
                    if self.bus is None:
                        return self.stop_acked
                    if left <= 0:
                        return None
                    self.cond.wait(left)
                sw = self._latest[2]
            st = state_of(sw)
            if st != "OPERATION ENABLED":
                return _DRIVE_STATE.get(st, DriveState.DISABLED)
            self.torque_off()
            if time.monotonic() > deadline:
                return DriveState.ENABLED

    def status(self) -> DriveStatus:
        self._alive()
        sw = self._read(0x6041)
        st = state_of(sw)
        faults = []
        if st == "FAULT":
            faults.append(str(self._fault(sw)))
        if sw & 0x0800:
            faults.append("internal limit active")
        if self.latched is not None:
            faults.append(f"host stopped the drive: {self.latched}")
        return DriveStatus(_DRIVE_STATE.get(st, DriveState.DISABLED), faults)

    def _go_silent(self) -> None:
        """Test hook: behave like a host that died (no heartbeat, no SYNC, no frames)."""
        self.bus.silent = True

    def close(self) -> None:
        if getattr(self, "node", None) is not None and not self.bus.silent:
            self.disable()
            try:          # disarm the drive's consumer: an orderly exit is not a dead host
                with self.sdo_lock:
                    self.node.sdo[0x1016][1].raw = 0
            except Exception:
                pass
        self._teardown()

    def _teardown(self) -> None:
        if getattr(self, "bus", None) is None:
            return
        n = self.node_id
        for cob, cb in ((0x180 + n, self._on_tpdo1), (0x280 + n, self._on_tpdo2),
                        (0x700 + n, self._on_heartbeat)):
            try:
                self.net.unsubscribe(cob, cb)
            except (KeyError, ValueError):
                pass
        if getattr(self, "node", None) is not None:
            try:
                del self.net[n]
            except Exception:
                pass
        bus, self.bus = self.bus, None
        with self.cond:           # a confirm_off waiting for a TPDO gives up now
            self.cond.notify_all()
        bus.release()
