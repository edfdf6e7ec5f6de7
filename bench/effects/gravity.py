"""gravity: uncompensated gravity a sin q + b cos q on a revolute joint (the host's gravity
model is off, or the payload changed)."""
from __future__ import annotations

import math

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number


class Gravity(Effect):
    name = "gravity"
    signals = ("position",)
    summary = "uncompensated a sin q + b cos q"

    def applicable(self, ctx: Context) -> bool:
        return ctx.revolute

    def variants(self, ctx: Context) -> list[dict]:
        return [{"grav_a": 0.0, "grav_b": 0.0}]

    def apply(self, values, extra, ev):
        ev[terms.GRAV_SIN] += values["grav_a"]
        ev[terms.GRAV_COS] += values["grav_b"]

    def evidence(self, values, explained, ctx):
        a, b = values["grav_a"], values["grav_b"]
        amp = math.hypot(a, b)
        return (f"residual follows position like uncompensated gravity, {a:+.3g} sin q {b:+.3g} cos q "
                f"(amplitude {amp:.3g} {ctx.torque_unit}); {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("a", "b", "amplitude", "phase"), self.name)
        if "amplitude" in kw:
            amp, ph = number(kw, "amplitude", self.name), number(kw, "phase", self.name, 0.0)
            a, b = amp * math.cos(ph), amp * math.sin(ph)
        else:
            a, b = number(kw, "a", self.name, 0.0), number(kw, "b", self.name, 0.0)
        ev[terms.GRAV_SIN] += a
        ev[terms.GRAV_COS] += b
        return {}
