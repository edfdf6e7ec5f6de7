"""cogging: an additive torque periodic in position, the same in both directions of motion
(permanent-magnet detent torque, gear-mesh ripple).  The pitch is found from the residual's
periodogram in position; three harmonics are fitted."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import check_known, explained_text, number
from bench.effects.periodic import PositionSeries, format_length, torque_locked
from bench.errors import InputError


class Cogging(PositionSeries):
    name = "cogging"
    summary = "additive torque periodic in position"
    prefix = "cog"
    pitch_slot = terms.COG_PITCH
    coef_slot = terms.COG_COEF
    harmonics = terms.COG_HARMONICS

    def credible(self, values, ctx):
        # a ripple that repeats: two whole periods inside the travel.  With one, three
        # harmonics over a single period make any smooth function of position -- a saturating
        # torque constant on the inertia-dominated linear stage under a sine (tau^3 ~ -q^3, the
        # same in both directions) logged at 125 Hz was "cogging" of pitch 105 mm over 124 mm,
        # with "nothing left", on 5 of 5 tuning seeds (1011-1015).  Injected cogging has 4-20
        # periods in the travel, a gear's mesh hundreds.
        return super().credible(values, ctx) and 2.0 * self.pitch(values) <= float(np.ptp(ctx.data.c.q))

    def evidence(self, values, explained, ctx):
        return (f"residual is periodic in position with pitch "
                f"{format_length(self.pitch(values), ctx.position_unit)}, the same in both directions "
                f"of motion (cogging, amplitude {self.fundamental(values):.3g} {ctx.torque_unit}); "
                f"{explained_text(explained)}{torque_locked(ctx)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("amplitude", "pitch", "phase", "h2", "h3"), self.name)
        amp, pitch = number(kw, "amplitude", self.name), number(kw, "pitch", self.name)
        if pitch <= 0:
            raise InputError("effect cogging: pitch must be positive")
        rel = (1.0, number(kw, "h2", self.name, 0.0), number(kw, "h3", self.name, 0.0))
        self.inject_series(ev, pitch, [amp * r for r in rel], number(kw, "phase", self.name, 0.0))
        return {}
