"""gravity: uncompensated gravity a sin q + b cos q on a revolute joint (the host's gravity
model is off, or the payload changed)."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number

# Below this variation over the travel (of its own size) a gravity term is a constant to the
# fit: gravity peaking mid-travel varies by 1 - cos(T/2) ~ T^2/8, 1.1 % over the 0.3 rad of
# j1's robot-joint-log record, where an Fc/4 offset was once named gravity (README known limits)
INTERCHANGEABLE = 0.05


def travel(ctx: Context) -> float:
    q = ctx.data.c.q[ctx.data.mask]
    return float(q.max() - q.min()) if len(q) else 0.0


def offset_or_gravity(ctx: Context, variation: float) -> str:
    """The sentence that says an offset and gravity cannot be told apart over this travel
    (empty when they can)."""
    if variation >= INTERCHANGEABLE:
        return ""
    return (f"; over this record's travel ({travel(ctx):.3g} rad) gravity would vary by only "
            f"{100 * variation:.2g} % of its size, so a constant offset and uncompensated gravity "
            f"cannot be told apart here: record a longer travel (a radian or more) to separate them")


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
        q = ctx.data.c.q[ctx.data.mask]
        g = a * np.sin(q) + b * np.cos(q)
        size = float(np.max(np.abs(g))) if len(g) else 0.0
        variation = float(np.ptp(g)) / size if size > 0 else 1.0
        return (f"residual follows position like uncompensated gravity, {a:+.3g} sin q {b:+.3g} cos q "
                f"(amplitude {amp:.3g} {ctx.torque_unit}); {explained_text(explained)}"
                f"{offset_or_gravity(ctx, variation)}")

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
