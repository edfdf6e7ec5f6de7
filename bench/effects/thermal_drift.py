"""thermal_drift: friction levels drift monotonically over the record as the joint warms up
(lubricant viscosity falls): s(v) and sigma2 are scaled by 1 + g (1 - exp(-t / tau))."""
from __future__ import annotations

import math

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number
from bench.errors import InputError
from bench.fitting import Param


class ThermalDrift(Effect):
    name = "thermal_drift"
    signals = ("time",)
    summary = "friction drifting over the record"
    hyper = ("th_tau",)

    def variants(self, ctx: Context) -> list[dict]:
        T = float(ctx.data.c.t[-1] - ctx.data.c.t[0])
        return [{"th_tau": f * T, "th_gain": 0.0} for f in (0.1, 0.3, 1.0, 3.0)]

    def params(self, init):
        return [Param("th_tau", init["th_tau"], log=True), Param("th_gain", init["th_gain"], log=False, lo=-0.9)]

    def fd_step(self, key, ctx):
        return 1e-3

    def apply(self, values, extra, ev):
        ev[terms.THERM_GAIN] = values["th_gain"]
        ev[terms.THERM_TAU] = values["th_tau"]

    def evidence(self, values, explained, ctx):
        T = float(ctx.data.c.t[-1] - ctx.data.c.t[0])
        drift = values["th_gain"] * (1.0 - math.exp(-T / values["th_tau"]))
        return (f"friction level drifts by {drift:+.0%} over the {T:.3g} s record (time constant "
                f"{values['th_tau']:.3g} s), as a joint warming up does; {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("gain", "tau"), self.name)
        gain, tau = number(kw, "gain", self.name), number(kw, "tau", self.name)
        if tau <= 0 or gain <= -0.9:
            raise InputError("effect thermal_drift: tau must be positive and gain > -0.9")
        ev[terms.THERM_GAIN] = gain
        ev[terms.THERM_TAU] = tau
        return {}
