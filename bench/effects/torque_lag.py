"""torque_lag: the joint feels the torque later than the record says it was applied (a slow
current loop, a command applied at the next SYNC, a filter in the drive), so eq. 5 leaves
tau(t) - tau(t - lag) ~ lag * dtau/dt in the friction estimate."""
from __future__ import annotations

import numpy as np

from bench.effects.base import (Context, Effect, check_known, column_lag_twin, explained_text, number,
                                signal_adds)
from bench.errors import InputError

MAX_LAG = 0.2      # s: beyond this a "lag" is a different experiment
# Share of what the lag's fitted model leaves without its term that the cube of the torque's
# rate still explains once the term is in (a partial R^2, ``signal_adds``): a lag is linear in
# the torque.  Tuning seeds (measured 2026-11-25): true lags under the recording conditions on
# the linear stage and j1-j4 (1300-1361, torque columns) 0.000-0.027; a saturating torque
# constant the lag was tried on (1100-1102) 0.128-0.32 on the linear stage, j1 and j2 (0.04
# and 0.007 on j4, where the lag was not credited).
CUBIC_ADDS = 0.06
# A torque column sampled rather than held (a logger's record, ``torque_hold: sample``) reads
# each of the drive's held commands at some instant of its control period, and a staircase
# held for a period P moves the joint like the smooth torque P/2 later: 0.5 ms at 1 kHz, 1 ms
# at 500 Hz.  The log cannot say at which rate the drive ran, so a lag within that is not
# named.  Tuning seeds 1972, 1984-1991 (2026-11-27): clean linear-stage PD records logged at
# 8 ms were given a lag of 0.53-0.60 ms in 3 of 9; the library's lags are 2-8 ms.
HELD_LAG = 1e-3


class TorqueLag(Effect):
    name = "torque_lag"
    summary = "the applied torque lags the recorded one"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"torque_lag": 0.0}]

    def fd_step(self, key, ctx):
        return 0.25 * ctx.data.c.dt_grid

    def credible(self, values, ctx):
        """The joint cannot feel a commanded torque before it is applied: a fitted lag must be
        positive where the torque column is what was applied.  A spring along the linear
        stage's travel was taken for a lag of -2.2 to -3.2 ms under one sine (test seeds 5942,
        5943, 5946); the library's lags are 2-7 ms the other way.  In a friction-torque record
        (inertia 0) a sensor's filter can delay the reading instead, so there either sign is
        physics.  A sampled torque column cannot place a lag below a drive's hold
        (``HELD_LAG``)."""
        lag = values["torque_lag"]
        if ctx.inertia > 0 and ctx.meta.get("torque_hold") == "sample" and lag < HELD_LAG:
            return False
        return lag > 0 or ctx.inertia == 0

    def holds(self, values, ctx):
        """A lag is linear in the torque, tau(t) - tau(t - lag) ~ lag dtau/dt: with its term in,
        the cube of the torque's rate must explain nothing more.  A torque constant that
        saturates at high current (tau^3) was taken for a 14 ms lag on the linear stage (fresh
        seed 8706, with LuGre bent: Fc 67 % high).  A friction-torque column's rate is the
        friction's own, nonlinear in the motion: there the check does not apply."""
        if ctx.inertia == 0:
            return True
        c = ctx.data.c
        rate = np.gradient(c.tau, c.t)
        return signal_adds(values["torque_lag"] * rate, rate ** 3, ctx) <= CUBIC_ADDS

    def apply(self, values, extra, ev):
        extra["torque_lag"] += values["torque_lag"]

    def evidence(self, values, explained, ctx):
        lag = values["torque_lag"]
        text = (f"residual follows the rate of change of the torque: the joint feels the torque "
                f"{abs(lag) * 1e3:.3g} ms {'after' if lag > 0 else 'before'} the record says it was "
                f"applied (current loop, command delay); {explained_text(explained)}")
        return text + ("; " + column_lag_twin(lag, values, "lag") if ctx.inertia == 0 else "")

    def inject(self, kw, ev, spec):
        check_known(kw, ("delay",), self.name)
        lag = number(kw, "delay", self.name)
        if not 0 <= lag <= MAX_LAG:
            raise InputError(f"effect torque_lag: delay must be 0 to {MAX_LAG:g} s, got {lag:g}")
        return {"torque_lag": lag}
