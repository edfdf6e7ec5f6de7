"""joint_flexibility: a compliant gear (harmonic drive, long shaft, belt) between motor and
load: a two-mass joint with locked-rotor resonance ``frequency`` and damping ratio
``damping``.  Friction transitions (breakaway, reversals) ring the resonance.

With the encoder on the motor, eq. 5 leaves M_load (qdd_load - qdd_motor): the load's
motion is the gear spring driven by the measured motor trajectory
(``bench.terms.load_step``, the virtual joint's own).  The load inertia is linear in the
term (screened); the frequency is searched on a grid up to the comparison filter's cutoff
(a resonance above it is filtered out of what the fit sees), damping and frequency are then
refined by the joint fit.

With the encoder on the load (``encoder: load``) the motor's lead through the spring follows
from the load's acceleration (``bench.load_side.spring_slip``); the motor's friction runs on
its own velocity, and the linear part is the motor's inertia (``flex_load`` holds the inertia
beyond the spring from the encoder)."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, check_known, explained_text, number
from bench.effects.gear import GearEffect, best_gears
from bench.errors import InputError
from bench.fitting import Param

DEFAULT_DAMPING = 0.05    # lightly damped: harmonic drives and steel shafts, 0.02-0.1
MIN_DAMPING = 0.005       # the fit's floor
# ...and rings: above a damping ratio of 0.3 the resonance peak is below 1.75x (1 / (2 zeta
# sqrt(1 - zeta^2))), a smooth low-pass that shapes any cycle-locked mismatch.  A saturating
# torque constant on the linear stage (tuning seeds 1001, 1013) was "explained" by 3.7-4 Hz
# at damping 0.44-0.52; real gear springs (harmonic drives, shafts, couplings) 0.02-0.2, and
# their fits on tuning seeds 1500-1502 0.04-0.12.
MAX_DAMPING = 0.3


def slowest(c) -> float:
    """The slowest spring searched: twice the excitation, at least 1 Hz."""
    return max(2.0 * c.frequency, 1.0)


def searched_frequencies(c) -> np.ndarray:
    """The spring frequencies the search scores: from ``slowest`` up to the cutoff, not
    beyond: there the fit shapes the filter's own edge (on tuning seed 1490, a 3 ms logger's
    17 Hz cutoff, an 18.7 Hz "resonance" of 4 % of the inertia).  Empty when none fit."""
    lo, hi = slowest(c), c.cutoff
    return np.geomspace(lo, hi, 14) if hi > lo else np.empty(0)


class JointFlexibility(GearEffect):
    name = "joint_flexibility"
    signals = ("travel_since_reversal",)
    summary = "two-mass joint: a gear spring between motor and load"
    hyper = ("flex_frequency", "flex_kappa")
    load_key = "flex_load"
    kappa_key = "flex_kappa"
    # The screening scores the spring's starts against a LuGre fit the spring bent (sigma0
    # 350x, Fs 1.7x on the linear stage's 14.5 Hz spring, tuning seed 1601): there 2.2 Hz
    # screened best and its refit ended at 2.4 Hz, damping 0.53 (not credible), while the
    # refit from the 15.3 Hz start found 14.54 Hz, damping 0.096, 30 % of the inertia (true
    # 14.53 Hz, 0.096, 30 %) and 1 % of the held-out error.  So every start is refitted.
    restarts = 3

    def variants(self, ctx: Context) -> list[dict]:
        freqs = searched_frequencies(ctx.data.c)
        if not len(freqs):
            return []
        grid = [(0.0, f, DEFAULT_DAMPING) for f in freqs]
        # seen from the load, the motor's slip through the spring is a term of its own
        slip = {"flex_slip": 0.0} if ctx.data.load_encoder else {}
        return [{"flex_frequency": f, "flex_damping": z, "flex_load": 0.0, "flex_kappa": k, **slip}
                for _, f, z, k in best_gears(ctx, grid, dampings=(0.02, 0.1, 0.2))]

    def params(self, init):
        return [Param("flex_frequency", init["flex_frequency"], log=True),
                Param("flex_damping", init["flex_damping"], log=True,
                      lo=math.log(MIN_DAMPING), hi=math.log(1.0)),
                self.load_param(init)] + self.kappa_params(init)

    def fd_step(self, key, ctx):
        if key in ("flex_damping", "flex_slip"):
            return 0.01
        return super().fd_step(key, ctx)

    def credible(self, values, ctx):
        # a damping at the fit's floor is a narrow line fitted to noise (see gear.MIN_LOAD_SHARE),
        # unless friction beyond the spring damps it instead of its own: j1's 12 Hz spring
        # with 40 % of the friction beyond it fitted 0.005 (independent simulator, tuning
        # seed 1941); with 30 % beyond a 12 Hz spring it fitted 0.026-0.037 (seed 1986)
        floor_ok = self.share(values) > 0 or 1.1 * MIN_DAMPING < values["flex_damping"]
        # ...and within the searched range: a fit that leaves it downwards shapes the
        # excitation's own cycle (0.55 Hz under a 0.25 Hz sine, j1 with a 14 Hz spring and 40 %
        # of the friction beyond it, independent simulator, tuning seed 1954)
        return (slowest(ctx.data.c) <= values["flex_frequency"] <= ctx.data.c.cutoff
                and floor_ok and values["flex_damping"] <= MAX_DAMPING
                and self.gear_credible(values, ctx))

    def fails_at_end(self, values, ctx):
        # credible when its round added it, but refitted beside a later effect the spring may
        # flatten into a smooth low-pass that shapes whatever is left: a loaded gear mesh under
        # PID tracking (j1, independent simulator, tuning seed 1825) was told as a 9.6 Hz
        # spring of damping 0.009 that ended at 14.8 Hz, damping 0.83, beside a torque lag
        zeta, f = values["flex_damping"], values["flex_frequency"]
        if zeta > MAX_DAMPING:
            return (f"refitted beside the other effects its damping ratio ended at {zeta:.2g}, a smooth "
                    f"low-pass rather than a resonance that rings")
        if not slowest(ctx.data.c) <= f <= ctx.data.c.cutoff:
            return (f"refitted beside the other effects its resonance ended at {f:.3g} Hz, outside the "
                    f"band it can be seen in ({slowest(ctx.data.c):.3g}-{ctx.data.c.cutoff:.3g} Hz)")
        return ""

    def apply(self, values, extra, ev):
        extra["flex_frequency"] = values["flex_frequency"]
        extra["flex_damping"] = values["flex_damping"]
        extra["load_inertia"] += values["flex_load"]
        # the slip's share: screened from 0, not a fitted parameter, so 1 once refitted
        extra["flex_slip"] = values.get("flex_slip", 1.0)
        self.apply_kappa(values, extra)

    def evidence(self, values, explained, ctx):
        f, zeta = values["flex_frequency"], values["flex_damping"]
        return (f"the joint is compliant: a resonance at {f:.3g} Hz (locked rotor) with damping "
                f"ratio {zeta:.2g} rings at friction transitions ({self.load_share(values, ctx)}"
                f"{self.friction_text(values)}); "
                f"keep the position loop's bandwidth well below it (about {f / 3:.2g} Hz) or add "
                f"a notch / load-side feedback; {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("frequency", "damping", "load_fraction", "load_friction"), self.name)
        f = number(kw, "frequency", self.name)
        zeta = number(kw, "damping", self.name, DEFAULT_DAMPING)
        if not f > 0:
            raise InputError("effect joint_flexibility: frequency must be positive [Hz]")
        if not 0 < zeta < 2:
            raise InputError("effect joint_flexibility: damping ratio must lie in (0, 2)")
        ev[terms.FLEX_FREQ] = f
        ev[terms.FLEX_DAMP] = zeta
        self.inject_load(kw, ev)
        return {}
