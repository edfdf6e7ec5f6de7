"""An emulated ODrive (firmware 0.5 ASCII protocol) on a pseudo-terminal.

The host opens ``responder.path`` (the pty's slave side, a real tty) with pyserial; this
thread serves the master side.  Supported: ``c <axis> <torque>`` (torque command; feeds the
watchdog; in lock-step it also advances simulated time by one control period),
``v <axis> 0`` (brake to standstill: the quick stop; no clock tick of its own), ``f <axis>`` -> "<pos> <vel>" in turns
and turns/s, ``u <axis>`` (feed the watchdog), ``r``/``w`` of the properties below, ``sc``
(clear errors), GCode checksums ``*<xor>`` both ways (a line with a bad checksum is ignored),
``; comments``.  Units: turns = joint units x ``turns_per_unit``; torque in joint units.
"""
from __future__ import annotations

import os
import select
import threading
import time
import tty

from drivers.protocols import DriveState
from virtual_drives.drive_core import FAULT_WATCHDOG, DriveCore

ERR_MOTOR_FAILED = 0x40
ERR_WATCHDOG = 0x800
ERR_MIN_ENDSTOP, ERR_MAX_ENDSTOP = 0x1000, 0x2000
SERIAL_FAULTS = ("mute", "corrupt_checksum", "late", "glitch", "fault", "garbage")


def checksum(text: str) -> int:
    c = 0
    for b in text.encode("ascii", "replace"):
        c ^= b
    return c


class OdriveResponder:
    def __init__(self, core: DriveCore):
        self.core = core
        self.axis = int(core.joint["axis"])
        self.tpu = float(core.joint["turns_per_unit"])
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)          # no echo, no line editing, no CR/LF translation
        self.path = os.ttyname(self.slave)
        self.faults: dict[str, dict] = {}
        self.watchdog_timeout = float(core.joint["watchdog_s"])
        self.watchdog_enabled = False
        self.control_mode = 1
        self.vel_limit = core.joint["velocity_limit"] * self.tpu
        self.lock = threading.Lock()
        self._late: list[tuple[float, bytes]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"odrive-{core.name}")
        self._thread.start()

    # --- fault injection --------------------------------------------------------------------
    def inject(self, fault: str, **args) -> None:
        if fault not in SERIAL_FAULTS:
            raise ValueError(f"unknown serial fault {fault!r}; known: {', '.join(SERIAL_FAULTS)}")
        if fault == "glitch":
            self.core.glitch = int(args.get("counts", 1 << 16))
            self.core.glitch_samples = int(args.get("samples", 1))
        elif fault == "fault":
            self.core.fault(int(args.get("code", ERR_MOTOR_FAILED)), "injected axis error")
        else:
            args.setdefault("count", -1)     # -1: until cleared
            with self.lock:
                self.faults[fault] = dict(args)

    def clear(self, fault: str) -> None:
        with self.lock:
            self.faults.pop(fault, None)

    def _take(self, fault: str) -> dict | None:
        """The active fault's arguments, using up one of its ``count`` occurrences."""
        f = self.faults.get(fault)
        if f is None:
            return None
        if f["count"] > 0:
            f["count"] -= 1
            if f["count"] == 0:
                del self.faults[fault]
        return f

    # --- properties ----------------------------------------------------------------------------
    def _error(self) -> int:
        core, err = self.core, 0
        if core.state == DriveState.FAULT:
            err |= ERR_WATCHDOG if core.fault_code == FAULT_WATCHDOG else int(core.fault_code)
        if core.internal_limit:
            err |= ERR_MIN_ENDSTOP if core.vj.state.q < core.limits[0] else ERR_MAX_ENDSTOP
        return err

    def _read_prop(self, name: str):
        core, a = self.core, f"axis{self.axis}."
        if name == "vbus_voltage":
            return 24.0
        if not name.startswith(a):
            return None
        p = name[len(a):]
        if p == "error":
            return self._error()
        if p == "current_state":
            return 8 if core.powered else 1
        if p == "config.watchdog_timeout":
            return self.watchdog_timeout
        if p == "config.enable_watchdog":
            return int(self.watchdog_enabled)
        if p == "motor.config.torque_lim":
            return core.max_torque
        if p == "controller.config.vel_limit":
            return self.vel_limit
        if p == "controller.config.control_mode":
            return self.control_mode
        if p == "controller.input_torque":
            return core.command
        if p == "encoder.pos_estimate":
            return core.vj.measured_position() * self.tpu
        if p == "encoder.vel_estimate":
            return core.vj.state.v * self.tpu
        if p == "motor.torque_estimate":       # current x torque constant, with sensor noise
            return core.measured_torque()
        return None

    def _write_prop(self, name: str, value: str) -> bool:
        core, a = self.core, f"axis{self.axis}."
        if not name.startswith(a):
            return False
        p, x = name[len(a):], float(value)
        if p == "requested_state":
            if int(x) == 8 and self._error() == 0 and self.control_mode == 1:
                core.enable()
            elif int(x) == 1:
                core.disable()
        elif p == "error" and x == 0:
            self._clear_errors()
        elif p == "config.watchdog_timeout":
            self.watchdog_timeout = x
            self._arm()
        elif p == "config.enable_watchdog":
            self.watchdog_enabled = bool(int(x))
            self._arm()
        elif p == "motor.config.torque_lim":
            core.max_torque = x
        elif p == "controller.config.vel_limit":
            self.vel_limit = x
        elif p == "controller.config.control_mode":
            self.control_mode = int(x)
        elif p == "controller.input_torque":
            core.set_command(x)
        else:
            return False
        return True

    def _arm(self) -> None:
        self.core.watchdog_s = self.watchdog_timeout if self.watchdog_enabled else 0.0
        self.core.feed()

    def _clear_errors(self) -> None:
        self.core.reset_fault()
        self.core.internal_limit = False
        if self.watchdog_enabled:
            self.core.feed()

    # --- commands ------------------------------------------------------------------------------
    def _tick(self, torque: float) -> None:
        core = self.core
        core.feed()
        with core.lock:
            if core.clock == "lockstep":
                if core.state == DriveState.ENABLED:
                    core.set_command(torque)
                core.step()
            else:
                core.catch_up(time.monotonic(), command=True)
                if core.state == DriveState.ENABLED:
                    core.set_command(torque)
            core.feed()   # the host spoke when the command came; serving it is not its silence

    def handle(self, line: str) -> str | None:
        """One command line (checksum and comment removed) -> reply text or None."""
        parts = line.split()
        if not parts:
            return None
        cmd, args = parts[0], parts[1:]
        try:
            if cmd in ("c", "v", "f", "u") and (not args or int(args[0]) != self.axis):
                return "invalid motor"
            if cmd == "c":
                self._tick(float(args[1]))
            elif cmd == "v":
                if float(args[1]) != 0.0:
                    return "velocity control is not emulated (only 'v <axis> 0' stops)"
                self.core.feed()
                self.core.quick_stop()   # braking goes on with the clock: no tick of its own
            elif cmd == "f":
                _, q, v, _ = self.core.measure()
                return f"{q * self.tpu:.12g} {v * self.tpu:.12g}"
            elif cmd == "u":
                self.core.feed()
            elif cmd == "r":
                value = self._read_prop(args[0])
                return "invalid property" if value is None else \
                    (str(value) if isinstance(value, int) else f"{value:.12g}")
            elif cmd == "w":
                if not self._write_prop(args[0], args[1]):
                    return "invalid property"
            elif cmd == "sc":
                self._clear_errors()
            else:
                return "unknown command"
        except (IndexError, ValueError):
            return "invalid command format"
        return None

    def _reply(self, text: str, with_checksum: bool) -> bytes:
        if self._take("corrupt_checksum"):
            if not with_checksum:
                return b"#\xff?garbled\n"
            return f"{text} *{(checksum(text + ' ') + 1) % 256}\n".encode()
        if with_checksum:
            return f"{text} *{checksum(text + ' ')}\n".encode()
        return f"{text}\n".encode()

    def _serve_line(self, raw: bytes) -> bytes:
        text = raw.decode("ascii", "replace").split(";", 1)[0]
        with_checksum = "*" in text
        if with_checksum:
            body, _, cs = text.rpartition("*")
            try:
                if int(cs.strip()) != checksum(body):
                    return b""           # ODrive ignores a line with a bad checksum
            except ValueError:
                return b""
            text = body
        reply = self.handle(text.strip())
        return b"" if reply is None else self._reply(reply, with_checksum)

    def _run(self) -> None:
        buf = b""
        while not self._stop.is_set():
            timeout = 0.05
            if self._late:
                timeout = max(0.0, min(timeout, self._late[0][0] - time.monotonic()))
            try:
                ready, _, _ = select.select([self.master], [], [], timeout)
            except (OSError, ValueError):
                return
            self._flush_late()
            if not ready:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            if self.faults.get("mute"):
                continue                 # the comm stack hangs; the watchdog starves
            buf += data
            out = b""
            while b"\n" in buf:
                raw, buf = buf.split(b"\n", 1)
                out += self._serve_line(raw.rstrip(b"\r"))
            if out:
                if self._take("garbage"):
                    out = b"\x00\xfe garbage \x13\n" + out
                late = self._take("late")
                if late is not None:
                    self._late.append((time.monotonic() + float(late.get("delay", 1.0)), out))
                else:
                    self._write(out)

    def _flush_late(self) -> None:
        now = time.monotonic()
        while self._late and self._late[0][0] <= now:
            self._write(self._late.pop(0)[1])

    def _write(self, data: bytes) -> None:
        try:
            os.write(self.master, data)
        except OSError:
            pass

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass
