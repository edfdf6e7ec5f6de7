"""The bench in motion: every joint cycled once per control period, with safety around it.

Procedures move joints only through a ``Rig``.  Each ``step`` cycles every drive of the bench
(joints not commanded hold their position with a stiff PD plus gravity), checks each joint's
predicted stopping point against its limits *before* sending a torque, logs one trace row,
and on any ``DriveError`` quick-stops and disables every drive before re-raising as
``ProcedureFailed``.  Drives come from a plug factory (``procedures.plugs.open_drive``); the
rig never knows which transport it talks to.
"""
from __future__ import annotations

import math

from drivers.protocols import DriveError, Sample, TorqueDrive
from procedures.config import BenchConfig, declared_inertia, gravity_torque
from procedures.events import Cancel, ProcedureFailed

HOLD_BANDWIDTH = 20.0    # rad/s: stiff enough to lock a joint, slow enough for 1 kHz
BRAKE_FRACTION = 0.6     # share of the torque headroom assumed available for braking


class LimitApproach(ProcedureFailed):
    """A joint would not be able to stop inside its limits; the rig braked it."""


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

    # --- set-up / tear-down ----------------------------------------------------------------
    def start(self) -> None:
        """Read every axis (drives still disabled), then enable them holding where they are."""
        try:
            for jid in self.ids:
                self.samples[jid] = self.drives[jid].cycle(0.0)
            for jid in self.ids:
                self.drives[jid].enable()
                self.hold_at[jid] = self.samples[jid].position
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
        return declared_inertia(self.joints[jid], {i: s.position for i, s in self.samples.items()})

    def gravity(self, jid: str, q: float | None = None) -> float:
        return gravity_torque(self.joints[jid], self.samples[jid].position if q is None else q)

    def brake_decel(self, jid: str) -> float:
        j = self.joints[jid]
        headroom = j["torque_limit"] - math.hypot(*j["gravity"])
        return max(BRAKE_FRACTION * headroom, 1e-9) / self.inertia(jid)

    def stopping_point(self, jid: str, q: float, v: float, extra_periods: int = 3) -> float:
        """Where the joint would come to rest if braking started now (model-free: declared
        inertia and torque headroom only; friction would only help)."""
        d = v * v / (2.0 * self.brake_decel(jid)) + abs(v) * extra_periods * self.dt
        return q + math.copysign(d, v)

    def hold_torque(self, jid: str, target: float | None = None) -> float:
        s = self.samples[jid]
        M = self.inertia(jid)
        w = self.joints[jid].get("hold_bandwidth", HOLD_BANDWIDTH)
        tgt = self.hold_at[jid] if target is None else target
        return self.gravity(jid) + M * w * w * (tgt - s.position) - 2.0 * M * w * s.velocity

    # --- the cycle -------------------------------------------------------------------------
    def step(self, torques: dict[str, float] | None = None) -> dict[str, Sample]:
        """One control period for the whole bench.  Returns the new samples."""
        torques = torques or {}
        if self.k % 64 == 0 and self.cancel.is_set():
            self.brake_all()
            self.cancel.check()
        row = [self.k * self.dt]
        new = {}
        for jid in self.ids:
            j = self.joints[jid]
            s = self.samples[jid]
            lo, hi = j["position_limits"]
            stop = self.stopping_point(jid, s.position, s.velocity)
            if not lo <= stop <= hi:
                self.brake_all()
                raise LimitApproach(f"{jid}: would stop at {stop:.4g}, outside [{lo:.4g}, {hi:.4g}]; braked")
            tau = torques.get(jid)
            if tau is None:
                tau = self.hold_torque(jid)
            lim = j["torque_limit"]
            tau = min(lim, max(-lim, float(tau)))
            try:
                new[jid] = self.drives[jid].cycle(tau)
            except DriveError as e:
                self.emergency_stop()
                raise ProcedureFailed(f"{jid}: drive error: {e}") from None
            row += [s.position, s.velocity, new[jid].torque, tau, self.gravity(jid)]
        if self.trace is not None:
            self.trace.append(row, self.segment)
        self.samples.update(new)
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
                    s = self.samples[jid]
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
            lim = self.joints[jid]["torque_limit"]
            tau = min(lim, max(-lim, torques[jid]))
            n = self.drives[jid].cycle(tau)
            row += [s.position, s.velocity, n.torque, tau, self.gravity(jid)]
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

