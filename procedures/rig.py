"""The bench in motion: every joint cycled once per control period, with safety around it.

Procedures move joints only through a ``Rig``.  Each ``step`` cycles the drives of the bench
(joints not commanded hold their position with a stiff PD plus gravity), checks each joint's
predicted stopping point against its limits *before* sending a torque, logs one trace row,
and on any ``DriveError`` quick-stops and disables every drive before re-raising as
``ProcedureFailed``.  Drives come from a plug factory (``procedures.plugs.open_drive``); the
rig never knows which transport it talks to.

Order and rate.  Commanded joints are cycled first in a round, so on a shared CAN bus the
commanded torque goes out before the round's SYNC and applies in the same period (a drive
that joins a round after its SYNC gets its torque applied one period later).  On a lock-step
clock a joint that is only held and already at rest (speed under 0.1 % of its limit) is
cycled once per ``idle_period`` (bench config) instead of every period: its drive keeps the
last torque in between (CiA 402 latched target torque, ODrive input torque), its watchdog is
fed well inside its timeout (and at least every ``IDLE_WALL_S`` of wall time), and it is
cycled every period again as soon as it is commanded or seen moving.  The trace row then
repeats its last sample.  Lock-step time costs host work per round, so this is where the
emulated bench gains most; on a real-time clock every joint is cycled every period.
"""
from __future__ import annotations

import bisect
import math
import time

from drivers.protocols import DriveError, Sample, TorqueDrive
from procedures.config import BenchConfig
from procedures.events import Cancel, ProcedureFailed

HOLD_BANDWIDTH = 20.0    # rad/s: stiff enough to lock a joint, slow enough for 1 kHz
BRAKE_FRACTION = 0.6     # share of the torque headroom assumed available for braking
REST_FRACTION = 1e-3     # "at rest": speed under this share of the velocity limit
IDLE_WALL_S = 0.05       # a resting joint is cycled at least this often in wall time


class LimitApproach(ProcedureFailed):
    """A joint would not be able to stop inside its limits; the rig braked it."""


class _Axis:
    """Per-joint constants of the hot path (read once from the joint dict)."""

    __slots__ = ("id", "lo", "hi", "tlim", "ga", "gb", "vrest", "w", "headroom", "hold", "m", "mkey", "mq", "mv")

    def __init__(self, j: dict):
        self.id = j["id"]
        self.lo, self.hi = j["position_limits"]
        self.tlim = float(j["torque_limit"])
        self.ga, self.gb = (float(x) for x in j["gravity"])
        self.vrest = REST_FRACTION * float(j["velocity_limit"])
        self.hold = float(j.get("hold", 0.5 * (self.lo + self.hi)))
        self.w = float(j.get("hold_bandwidth", HOLD_BANDWIDTH))
        self.headroom = max(BRAKE_FRACTION * (self.tlim - math.hypot(self.ga, self.gb)), 1e-9)
        m = j["inertia"]
        self.m = None if isinstance(m, dict) else float(m)
        if self.m is None:
            self.mkey = m.get("joint") or j["id"]
            self.mq, self.mv = list(m["q"]), list(m["value"])

    def inertia(self, samples: dict, hold: float) -> float:
        if self.m is not None:
            return self.m
        s = samples.get(self.mkey)
        x = s.position if s is not None else (hold if self.mkey == self.id else 0.0)
        q, v = self.mq, self.mv        # np.interp semantics: clamp outside the table
        if x <= q[0]:
            return v[0]
        if x >= q[-1]:
            return v[-1]
        i = bisect.bisect_right(q, x)
        return v[i - 1] + (v[i] - v[i - 1]) * (x - q[i - 1]) / (q[i] - q[i - 1])

    def gravity(self, q: float) -> float:
        return self.ga * math.sin(q) + self.gb * math.cos(q) if (self.ga or self.gb) else 0.0


class Rig:
    def __init__(self, cfg: BenchConfig, drives: dict[str, TorqueDrive], cancel: Cancel | None = None,
                 trace=None):
        self.cfg = cfg
        self.dt = cfg.control_period
        self.joints = {j["id"]: j for j in cfg.joints}
        self.ids = [j["id"] for j in cfg.joints]
        self.drives = drives
        self.cancel = cancel or Cancel()
        self.trace = trace
        self.k = 0
        self.samples: dict[str, Sample] = {}
        self.hold_at: dict[str, float] = {}
        self.segment = ""
        self._ax = {jid: _Axis(j) for jid, j in self.joints.items()}
        idle = getattr(cfg, "idle_period", None)
        self.idle_every = (max(1, int(round(idle / self.dt)))
                           if idle and getattr(cfg, "clock", "lockstep") == "lockstep" else 1)
        self._last_cycle: dict[str, int] = {}        # round of each joint's last cycle
        self._last_wall: dict[str, float] = {}       # wall time of it
        self._last_cmd: dict[str, float] = {}        # torque sent then (in force since)
        self.skipped = 0                             # joint-cycles left out (resting, held)

    # --- set-up / tear-down ----------------------------------------------------------------
    def start(self) -> None:
        """Read every axis (drives still disabled), then enable them holding where they are."""
        try:
            for jid in self.ids:
                self.samples[jid] = self.drives[jid].cycle(0.0)
            for jid in self.ids:
                self.drives[jid].enable()
                self.hold_at[jid] = self.samples[jid].position
            self._last_cycle.clear()   # freshly enabled at torque 0: every joint gets its hold torque next round
        except DriveError as e:
            self.emergency_stop()
            raise ProcedureFailed(f"could not enable the drives: {e}") from None

    def emergency_stop(self) -> None:
        for d in self.drives.values():
            try:
                d.quick_stop()
            except Exception:  # quick_stop must never raise; be sure anyway
                pass
        for d in self.drives.values():
            try:
                d.disable()
            except Exception:
                pass

    def park(self) -> None:
        """Normal end: bring moving joints to rest, then disable everything."""
        try:
            self.settle()
        except Exception:
            self.emergency_stop()
            raise
        for d in self.drives.values():
            d.disable()

    # --- physics helpers -------------------------------------------------------------------
    def inertia(self, jid: str) -> float:
        ax = self._ax[jid]
        return ax.inertia(self.samples, ax.hold)

    def gravity(self, jid: str, q: float | None = None) -> float:
        return self._ax[jid].gravity(self.samples[jid].position if q is None else q)

    def brake_decel(self, jid: str) -> float:
        return self._ax[jid].headroom / self.inertia(jid)

    def stopping_point(self, jid: str, q: float, v: float, extra_periods: int = 3) -> float:
        """Where the joint would come to rest if braking started now (model-free: declared
        inertia and torque headroom only; friction would only help)."""
        d = v * v / (2.0 * self.brake_decel(jid)) + abs(v) * extra_periods * self.dt
        return q + math.copysign(d, v)

    def hold_torque(self, jid: str, target: float | None = None) -> float:
        s = self.samples[jid]
        ax = self._ax[jid]
        M = ax.inertia(self.samples, ax.hold)
        w = ax.w
        tgt = self.hold_at[jid] if target is None else target
        return ax.gravity(s.position) + M * w * w * (tgt - s.position) - 2.0 * M * w * s.velocity

    # --- the cycle -------------------------------------------------------------------------
    def _cycle(self, jid: str, tau: float) -> Sample:
        n = self.drives[jid].cycle(tau)
        self._last_cycle[jid] = self.k
        self._last_cmd[jid] = tau
        if self.idle_every > 1:
            self._last_wall[jid] = time.monotonic()
        return n

    def _resting(self, jid: str, now: float) -> bool:
        """Held, at rest and cycled recently enough to be left out of this round."""
        last = self._last_cycle.get(jid)
        return (last is not None and self.k - last < self.idle_every
                and abs(self.samples[jid].velocity) <= self._ax[jid].vrest
                and now - self._last_wall.get(jid, now) < IDLE_WALL_S)

    def step(self, torques: dict[str, float] | None = None) -> dict[str, Sample]:
        """One control period for the whole bench.  Returns the new samples of the joints
        cycled this round (every commanded joint is)."""
        torques = torques or {}
        if self.k % 64 == 0 and self.cancel.is_set():
            self.brake_all()
            self.cancel.check()
        samples = self.samples
        # commanded joints first: on a shared CAN bus their torque precedes the round's SYNC
        order = self.ids if not torques else (
            [j for j in self.ids if j in torques] + [j for j in self.ids if j not in torques])
        now = time.monotonic() if self.idle_every > 1 else 0.0
        new = {}
        cols = {}
        for jid in order:
            ax = self._ax[jid]
            s = samples[jid]
            q, v = s.position, s.velocity
            if v != 0.0:
                M = ax.inertia(samples, ax.hold)
                d = v * v * M / (2.0 * ax.headroom) + abs(v) * 3 * self.dt
                stop = q + math.copysign(d, v)
                if not ax.lo <= stop <= ax.hi:
                    self.brake_all()
                    raise LimitApproach(f"{jid}: would stop at {stop:.4g}, outside [{ax.lo:.4g}, {ax.hi:.4g}]; braked")
            elif not ax.lo <= q <= ax.hi:
                self.brake_all()
                raise LimitApproach(f"{jid}: at {q:.4g}, outside [{ax.lo:.4g}, {ax.hi:.4g}]; braked")
            tau = torques.get(jid)
            if tau is None:
                if self.idle_every > 1 and self._resting(jid, now):
                    self.skipped += 1
                    cols[jid] = (q, v, s.torque, self._last_cmd.get(jid, 0.0), ax.gravity(q))
                    continue
                tau = self.hold_torque(jid)
            lim = ax.tlim
            tau = min(lim, max(-lim, float(tau)))
            try:
                new[jid] = self._cycle(jid, tau)
            except DriveError as e:
                self.emergency_stop()
                raise ProcedureFailed(f"{jid}: drive error: {e}") from None
            cols[jid] = (q, v, new[jid].torque, tau, ax.gravity(q))
        if self.trace is not None:
            row = [self.k * self.dt]
            for jid in self.ids:
                row.extend(cols[jid])
            self.trace.append(row, self.segment)
        samples.update(new)
        self.k += 1
        return new

    def trace_columns(self) -> list[str]:
        cols = ["t"]
        for jid in self.ids:
            cols += [f"q_{jid}", f"v_{jid}", f"tau_{jid}", f"cmd_{jid}", f"g_{jid}"]
        return cols

    # --- composite motions -----------------------------------------------------------------
    def settle(self, max_s: float = 10.0) -> None:
        """Hold every joint where it is until all are at rest."""
        self.hold_here()
        quiet = 0
        for _ in range(int(max_s / self.dt)):
            self.step()
            moving = any(abs(s.velocity) > 1e-3 * self.joints[j]["velocity_limit"]
                         for j, s in self.samples.items())
            quiet = 0 if moving else quiet + 1
            if quiet >= 20:
                return

    def hold_here(self) -> None:
        for jid, s in self.samples.items():
            self.hold_at[jid] = self.stopping_point(jid, s.position, s.velocity, 0)

    def brake_all(self) -> None:
        """Controlled stop of every joint (hold at its stopping point); drive errors during the
        stop escalate to an emergency stop."""
        self.hold_here()
        saved, self.cancel = self.cancel, Cancel()  # no cancel check while braking
        try:
            for _ in range(int(2.0 / self.dt)):
                torques = {jid: self.hold_torque(jid) for jid in self.ids}
                for jid in self.ids:
                    lo, hi = self.joints[jid]["position_limits"]
                    self.hold_at[jid] = min(hi, max(lo, self.hold_at[jid]))
                    torques[jid] = self.hold_torque(jid)
                try:
                    self._raw_step(torques)
                except DriveError:
                    self.emergency_stop()
                    return
                if all(abs(s.velocity) < 1e-3 * self.joints[j]["velocity_limit"] for j, s in self.samples.items()):
                    return
        finally:
            self.cancel = saved

    def _raw_step(self, torques: dict[str, float]) -> None:
        row = [self.k * self.dt]
        for jid in self.ids:
            s = self.samples[jid]
            ax = self._ax[jid]
            tau = min(ax.tlim, max(-ax.tlim, torques[jid]))
            n = self._cycle(jid, tau)
            row += [s.position, s.velocity, n.torque, tau, ax.gravity(s.position)]
            self.samples[jid] = n
        if self.trace is not None:
            self.trace.append(row, self.segment or "brake")
        self.k += 1

    def move_to(self, jid: str, target: float, speed_fraction: float = 0.3) -> None:
        """Minimum-jerk move of one joint (others hold) under PD + gravity."""
        j = self.joints[jid]
        lo, hi = j["position_limits"]
        if not lo < target < hi:
            raise ProcedureFailed(f"{jid}: move target {target} outside limits [{lo}, {hi}]")
        q0 = self.samples[jid].position
        dist = target - q0
        if abs(dist) < 1e-9:
            return
        T = max(1.875 * abs(dist) / (speed_fraction * j["velocity_limit"]), 0.2)
        n = int(math.ceil(T / self.dt))
        for i in range(1, n + 1):
            x = i / n
            self.hold_at[jid] = q0 + dist * (10 * x**3 - 15 * x**4 + 6 * x**5)
            self.step({jid: self.hold_torque(jid)})
        self.hold_at[jid] = target
        self.settle(2.0)
        self.hold_at[jid] = target

