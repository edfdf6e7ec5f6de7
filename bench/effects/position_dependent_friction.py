"""position_dependent_friction: the friction level varies periodically with position
(eccentric bearing, uneven preload along a screw): s(v) is scaled by a Fourier series in q,
so the torque changes sign with the direction of motion, unlike cogging."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import Context, check_known, explained_text, number
from bench.effects.periodic import PositionSeries, format_length, torque_locked
from bench.errors import InputError


class PositionDependentFriction(PositionSeries):
    name = "position_dependent_friction"
    summary = "friction level periodic in position"
    prefix = "pf"
    pitch_slot = terms.PF_PITCH
    coef_slot = terms.PF_COEF
    harmonics = terms.PF_HARMONICS

    def periodogram_weight(self, ctx: Context):
        # the term is (level - 1) times the friction: weight the periodogram basis with the
        # model's friction without its viscous part, ~ sgn(v) s(v)
        return ctx.model - ctx.values["sigma2"] * ctx.data.c.v

    def fd_step(self, key, ctx):
        return 1e-3

    def evidence(self, values, explained, ctx):
        periods = float(np.ptp(ctx.data.c.q)) / self.pitch(values)
        # under two periods in the travel nothing shows that it repeats (a saturating torque
        # constant under one sine was fitted with 1.3-1.7: README known limits)
        how = ("periodically in position" if periods >= 2.0 else
               f"along the travel ({periods:.2g} periods of it in the travel: whether it repeats is not seen)")
        return (f"friction level varies by ±{self.fundamental(values):.0%} {how}, "
                f"pitch {format_length(self.pitch(values), ctx.position_unit)}, and the error changes "
                f"sign with the direction of motion (position-dependent friction); "
                f"{explained_text(explained)}{torque_locked(ctx)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("amplitude", "pitch", "phase"), self.name)
        amp, pitch = number(kw, "amplitude", self.name), number(kw, "pitch", self.name)
        if pitch <= 0 or not abs(amp) < 0.9:
            raise InputError("effect position_dependent_friction: pitch must be positive and "
                             "|amplitude| < 0.9 (relative)")
        self.inject_series(ev, pitch, [amp], number(kw, "phase", self.name, 0.0))
        return {}
