"""inertia_error: the declared M_jj differs from the true one, so eq. 5 leaves
(M_true - M_declared) * qdd in the friction estimate (the paper's Fig. 2)."""
from __future__ import annotations

from bench.effects.base import Context, Effect, check_known, explained_text, number


class InertiaError(Effect):
    name = "inertia_error"
    summary = "declared inertia differs from the true one"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"inertia_error": 0.0}]

    def fd_step(self, key, ctx):
        return 1e-3 * ctx.inertia

    def apply(self, values, extra, ev):
        extra["inertia_error"] += values["inertia_error"]

    def evidence(self, values, explained, ctx):
        M, dM = ctx.inertia, values["inertia_error"]
        return (f"residual is proportional to acceleration: the declared inertia {M:.4g} is "
                f"{abs(dM / M):.0%} too {'low' if dM > 0 else 'high'} (M ~ {M + dM:.4g}); "
                f"{explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("factor",), self.name)
        factor = number(kw, "factor", self.name)
        if factor <= 0:
            from bench.errors import InputError
            raise InputError("effect inertia_error: factor (declared / true inertia) must be positive")
        return {"inertia_factor": factor}
