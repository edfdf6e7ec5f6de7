"""torque_lag: the joint feels the torque later than the record says it was applied (a slow
current loop, a command applied at the next SYNC, a filter in the drive), so eq. 5 leaves
tau(t) - tau(t - lag) ~ lag * dtau/dt in the friction estimate."""
from __future__ import annotations

from bench.effects.base import Context, Effect, check_known, explained_text, number
from bench.errors import InputError

MAX_LAG = 0.2      # s: beyond this a "lag" is a different experiment


class TorqueLag(Effect):
    name = "torque_lag"
    summary = "the applied torque lags the recorded one"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"torque_lag": 0.0}]

    def fd_step(self, key, ctx):
        return 0.25 * ctx.data.c.dt_grid

    def apply(self, values, extra, ev):
        extra["torque_lag"] += values["torque_lag"]

    def evidence(self, values, explained, ctx):
        lag = values["torque_lag"]
        return (f"residual follows the rate of change of the torque: the joint feels the torque "
                f"{abs(lag) * 1e3:.3g} ms {'after' if lag > 0 else 'before'} the record says it was "
                f"applied (current loop, command delay); {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("delay",), self.name)
        lag = number(kw, "delay", self.name)
        if not 0 <= lag <= MAX_LAG:
            raise InputError(f"effect torque_lag: delay must be 0 to {MAX_LAG:g} s, got {lag:g}")
        return {"torque_lag": lag}
