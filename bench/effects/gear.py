"""What backlash and joint flexibility share: a load beyond the gear whose inertia is the
linear part of the term (``extra['load_inertia']``, see ``bench.fitting.predict``)."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, Effect, number
from bench.errors import InputError
from bench.fitting import Param, gear_term


def format_angle(x: float, unit: str) -> str:
    if unit == "rad":
        return f"{1e3 * x:.3g} mrad ({math.degrees(x) * 60:.3g} arcmin)"
    return f"{1e6 * x:.3g} µm" if abs(x) < 1e-3 else f"{1e3 * x:.3g} mm"


def best_gears(ctx: Context, gears: list[tuple[float, float, float]], count: int = 2,
               dampings: tuple[float, ...] = ()) -> list:
    """The ``count`` gears (backlash width, spring frequency, damping) whose term best
    explains the residual with a positive load inertia (a negative one is no load: it only
    mimics some other mismatch).  The residual's signature picks the hyper-parameters, as a
    periodogram picks a pitch: a coarse geometric grid, then a fine one around each pick
    (and, for a spring, the damping among ``dampings``); the screening and the joint fit
    then judge them."""
    m = ctx.data.mask
    r = ctx.residual[m]
    rr = float(r @ r) or 1.0

    def score(g):
        x = gear_term(ctx.data.c, *g)[m]
        xx, xr = float(x @ x), float(x @ r)
        return xr * xr / xx / rr if xx > 0 and xr > 0 else 0.0

    scored = sorted(((score(g), g) for g in gears), key=lambda s: -s[0])
    picks = [g for sc, g in scored if sc > 0][:count]
    if len(gears) < 2:
        return picks
    # the coarse grid's step, as a ratio (width or frequency: whichever the gear varies)
    axis = 0 if gears[0][0] > 0 else 1
    step = gears[1][axis] / gears[0][axis]
    out = []
    for g in picks:
        fine = [tuple(g[i] * (f if i == axis else 1.0) for i in range(3))
                for f in np.geomspace(1 / step, step, 13)]
        best = max(fine, key=score)
        if dampings:
            best = max([best] + [(best[0], best[1], z) for z in dampings], key=score)
        out.append(best)
    return out


def load_side(meta: dict) -> bool:
    return str(meta.get("encoder", "motor")).strip().lower() == "load"


class GearEffect(Effect):
    load_key = ""

    def applicable(self, ctx: Context) -> bool:
        # the term is what eq. 5's M qdd leaves behind: a record of friction torque
        # (inertia 0, nothing subtracted) has no such term; and it runs the load along the
        # *motor's* measured trajectory, so a load-side encoder would get the wrong physics
        # credited (a load-side record is left to the verdict, which says what to record)
        return ctx.inertia > 0 and not load_side(ctx.meta)

    def inapplicable(self, ctx: Context) -> str:
        if load_side(ctx.meta):
            return ("a record whose encoder is on the load (`encoder: load`): the fit runs the gear "
                    "from the motor's position, so record the motor encoder")
        return "a friction-torque record (inertia 0): it has no M qdd term for a load to leave behind"

    def load_param(self, init) -> Param:
        # a load inertia is positive; it starts at zero strength, so it is bounded, not logged
        return Param(self.load_key, max(init[self.load_key], 0.0), log=False, lo=0.0)

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
