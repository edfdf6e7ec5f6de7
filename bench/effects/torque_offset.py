"""torque_offset: a constant torque bias (current-sensor offset, cable pull, unbalanced
spring) present in both directions of motion and at standstill."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number


# The two halves' means differ by at most this share of the larger: injected offsets on the
# six joints (tuning seeds 1600-1601) 0.006-0.05; a spring towards a point off the centre of
# the travel on the linear stage (outside physics, tuning seeds 1001-1003) 0.36-0.42.
HALVES_AGREE = 0.2


class TorqueOffset(Effect):
    name = "torque_offset"
    summary = "constant torque bias"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"offset": 0.0}]

    def credible(self, values, ctx):
        # a constant is the same over both halves of the travel: the residual it is fitted to
        # must have nearly one mean on each (a spring or a cable pulling towards one end has
        # opposite ones, and an offset would absorb only their average)
        m = ctx.data.mask
        r, q = ctx.residual[m], ctx.data.c.q[m]
        lower = q < np.median(q)
        lo, hi = float(np.mean(r[lower])), float(np.mean(r[~lower]))
        return abs(lo - hi) <= HALVES_AGREE * max(abs(lo), abs(hi))

    def apply(self, values, extra, ev):
        ev[terms.OFFSET] += values["offset"]

    def evidence(self, values, explained, ctx):
        return (f"residual has a constant bias of {values['offset']:+.3g} {ctx.torque_unit} in both "
                f"directions of motion and at standstill; {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("value",), self.name)
        ev[terms.OFFSET] += number(kw, "value", self.name)
        return {}
