"""An ODrive axis over its ASCII protocol on a serial port (pyserial).

One cycle is one pipelined write, ``c <axis> <torque>``, ``f <axis>``,
``r axis<n>.motor.torque_estimate``, ``r axis<n>.error``, and three reply lines: "<pos> <vel>"
(turns, turns/s), the measured torque (the drive's current times its torque constant, in
joint units) and the axis error bits.  ``c`` feeds
the ODrive watchdog (``axis<n>.config.watchdog_timeout``), so the watchdog is fed on every
cycle; a host that stops cycling leaves the axis to its watchdog, which idles the motor.

Every line received takes the next reply slot and must have that reply's shape (two
numbers / one integer); with ``checksum`` on, each line also carries the GCode checksum
``*<xor of the bytes before '*'>`` (decimal).  A cycle with a corrupt or garbage line
resynchronises (drains the line until it is quiet) and reads again once ("f" and "r" only:
re-sending "c" would advance a lock-step drive twice) before failing with
``ProtocolViolation``.
``f`` has no torque field: ``Sample.torque`` is the drive's torque estimate, as a CiA 402
drive's 0x6077 is, so a record carries the torque the drive measured, noise included.

E-stop from another thread: ``torque_off`` writes ``v <axis> 0`` (no reply, so it takes no
reply slot) under ``write_lock``, held only for a write; from then on every ``c`` goes out
with torque 0 and ``enable`` refuses.  ``confirm_off`` reads the axis state (one exchange)
under ``exchange_lock``, which a cycle holds for one exchange only.
"""
from __future__ import annotations

import select
import threading
import time

import serial

from drivers.protocols import (CommunicationTimeout, DriveError, DriveFault, DriveState,
                               DriveStatus, LimitViolation, ProtocolViolation, Sample,
                               WatchdogExpired)
from drivers.pacing import Pacer
from drivers.registry import register
from drivers.safety import SampleGuard

ERR_WATCHDOG = 0x800
ERR_ENDSTOPS = 0x1000 | 0x2000
AXIS_IDLE, AXIS_CLOSED_LOOP = 1, 8


def checksum(text: str) -> int:
    c = 0
    for b in text.encode("ascii"):
        c ^= b
    return c


def _shape(fields: list[str], shape: str) -> list | None:
    try:
        if shape == "ff" and len(fields) == 2:
            return [float(fields[0]), float(fields[1])]
        if shape == "i" and len(fields) == 1:
            return [int(fields[0])]
        if shape == "f" and len(fields) == 1:
            return [float(fields[0])]
    except ValueError:
        pass
    return None


def _halted_line(line: str, axis: int) -> str:
    """A line as it may go out after an e-stop: torque commands at 0, no closed loop."""
    if line.startswith("c "):
        return f"c {axis} 0.0"
    if line.startswith((f"w axis{axis}.requested_state {AXIS_CLOSED_LOOP}", "u ")):
        return f"v {axis} 0 0"
    return line


@register("serial")
class OdriveAsciiDrive:
    def __init__(self, j: dict):
        self.j = j
        self.name = j["id"]
        self.axis = int(j["axis"])
        self.tpu = float(j["turns_per_unit"])
        self.timeout = float(j["reply_timeout"])
        self.use_checksum = bool(j["checksum"])
        self.guard = SampleGuard(j)
        self.lockstep = j["clock"] == "lockstep"
        self.dt = float(j["control_period"])
        self.want = DriveState.DISABLED
        self.latched: DriveError | None = None
        self.last: Sample | None = None
        self.ticks = 0                   # torque commands sent: lock-step time base
        self.pacer = Pacer.shared(j["clock"], self.dt)
        self.consumed = 0
        self.t0 = time.monotonic()
        self.buf = bytearray()
        self.write_lock = threading.Lock()       # whole lines: a stop never splits a command
        self.exchange_lock = threading.RLock()   # request + replies: one reader at a time
        self.halted = False                      # e-stop: torque 0 and never enabled again
        self.stop_acked: DriveState | None = None  # the last stop the drive acknowledged
        try:
            self.ser = serial.Serial(j["port"], baudrate=j["baudrate"], timeout=0,
                                     write_timeout=max(self.timeout, 0.5))
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DriveError(f"{self.name}: cannot open serial port {j['port']!r}: {exc}") \
                from exc
        self.fd = self.ser.fileno()
        try:
            self._configure()
        except BaseException:
            self.ser.close()
            raise

    # --- line protocol ----------------------------------------------------------------------
    def _encode(self, lines: list[str]) -> bytes:
        if self.use_checksum:
            lines = [f"{ln} *{checksum(ln + ' ')}" for ln in lines]
        return ("\n".join(lines) + "\n").encode("ascii")

    def _send(self, lines: list[str]) -> None:
        try:
            with self.write_lock:
                if self.halted:       # after torque_off no line can put torque back on
                    lines = [_halted_line(ln, self.axis) for ln in lines]
                self.ser.write(self._encode(lines))
        except (serial.SerialException, OSError) as exc:
            raise CommunicationTimeout(f"{self.name}: write to {self.j['port']} failed: {exc}") \
                from exc

    def _readline(self, deadline: float) -> bytes | None:
        while True:
            nl = self.buf.find(b"\n")
            if nl >= 0:
                line = bytes(self.buf[:nl]).rstrip(b"\r")
                del self.buf[:nl + 1]
                return line
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                try:
                    self.buf += self.ser.read(self.ser.in_waiting or 1)
                except (serial.SerialException, OSError) as exc:
                    raise CommunicationTimeout(f"{self.name}: read from {self.j['port']} "
                                               f"failed: {exc}") from exc

    def _fields(self, raw: bytes) -> list[str] | None:
        try:
            text = raw.decode("ascii")
        except UnicodeDecodeError:
            return None
        if self.use_checksum:
            body, star, cs = text.rpartition("*")
            if not star or not cs.strip().isdigit() or int(cs) != checksum(body):
                return None
            text = body
        return text.split()

    def _exchange(self, lines: list[str], shapes: list[str], timeout: float | None = None) -> list[list]:
        with self.exchange_lock:
            return self._exchange_locked(lines, shapes, timeout)

    def _exchange_locked(self, lines: list[str], shapes: list[str], timeout: float | None = None) -> list[list]:
        self._send(lines)
        timeout = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + timeout
        got, bad = [], 0
        # the drive answers each query line once, in order: every line received takes the
        # next reply slot, so a corrupt reply fails the exchange at once instead of waiting
        while len(got) + bad < len(shapes):
            raw = self._readline(deadline)
            if raw is None:
                raise CommunicationTimeout(f"{self.name}: no reply from {self.j['port']} within "
                                           f"{timeout * 1e3:.0f} ms to {lines}")
            fields = self._fields(raw)
            value = None if fields is None else _shape(fields, shapes[len(got) + bad])
            if value is None:
                bad += 1
            else:
                got.append(value)
        if bad:
            raise ProtocolViolation(f"{self.name}: {bad} corrupt or unexpected "
                                    f"repl{'y' if bad == 1 else 'ies'} to {lines}")
        return got

    def _resync(self, quiet: float = 0.005) -> None:
        """Drop everything the drive sends until it has been quiet for ``quiet`` s."""
        with self.exchange_lock:
            self._drain(quiet)

    def _drain(self, quiet: float) -> None:
        self.buf.clear()
        while select.select([self.fd], [], [], quiet)[0]:
            self.ser.read(self.ser.in_waiting or 1)

    def _r(self, prop: str, shape: str = "f"):
        return self._exchange([f"r {prop}"], [shape])[0][0]

    def _w(self, prop: str, value) -> None:
        self._send([f"w {prop} {value}"])

    # --- configuration -------------------------------------------------------------------------
    def _configure(self) -> None:
        j, a = self.j, f"axis{self.axis}"
        self._resync()
        self._r("vbus_voltage")              # is anybody there?
        self._w(f"{a}.config.enable_watchdog", 0)
        self._w(f"{a}.config.watchdog_timeout", repr(float(j["watchdog_s"])))
        self._w(f"{a}.motor.config.torque_lim", repr(float(j["torque_limit"])))
        self._w(f"{a}.controller.config.vel_limit", repr(j["velocity_limit"] * self.tpu))
        self._w(f"{a}.controller.config.control_mode", 1)     # torque control
        if self._r(f"{a}.controller.config.control_mode", "i") != 1:
            raise DriveError(f"{self.name}: axis {self.axis} refused torque control mode")

    # --- TorqueDrive -----------------------------------------------------------------------------
    def cycle(self, torque: float) -> Sample:
        """Enabled: command ``torque`` for the next period.  Otherwise (after ``quick_stop``,
        ``disable`` or an error) command 0 and report, so a caller can watch the stop (a
        lock-step drive still advances one period); only communication failures raise."""
        enabled = self.want == DriveState.ENABLED
        try:
            tau = self.guard.command(torque) if enabled else 0.0
            a = self.axis
            read = [f"f {a}", f"r axis{a}.motor.torque_estimate", f"r axis{a}.error"]
            shapes = ["ff", "f", "i"]
            self.consumed = self.pacer.next_tick(self.consumed)
            self.ticks += 1
            try:
                (pos, vel), (meas,), (err,) = self._exchange([f"c {a} {tau!r}"] + read, shapes)
            except ProtocolViolation:
                self._resync()                # one retry after garbage, without "c"
                (pos, vel), (meas,), (err,) = self._exchange(read, shapes)
            t = self.ticks * self.dt if self.lockstep else time.monotonic() - self.t0
            s = Sample(t=t, position=pos / self.tpu, velocity=vel / self.tpu, torque=meas,
                       state=DriveState.FAULT if err else self.want, host_time=time.monotonic())
            return self._check(s, err) if enabled else s
        except DriveError as exc:
            if enabled:
                self.latched = exc
                self.quick_stop()
            raise

    def _check(self, s: Sample, err: int) -> Sample:
        if err & ERR_WATCHDOG:
            raise WatchdogExpired(f"{self.name}: axis {self.axis} watchdog expired "
                                  f"(error 0x{err:X}); motor idle")
        if err & ERR_ENDSTOPS:
            raise LimitViolation(f"{self.name}: axis {self.axis} stopped at its position limit "
                                 f"(error 0x{err:X}, position {s.position:.6g})")
        if err:
            raise DriveFault(f"{self.name}: axis {self.axis} error 0x{err:X}", err)
        self.guard.plausible(s, self.last)
        self.last = s
        self.guard.limits(s)
        return s

    def _halt_check(self) -> None:
        if self.halted:
            raise DriveError(f"{self.name}: emergency stop: torque off; not enabling")

    def enable(self) -> None:
        self._enable()            # the lock per exchange: an e-stop confirms in between
        if self.halted:            # the stop raced the last write: stop again, refuse
            self.torque_off()
            self._halt_check()

    def _enable(self) -> None:
        a = f"axis{self.axis}"
        self._halt_check()
        self._resync()
        if self._r(f"{a}.error", "i"):
            self._send(["sc"])
            err = self._r(f"{a}.error", "i")
            if err:
                raise DriveFault(f"{self.name}: axis {self.axis} error 0x{err:X} did not clear",
                                 err)
        self._w(f"{a}.controller.input_torque", 0)
        self._send([f"u {self.axis}"])
        self._w(f"{a}.config.enable_watchdog", 1)
        self._halt_check()
        self._w(f"{a}.requested_state", AXIS_CLOSED_LOOP)
        deadline = time.monotonic() + max(10 * self.timeout, 0.5)
        while self._r(f"{a}.current_state", "i") != AXIS_CLOSED_LOOP:
            self._halt_check()
            if time.monotonic() > deadline:
                raise ProtocolViolation(f"{self.name}: axis {self.axis} did not enter closed "
                                        f"loop control")
            time.sleep(0.002)
        self.last, self.latched = None, None
        self.want = DriveState.QUICK_STOP if self.halted else DriveState.ENABLED
        self.guard.reset()

    def _stop_with(self, lines: list[str], want: DriveState) -> None:
        # the read that follows confirms the drive has processed the stop (lines are handled
        # in order); a drive that does not answer is left to its watchdog.  Never raises.
        self.want = want
        saved, self.timeout = self.timeout, min(self.timeout, 0.1)
        try:
            self._exchange(lines + [f"r axis{self.axis}.current_state"], ["i"])
            self.stop_acked = want     # the drive answered after the stop lines: it has them
        except Exception:
            pass
        finally:
            self.timeout = saved

    def quick_stop(self) -> None:
        # velocity 0 brakes to standstill (and feeds the watchdog)
        self._stop_with([f"v {self.axis} 0 0"], DriveState.QUICK_STOP)

    def disable(self) -> None:
        self._stop_with([f"w axis{self.axis}.requested_state {AXIS_IDLE}",
                         f"w axis{self.axis}.config.enable_watchdog 0"], DriveState.DISABLED)

    # --- e-stop: from any thread, whatever the control thread is doing ---------------------------
    def torque_off(self) -> None:
        """Brake now: ``v <axis> 0`` (velocity 0, no reply), written between two of the
        control thread's writes, never waiting for its replies.  Never raises."""
        self.halted = True
        self.want = DriveState.QUICK_STOP
        got = self.write_lock.acquire(timeout=0.05)
        try:
            self.ser.write(self._encode([f"v {self.axis} 0 0"]))
        except Exception:
            pass
        finally:
            if got:
                self.write_lock.release()

    def confirm_off(self, timeout: float) -> DriveState | None:
        """The axis state after ``torque_off``: one exchange (state and error in one write),
        between two of the control thread's.  The line is read in order and every line after
        torque_off's goes out halted, so an axis still in closed loop is braking: quick stop,
        whatever ``want`` a concurrent ``disable`` has set.  None: no answer in time."""
        deadline = time.monotonic() + timeout
        while True:
            if not self.ser.is_open:       # closed by its run meanwhile: the stop it acknowledged
                return self.stop_acked
            if not self.exchange_lock.acquire(timeout=max(0.0, deadline - time.monotonic())):
                return None
            try:
                state, err = self._axis_state(max(deadline - time.monotonic(), 0.01))
            except Exception:
                return None if self.ser.is_open else self.stop_acked
            finally:
                self.exchange_lock.release()
            if err:
                return DriveState.FAULT
            if state != AXIS_CLOSED_LOOP:
                return DriveState.DISABLED
            if self.halted:
                return DriveState.QUICK_STOP
            if time.monotonic() > deadline:
                return DriveState.ENABLED
            self.torque_off()      # called without torque_off first: stop, then read again

    def _axis_state(self, timeout: float | None = None) -> tuple[int, int]:
        a = f"axis{self.axis}"
        (state,), (err,) = self._exchange([f"r {a}.current_state", f"r {a}.error"], ["i", "i"], timeout)
        return state, err

    def status(self) -> DriveStatus:
        state, err = self._axis_state()
        faults = [f"axis error 0x{err:X}"] if err else []
        if self.latched is not None:
            faults.append(f"host stopped the drive: {self.latched}")
        if err:
            return DriveStatus(DriveState.FAULT, faults)
        if state != AXIS_CLOSED_LOOP:
            return DriveStatus(DriveState.DISABLED, faults)
        return DriveStatus(DriveState.QUICK_STOP if self.want == DriveState.QUICK_STOP
                           else DriveState.ENABLED, faults)

    def close(self) -> None:
        if self.ser.is_open:
            self.disable()
            self.ser.close()
