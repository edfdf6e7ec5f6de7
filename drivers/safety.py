"""Host-side interlocks shared by every real transport: a torque command is checked before
it is sent, a sample is checked before it is returned.  The drive has its own limits too
(max torque, software position limits, watchdog); these are the host's second line."""
from __future__ import annotations

import math

from drivers.protocols import LimitViolation, ProtocolViolation, Sample

STALE_SAMPLES = 3      # identical drive time stamps in a row before the status counts as frozen


class SampleGuard:
    def __init__(self, j: dict):
        self.name = j["id"]
        self.lo, self.hi = j["position_limits"]
        self.vlim = float(j["velocity_limit"])
        self.tlim = float(j["torque_limit"])
        self.res = 1.0 / float(j["counts_per_unit"])
        self.dt = float(j["control_period"])
        self.stale = 0

    def reset(self) -> None:
        self.stale = 0

    def command(self, torque: float) -> float:
        torque = float(torque)
        if not math.isfinite(torque) or abs(torque) > self.tlim:
            raise LimitViolation(f"{self.name}: torque command {torque:g} outside the limit "
                                 f"+-{self.tlim:g}; drive stopped")
        return torque

    def fresh(self, t: float, prev: Sample | None) -> None:
        """The drive's time stamp must advance: a status image that repeats is frozen."""
        if prev is not None and t <= prev.t:
            self.stale += 1
            if self.stale >= STALE_SAMPLES:
                raise ProtocolViolation(f"{self.name}: drive status frozen: time stamp stuck at "
                                        f"{t:.6f} s for {self.stale} samples")
        else:
            self.stale = 0

    def plausible(self, s: Sample, prev: Sample | None) -> None:
        """An encoder cannot jump further than the fastest allowed motion plus a few counts."""
        if prev is None:
            return
        span = s.t - prev.t if s.t > prev.t else self.dt
        vmax = max(self.vlim, abs(s.velocity), abs(prev.velocity))
        step = abs(s.position - prev.position)
        if step > 2.0 * vmax * span + 4.0 * self.res:
            raise ProtocolViolation(f"{self.name}: implausible encoder step {step:.6g} in "
                                    f"{span * 1e3:.3g} ms (max {vmax:g}/s): encoder glitch")

    def limits(self, s: Sample) -> None:
        if not self.lo <= s.position <= self.hi:
            raise LimitViolation(f"{self.name}: position {s.position:.6g} outside the "
                                 f"software limits [{self.lo:g}, {self.hi:g}]; drive stopped")
        if abs(s.velocity) > self.vlim:
            raise LimitViolation(f"{self.name}: velocity {s.velocity:.6g} beyond the limit "
                                 f"+-{self.vlim:g}; drive stopped")
