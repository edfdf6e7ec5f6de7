"""thermal_drift: friction drifts monotonically over the record as the joint warms up.  The
lubricant thins, so the viscous coefficient sigma2 falls, and the Coulomb/Stribeck levels move
too, by their own amount (often less, or the other way): s(v) is scaled by
1 + g (1 - exp(-t / tau)) and sigma2 by 1 + g_v (1 - exp(-t / tau)), one time constant (the
joint's temperature).  One gain for both was too narrow: a drift of the viscous part alone
(another simulator's convention, and what warm-up does on a fast joint) was not named on j1
and left a residual of 11 % of Fc after the one-gain fit on j2/j3 (independent records,
2026-11-25)."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, Effect, check_known, explained_text, number
from bench.errors import InputError
from bench.fitting import LUGRE_KEYS, Param
from bench.level_drift import drift_follows
from bench.lugre import LuGreParams

# The neighbours must follow the levels at least as well as the drift, by this share of Fc.
# Measured 2026-11-25 (tuning seeds 1450-1465 and seeds 9301-9306, since moved to 9401+ in the
# test): drifts that were exponentials (ours and the independent simulator's viscous warm-up,
# six joints each) had neighbours 6.8-860000x worse than the drift; steps of 6-12 % of Fc
# 0.11-0.73x, 1.0-1.9 % of Fc.
FOLLOWS_RATIO, FOLLOWS_SIZE = 1.0, 0.008
# Nor may one step follow them better (the same share of Fc).  Under two tones a Table II
# joint's 20 s has 8-9 uneven segments, too few and noisy for the neighbours: a 10 % step at
# 10 s was credited as a warm-up of +15 % (j2, j4: tuning seeds 1603, 1605; j4 fresh seed
# 10065, looked at to find this), the neighbours 1.0-1.06x the drift.  Measured 2026-12-02
# (own error / a step's): 10 % steps mid-record under two tones, a felt disturbance of 1 % of
# Fc, six joints (1600-1605) 5.3-158x, 2.3-2.6 % of Fc; exponential drifts 0.034x at most (the
# independent simulator's viscous warm-up, two tones and one sine, 1610-1618: <= 0.002x; our
# scenarios' drifts, tau 0.2-1x the record, under nine recording conditions, 1630-1638:
# <= 0.034x, the rotary motor's robot joint log).
STEP_RATIO = 1.0
# Drifts no warm-up makes: a level falling below a tenth of itself or growing tenfold.
RUNAWAY = (-0.9, 9.0)


class ThermalDrift(Effect):
    name = "thermal_drift"
    signals = ("time",)
    summary = "friction drifting over the record"
    hyper = ("th_tau",)

    def variants(self, ctx: Context) -> list[dict]:
        T = float(ctx.data.c.t[-1] - ctx.data.c.t[0])
        return [{"th_tau": f * T, "th_gain": 0.0, "th_visc": 0.0} for f in (0.1, 0.3, 1.0, 3.0)]

    def params(self, init):
        return [Param("th_tau", init["th_tau"], log=True),
                Param("th_gain", init["th_gain"], log=False, lo=-0.9),
                Param("th_visc", init["th_visc"], log=False, lo=-0.9)]

    def holds(self, values, ctx):
        """One exponential must describe how the level moves: the neighbouring motion
        segments must not predict the level series better than the fitted drift does
        (``bench.level_drift.drift_follows``), nor one step of them.  A step of the levels
        mid-record was fitted as a drift explaining 25-45 % of the held-out residual
        (independent records, 2026-11-25)."""
        # the term in sliding, where the bristles sit at s(v): the levels are taken there
        c, m = ctx.data.c, ctx.data.mask
        rise = 1.0 - np.exp(-(c.t - c.t[0]) / values["th_tau"])
        s = LuGreParams(**{k: values[k] for k in LUGRE_KEYS}, delta=values.get("delta", 1.0)).stribeck(c.v)
        term = rise * (values["th_gain"] * s * np.sign(c.v) + values["th_visc"] * values["sigma2"] * c.v)
        own, neighbours, step, n = drift_follows(c, ctx.residual, term, m)
        if n == 0:
            return True
        size = FOLLOWS_SIZE * ctx.data.coulomb
        return not any(other < ratio * own and math.sqrt((own - other) / n) >= size
                       for other, ratio in ((neighbours, FOLLOWS_RATIO), (step, STEP_RATIO)))

    def fd_step(self, key, ctx):
        return 1e-3

    def apply(self, values, extra, ev):
        ev[terms.THERM_GAIN] = values["th_gain"]
        ev[terms.THERM_VISC] = values["th_visc"]
        ev[terms.THERM_TAU] = values["th_tau"]

    def evidence(self, values, explained, ctx):
        T = float(ctx.data.c.t[-1] - ctx.data.c.t[0])
        rise = 1.0 - math.exp(-T / values["th_tau"])
        level, visc = values["th_gain"] * rise, values["th_visc"] * rise
        what = (f"friction level drifts by {level:+.0%}" if abs(level - visc) < 0.02 else
                f"Coulomb/Stribeck level drifts by {level:+.0%} and viscous friction by {visc:+.0%}")
        text = (f"{what} over the {T:.3g} s record (time constant {values['th_tau']:.3g} s), as a "
                f"joint warming up does; {explained_text(explained)}")
        if min(level, visc) <= RUNAWAY[0] or max(level, visc) >= RUNAWAY[1]:
            # an entry tried and not added can end anywhere (a friction-column log of j2:
            # -147 % and +3e8 %); said, so a reader does not take it for a measurement
            text += "; no joint warms up like that: this refit ran away and measures nothing"
        return text

    def inject(self, kw, ev, spec):
        check_known(kw, ("gain", "tau", "viscous_gain"), self.name)
        gain, tau = number(kw, "gain", self.name), number(kw, "tau", self.name)
        visc = number(kw, "viscous_gain", self.name, gain)
        if tau <= 0 or gain <= -0.9 or visc <= -0.9:
            raise InputError("effect thermal_drift: tau must be positive and gain, viscous_gain > -0.9")
        ev[terms.THERM_GAIN] = gain
        ev[terms.THERM_VISC] = visc
        ev[terms.THERM_TAU] = tau
        return {}
