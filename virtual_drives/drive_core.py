"""The inside of one emulated drive, independent of its protocol: the joint's physics
(``VirtualJoint``, never re-implemented here), the power stage, drive-side safety and the
clock.  ``canopen_slave`` and ``odrive_responder`` are thin protocol adapters around it.

Clocks
  lockstep  ``step()`` advances simulated time by exactly one control period, once per SYNC
            or per serial torque command.
  realtime  ``catch_up(now)`` advances the physics to the wall clock in whole periods with
            the torque held since the last command; a command arriving more than half a
            period late counts as an overrun.  A background ``Ticker`` keeps the physics and
            the watchdogs going when the host is silent.

Drive-side safety (each also reachable through the protocol's own objects/properties)
  max torque       commands are clamped to +-max_torque
  position limits  leaving [lo, hi] while enabled -> quick stop, ``internal_limit`` set
  watchdog         no host sign of life for ``watchdog_s`` -> fault, torque off
  quick stop       brakes with at most max_torque to standstill, then power off
  brake            a holding brake locks the joint whenever the power stage is off
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import replace


from drivers.protocols import DriveState
from virtual_drives.joint import VirtualJoint
from virtual_drives.truth import joint_truth

FAULT_WATCHDOG = "watchdog"
PLL_GAIN = 0.1          # share of a command's phase error the drive's grid absorbs per command


class DriveCore:
    def __init__(self, joint: dict, clock: str = "lockstep", seed: int = 0):
        self.joint = joint
        self.name = joint["id"]
        self.clock = clock
        self.dt = float(joint["control_period"])
        # the preset (with the joint's gravity) or the joint's own physics table is the
        # physical truth; the joint's declared inertia is only the drive's own model
        truth = joint_truth(joint)
        self.vj = VirtualJoint(truth.spec, dt=self.dt, seed=seed, extra=truth.extra,
                               q0=joint.get("q0", joint["hold"]))
        # torque_lag: the current loop delays what the joint feels; the drive still reports
        # its current reference (the command), so the lag stays hidden in the record
        self.lag = truth.torque_lag
        k = int(math.floor(self.lag / self.dt))
        self._lag_k, self._lag_frac = k, self.lag / self.dt - k
        self._line = [0.0] * (k + 2)
        self.vj.advance(0.0, periods=0)   # load the compiled kernel now, not on the first SYNC
        self.lock = threading.RLock()
        self.state = DriveState.DISABLED
        self.max_torque = float(joint["torque_limit"])
        self.limits = tuple(joint["position_limits"])
        self.limits_enabled = True
        self.brake = bool(joint["brake"])
        self.command = 0.0            # latched torque command
        self.applied = 0.0            # torque applied over the last period
        self.internal_limit = False
        self.fault_code = 0
        self.fault_text = ""
        self.watchdog_s = 0.0         # 0: not armed
        self.last_alive = None        # host's last sign of life (monotonic)
        self.watchdog_gap = 0.0       # silence that tripped the watchdog
        self.steps = 0
        self.overruns = 0
        self.wall_ref = None          # realtime: wall time matching the physics time
        self.glitch = 0               # encoder counts added to the next reported positions
        self.glitch_samples = 0
        self.on_fault = []            # callbacks(code, text)
        self.on_state = []            # callbacks(old, new)
        self._qs_left = 0

    # --- power stage --------------------------------------------------------------------
    def _set_state(self, new: DriveState) -> None:
        old, self.state = self.state, new
        if old != new:
            for cb in self.on_state:
                cb(old, new)

    def enable(self) -> bool:
        with self.lock:
            if self.state == DriveState.FAULT:
                return False
            self.command = 0.0
            self.internal_limit = False
            self._set_state(DriveState.ENABLED)
            return True

    def disable(self) -> None:
        with self.lock:
            if self.state != DriveState.FAULT:
                self.command = 0.0
                self._set_state(DriveState.DISABLED)

    def quick_stop(self) -> None:
        with self.lock:
            if self.state == DriveState.ENABLED:
                self._qs_left = max(1, int(round(2.0 / self.dt)))  # give up braking after 2 s
                self._set_state(DriveState.QUICK_STOP)

    def fault(self, code: int, text: str) -> None:
        with self.lock:
            if self.state == DriveState.FAULT:
                return
            self.fault_code, self.fault_text = code, text
            self.command = 0.0
            self._set_state(DriveState.FAULT)
        for cb in self.on_fault:
            cb(code, text)

    def reset_fault(self) -> None:
        with self.lock:
            if self.state == DriveState.FAULT:
                self.fault_code, self.fault_text = 0, ""
                self.last_alive = None  # re-arm on the next sign of life
                self._set_state(DriveState.DISABLED)

    def set_command(self, torque: float) -> None:
        with self.lock:
            self.command = min(max(float(torque), -self.max_torque), self.max_torque)

    @property
    def powered(self) -> bool:
        return self.state in (DriveState.ENABLED, DriveState.QUICK_STOP)

    # --- watchdog -------------------------------------------------------------------------
    def feed(self, now: float | None = None) -> None:
        self.last_alive = time.monotonic() if now is None else now

    def check_watchdog(self) -> None:
        # under the lock, timed once it is held: a command being served (its step compiling a
        # kernel on a loaded host) is the drive's own stall, not the host's silence (a fresh
        # clone's suite, 2026-11-29: a serial drive tripped on its first torque command)
        with self.lock:
            now = time.monotonic()
            if self.watchdog_s > 0 and self.last_alive is not None \
                    and now - self.last_alive > self.watchdog_s:
                self.watchdog_gap = now - self.last_alive
                self.last_alive = None
                self.fault(FAULT_WATCHDOG, f"host silent for more than {self.watchdog_s:g} s")

    # --- clock ------------------------------------------------------------------------------
    def step(self, periods: int = 1) -> None:
        """Advance the physics by whole control periods (lock-step, or realtime catch-up)."""
        with self.lock:
            for _ in range(periods):
                self._one_period()

    def catch_up(self, now: float, command: bool) -> None:
        """Realtime: advance to wall time ``now``.  ``command`` marks a host command (SYNC or
        torque line), which is due one period after the previous one."""
        with self.lock:
            if self.wall_ref is None:
                self.wall_ref = now
                return
            n = int(math.floor((now - self.wall_ref) / self.dt + (0.5 if command else 0.0)))
            if command and n > 1:
                self.overruns += n - 1
            if n > 0:
                self.step(n)
                self.wall_ref += n * self.dt
            if command:
                # lock the drive's period grid onto the host's commands, as a CiA 402 drive
                # locks its cycle onto SYNC: otherwise a grid anchored at one early or late
                # command puts every later one near a rounding edge, where jitter alone
                # reads as a missed period
                self.wall_ref += PLL_GAIN * (now - self.wall_ref)

    def _torque(self) -> float:
        if self.state == DriveState.ENABLED:
            return self.command
        if self.state == DriveState.QUICK_STOP:
            # brake to standstill with the drive's own velocity loop (it knows the inertia,
            # not the friction): dead-beat, limited to max torque
            tau = -self.joint["drive_inertia"] * self.vj.state.v / self.dt
            return min(max(tau, -self.max_torque), self.max_torque)
        return 0.0

    def _felt(self, tau: float) -> float:
        """The torque the joint feels over this period: the command ``lag`` late, averaged
        over the period (held commands, delayed).  Power off cuts the current at once."""
        line = self._line
        if not self.powered:
            line[:] = [0.0] * len(line)
            return tau
        line.pop(0)
        line.append(tau)
        k = self._lag_k
        return (1.0 - self._lag_frac) * line[-1 - k] + self._lag_frac * line[-2 - k]

    def _one_period(self) -> None:
        tau = self._torque()
        brake = self.brake and not self.powered
        if brake:
            s = self.vj.state
            self.vj.state = replace(s, t=s.t + self.dt, v=0.0, v_load=0.0)
            self.vj.applied_torque = 0.0
        elif self.lag > 0:
            self.vj.advance(self._felt(tau))
            self.vj.applied_torque = tau
        else:
            self.vj.advance(tau)
        self.applied = tau
        self.steps += 1
        q, v = self.vj.state.q, self.vj.state.v
        if self.state == DriveState.ENABLED and self.limits_enabled \
                and not self.limits[0] <= q <= self.limits[1]:
            self.internal_limit = True
            self.quick_stop()
        elif self.state == DriveState.QUICK_STOP:
            self._qs_left -= 1
            standstill = abs(v) <= max(1e-4 * self.joint["velocity_limit"],
                                       2.0 / (self.joint["counts_per_unit"] * self.dt))
            if standstill or self._qs_left <= 0:
                self._set_state(DriveState.DISABLED)

    # --- measurements -------------------------------------------------------------------------
    def measure(self) -> tuple[float, float, float, float]:
        """(t, position, velocity, torque) as the drive's sensors see them."""
        with self.lock:
            q = self.vj.measured_position()
            if self.glitch_samples > 0:
                self.glitch_samples -= 1
                q += self.glitch / self.joint["counts_per_unit"]
            tau = self.vj.measured_torque() if self.powered else 0.0
            return self.vj.state.t, q, self.vj.measured_velocity(), tau

    def measured_torque(self) -> float:
        """The torque sensor alone (the drive's current reference plus noise; 0 unpowered)."""
        with self.lock:
            return self.vj.measured_torque() if self.powered else 0.0

    def snapshot(self) -> dict:
        with self.lock:
            s = self.vj.state
            return {"id": self.name, "state": self.state.value, "powered": self.powered,
                    "command": self.command, "applied_torque": self.applied if self.powered
                    else 0.0, "t": s.t, "q": s.q, "v": s.v, "steps": self.steps,
                    "overruns": self.overruns, "fault_code": self.fault_code,
                    "fault_text": self.fault_text, "internal_limit": self.internal_limit,
                    "watchdog_gap": self.watchdog_gap}


class Ticker:
    """Background thread of an emulator process: watchdogs (wall clock) and, in realtime,
    physics catch-up while the host sends nothing.  Period ~2 ms, cheap."""

    def __init__(self, period: float = 0.002):
        self.period = period
        self.cores: list[DriveCore] = []
        self.extra_checks = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="drive-ticker", daemon=True)

    def start(self) -> "Ticker":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            now = time.monotonic()
            for core in list(self.cores):
                core.check_watchdog()
                if core.clock == "realtime" and core.wall_ref is not None \
                        and now - core.wall_ref > 3 * core.dt:
                    core.catch_up(now, command=False)
            for check in list(self.extra_checks):
                check(now)
