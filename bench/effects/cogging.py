"""cogging: an additive torque periodic in position, the same in both directions of motion
(permanent-magnet detent torque, gear-mesh ripple).  The pitch is found from the residual's
periodogram in position; three harmonics are fitted."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import (Context, Effect, check_known, explained_text, number,
                                pitch_grid, position_periodogram, refine_pitch)
from bench.fitting import Param


def scored(ctx: Context, step: int = 4):
    idx = np.nonzero(ctx.data.mask)[0][::step]
    return idx


def format_length(x: float, unit: str) -> str:
    if unit == "m" and abs(x) < 1.0:
        return f"{1000 * x:.3g} mm"
    if unit == "rad":
        return f"{x:.4g} rad ({math.degrees(x):.3g}°)"
    return f"{x:.4g} {unit}"


def best_pitches(ctx: Context, weight: np.ndarray | None, count: int = 2) -> list[float]:
    idx = scored(ctx)
    q, r = ctx.data.c.q[idx], ctx.residual[idx]
    w = None if weight is None else weight[idx]
    grid = pitch_grid(q)
    score = position_periodogram(q, r, grid, w)
    picks: list[float] = []
    for i in np.argsort(score)[::-1]:
        p = float(grid[i])
        if all(abs(1 / p - 1 / o) > 2.0 / np.ptp(q) for o in picks):
            picks.append(refine_pitch(q, r, p, w))
        if len(picks) == count:
            break
    return picks


class Cogging(Effect):
    name = "cogging"
    summary = "additive torque periodic in position"
    hyper = ("cog_pitch",)
    direction_test = True
    harmonics = terms.COG_HARMONICS

    def variants(self, ctx: Context) -> list[dict]:
        out = []
        for p in best_pitches(ctx, None):
            init = {"cog_pitch": p}
            for k in range(1, self.harmonics + 1):
                init[f"cog_s{k}"] = 0.0
                init[f"cog_c{k}"] = 0.0
            out.append(init)
        return out

    def params(self, init):
        return [Param(k, v, log=(k == "cog_pitch")) for k, v in init.items()]

    def apply(self, values, extra, ev):
        ev[terms.COG_PITCH] = values["cog_pitch"]
        for k in range(self.harmonics):
            ev[terms.COG_COEF + 2 * k] += values.get(f"cog_s{k + 1}", 0.0)
            ev[terms.COG_COEF + 2 * k + 1] += values.get(f"cog_c{k + 1}", 0.0)

    def evidence(self, values, explained, ctx):
        p = values["cog_pitch"]
        amp = math.hypot(values.get("cog_s1", 0.0), values.get("cog_c1", 0.0))
        return (f"residual is periodic in position with pitch {format_length(p, ctx.position_unit)}, "
                f"the same in both directions of motion (cogging, amplitude {amp:.3g} {ctx.torque_unit}); "
                f"{explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("amplitude", "pitch", "phase", "h2", "h3"), self.name)
        amp, pitch = number(kw, "amplitude", self.name), number(kw, "pitch", self.name)
        if pitch <= 0:
            from bench.errors import InputError
            raise InputError("effect cogging: pitch must be positive")
        ph = number(kw, "phase", self.name, 0.0)
        ev[terms.COG_PITCH] = pitch
        for k, rel in enumerate((1.0, number(kw, "h2", self.name, 0.0), number(kw, "h3", self.name, 0.0))):
            ev[terms.COG_COEF + 2 * k] += amp * rel * math.cos(ph * (k + 1))
            ev[terms.COG_COEF + 2 * k + 1] += amp * rel * math.sin(ph * (k + 1))
        return {}
