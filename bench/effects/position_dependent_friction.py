"""position_dependent_friction: the friction level varies periodically with position
(eccentric bearing, uneven preload along a screw): s(v) is scaled by a Fourier series in q,
so the torque changes sign with the direction of motion, unlike cogging."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number
from bench.effects.cogging import best_pitches, format_length
from bench.fitting import Param


class PositionDependentFriction(Effect):
    name = "position_dependent_friction"
    summary = "friction level periodic in position"
    hyper = ("pf_pitch",)
    direction_test = True
    harmonics = terms.PF_HARMONICS

    def variants(self, ctx: Context) -> list[dict]:
        # the term is (level - 1) times the friction: weight the periodogram basis with the
        # model's friction without its viscous part, ~ sgn(v) s(v)
        weight = ctx.model - ctx.values["sigma2"] * ctx.data.c.v
        out = []
        for p in best_pitches(ctx, weight):
            init = {"pf_pitch": p}
            for k in range(1, self.harmonics + 1):
                init[f"pf_s{k}"] = 0.0
                init[f"pf_c{k}"] = 0.0
            out.append(init)
        return out

    def params(self, init):
        return [Param(k, v, log=(k == "pf_pitch")) for k, v in init.items()]

    def fd_step(self, key, ctx):
        return 1e-3

    def apply(self, values, extra, ev):
        ev[terms.PF_PITCH] = values["pf_pitch"]
        for k in range(self.harmonics):
            ev[terms.PF_COEF + 2 * k] += values.get(f"pf_s{k + 1}", 0.0)
            ev[terms.PF_COEF + 2 * k + 1] += values.get(f"pf_c{k + 1}", 0.0)

    def evidence(self, values, explained, ctx):
        p = values["pf_pitch"]
        amp = math.hypot(values.get("pf_s1", 0.0), values.get("pf_c1", 0.0))
        return (f"friction level varies by ±{amp:.0%} periodically in position, pitch "
                f"{format_length(p, ctx.position_unit)}, and the error changes sign with the direction "
                f"of motion (position-dependent friction); {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("amplitude", "pitch", "phase"), self.name)
        amp, pitch = number(kw, "amplitude", self.name), number(kw, "pitch", self.name)
        if pitch <= 0 or not 0 <= abs(amp) < 0.9:
            from bench.errors import InputError
            raise InputError("effect position_dependent_friction: pitch must be positive and |amplitude| < 0.9 (relative)")
        ph = number(kw, "phase", self.name, 0.0)
        ev[terms.PF_PITCH] = pitch
        ev[terms.PF_COEF] += amp * math.cos(ph)
        ev[terms.PF_COEF + 1] += amp * math.sin(ph)
        return {}
