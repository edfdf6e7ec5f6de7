"""direction_asymmetry: Coulomb and stiction levels differ for positive and negative
velocity (seal preload, gear-mesh asymmetry): s(v) is scaled by 1 + a sgn(v)."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import (Context, Effect, check_known, explained_text, level_left_along_travel, number,
                               one_level_along_travel)
from bench.errors import InputError


def _sliding(ctx: Context) -> np.ndarray:
    v = np.abs(ctx.data.c.v)
    return v > 0.3 * np.percentile(v[ctx.data.mask], 99)


class DirectionAsymmetry(Effect):
    name = "direction_asymmetry"
    signals = ("direction",)
    summary = "friction levels differ by direction"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"asym": 0.0}]

    def fd_step(self, key, ctx):
        return 1e-3

    def credible(self, values, ctx):
        """s(v) (1 + a sgn v) is Fc (1 + a) one way and -Fc (1 - a) the other: the symmetric fit
        leaves a Fc while sliding in either direction, the same all along the travel.  A spring
        along the linear stage's travel was taken for a 1 % asymmetry (tuning seeds 1002-1032)."""
        return one_level_along_travel(ctx, _sliding(ctx))

    judged_after = True

    def credible_after(self, values, ctx):
        return level_left_along_travel(ctx, values["asym"] * values["Fc"], _sliding(ctx))

    def apply(self, values, extra, ev):
        ev[terms.ASYM] += values["asym"]

    def evidence(self, values, explained, ctx):
        a = values["asym"]
        Fc = ctx.values["Fc"]
        return (f"friction levels depend on the direction of motion: Coulomb level "
                f"{Fc * (1 + a):.4g} for positive and {Fc * (1 - a):.4g} {ctx.torque_unit} for negative "
                f"velocity ({abs(2 * a / (1 - abs(a))):.0%} apart); {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("ratio",), self.name)
        a = number(kw, "ratio", self.name)
        if not -0.9 < a < 0.9:
            raise InputError("effect direction_asymmetry: ratio must lie in (-0.9, 0.9)")
        ev[terms.ASYM] += a
        return {}
