"""inertia_error: the declared M_jj differs from the true one, so eq. 5 leaves
(M_true - M_declared) * qdd in the friction estimate (the paper's Fig. 2)."""
from __future__ import annotations

import numpy as np

from bench.effects.base import POSITION_ADDS, Context, Effect, check_known, explained_text, number, position_adds
from bench.errors import InputError


class InertiaError(Effect):
    name = "inertia_error"
    summary = "declared inertia differs from the true one"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"inertia_error": 0.0}]

    def direct_estimate(self, ctx: Context) -> dict | None:
        """Fig. 2's argument made a regression: at high speed the true friction depends on v
        alone (F = Fc sgn v + sigma2 v), so the friction estimate's dependence on
        acceleration there is the inertia error."""
        c, F, m = ctx.data.c, ctx.data.friction, ctx.data.mask
        speed = np.abs(c.v)
        vmax = float(np.percentile(speed[m], 99.5))
        hi = m & (speed > 0.5 * vmax)
        if hi.sum() < 20:
            return None
        X = np.column_stack([np.sign(c.v[hi]), c.v[hi], c.a[hi]])
        coef, *_ = np.linalg.lstsq(X, F[hi], rcond=None)
        return {"inertia_error": float(coef[2])}

    def holds(self, values, ctx):
        """Its physics must hold beyond the excitation's frequency.  Under a sine the
        acceleration follows the position, so a force along the travel (a spring, a cable
        carrier) leaves what an inertia error leaves there; only the motion's harmonics tell
        them apart, and with the fitted term in, position must add nothing."""
        return position_adds(values["inertia_error"] * ctx.data.c.a, ctx) <= POSITION_ADDS

    def fd_step(self, key, ctx):
        if ctx.inertia > 0:
            return 1e-3 * ctx.inertia
        # a friction-torque record (M = 0): the inertia that would move the estimate as much
        a = ctx.data.c.a[ctx.data.mask]
        return 1e-3 * float(np.std(ctx.data.friction[ctx.data.mask])) / max(float(np.std(a)), 1e-300)

    def apply(self, values, extra, ev):
        extra["inertia_error"] += values["inertia_error"]

    def evidence(self, values, explained, ctx):
        M, dM = ctx.inertia, values["inertia_error"]
        if M == 0:
            return (f"residual is proportional to acceleration: the friction column still carries an "
                    f"inertia term M ~ {dM:.4g}; {explained_text(explained)}")
        return (f"residual is proportional to acceleration: the declared inertia {M:.4g} is "
                f"{abs(dM / M):.0%} too {'low' if dM > 0 else 'high'} (M ~ {M + dM:.4g}); "
                f"{explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("factor",), self.name)
        factor = number(kw, "factor", self.name)
        if factor <= 0:
            raise InputError("effect inertia_error: factor (declared / true inertia) must be positive")
        return {"inertia_factor": factor}
