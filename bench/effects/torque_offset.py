"""torque_offset: a constant torque bias (current-sensor offset, cable pull, unbalanced
spring) present in both directions of motion and at standstill."""
from __future__ import annotations

import math

from bench import terms
from bench.effects.base import (Context, Effect, check_known, explained_text, level_left_along_travel, number,
                               one_level_along_travel)
from bench.effects.gravity import offset_or_gravity, travel


class TorqueOffset(Effect):
    name = "torque_offset"
    summary = "constant torque bias"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"offset": 0.0}]

    def credible(self, values, ctx):
        # a constant is the same over both halves of the travel
        return one_level_along_travel(ctx)

    judged_after = True

    def credible_after(self, values, ctx):
        return level_left_along_travel(ctx, values["offset"])

    def apply(self, values, extra, ev):
        ev[terms.OFFSET] += values["offset"]

    def evidence(self, values, explained, ctx):
        # the gravity term that looks most like a constant here peaks mid-travel
        alike = offset_or_gravity(ctx, 1.0 - math.cos(0.5 * travel(ctx))) if ctx.revolute else ""
        return (f"residual has a constant bias of {values['offset']:+.3g} {ctx.torque_unit} in both "
                f"directions of motion and at standstill; {explained_text(explained)}{alike}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("value",), self.name)
        ev[terms.OFFSET] += number(kw, "value", self.name)
        return {}
