"""What backlash and joint flexibility share: a load beyond the gear whose inertia is the
linear part of the term (``extra['load_inertia']``, see ``bench.fitting.predict``)."""
from __future__ import annotations

import math

from bench import terms
from bench.effects.base import Context, Effect, number
from bench.errors import InputError
from bench.fitting import Param


def format_angle(x: float, unit: str) -> str:
    if unit == "rad":
        return f"{1e3 * x:.3g} mrad ({math.degrees(x) * 60:.3g} arcmin)"
    return f"{1e6 * x:.3g} µm" if abs(x) < 1e-3 else f"{1e3 * x:.3g} mm"


class GearEffect(Effect):
    load_key = ""

    def load_param(self, init) -> Param:
        return Param(self.load_key, init[self.load_key], log=False)

    def fd_step(self, key, ctx):
        if key == self.load_key:
            return 1e-2 * ctx.inertia
        return super().fd_step(key, ctx)

    def load_share(self, values, ctx: Context) -> str:
        M_l = values.get("bl_load", 0.0) + values.get("flex_load", 0.0)
        return f"load side {M_l:.3g} of the joint's {ctx.inertia:.3g} inertia ({M_l / ctx.inertia:.0%})"

    def inject_load(self, kw, ev) -> None:
        if "load_fraction" in kw:
            frac = number(kw, "load_fraction", self.name)
            if not 0 < frac < 1:
                raise InputError(f"effect {self.name}: load_fraction must lie in (0, 1)")
            ev[terms.LOAD_FRAC] = frac
