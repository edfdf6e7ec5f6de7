"""backlash: a dead zone of total width ``width`` in the gear between motor and load.  Each
time the torque the load needs changes sign, the teeth part and the motor turns through
the gap before they meet on the other flank (at a reversal of the motion when the load has
friction of its own; at the velocity peaks of a sine when, as here, the gear's friction is
on the motor).

With the encoder on the motor, eq. 5 leaves M_load (qdd_load - qdd_motor) in the friction
estimate: the load's acceleration is what it gets through the gear, so the term is computed
by running the gear (``bench.terms.load_step``, the virtual joint's own) along the measured
motor trajectory.  The load inertia is linear in the term (screened); the width is searched
on a grid and refined by the joint fit."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import Context, check_known, explained_text, number
from bench.effects.gear import GearEffect, best_gears, format_angle
from bench.errors import InputError
from bench.fitting import Param


class Backlash(GearEffect):
    name = "backlash"
    signals = ("travel_since_reversal",)
    summary = "dead zone in the gear between motor and load"
    hyper = ("bl_width",)
    load_key = "bl_load"

    def variants(self, ctx: Context) -> list[dict]:
        # a geared joint's play is a small fraction of its travel: 0.03 % to 3 %
        span = float(np.ptp(ctx.data.c.q_full))
        grid = [(f * span, 0.0, 0.0) for f in np.geomspace(3e-4, 3e-2, 13)]
        return [{"bl_width": w, "bl_load": 0.0} for w, _, _ in best_gears(ctx, grid)]

    def params(self, init):
        return [Param("bl_width", init["bl_width"], log=True), self.load_param(init)]

    def apply(self, values, extra, ev):
        extra["backlash"] = values["bl_width"]
        extra["load_inertia"] += values["bl_load"]

    def evidence(self, values, explained, ctx):
        w = values["bl_width"]
        return (f"backlash of {format_angle(w, ctx.position_unit)}: each time the gear's torque "
                f"reverses the motor turns {format_angle(w, ctx.position_unit)} before the load "
                f"follows ({self.load_share(values, ctx)}); check the gear's play and preload; "
                f"{explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("width", "load_fraction"), self.name)
        w = number(kw, "width", self.name)
        if not w > 0:
            raise InputError("effect backlash: width must be positive")
        ev[terms.BACKLASH] = w
        self.inject_load(kw, ev)
        return {}
