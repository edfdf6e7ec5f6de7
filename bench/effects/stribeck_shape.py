"""stribeck_shape: the Stribeck curve is exp(-(alpha |v|)^delta) with delta != 1 (Gaussian-
like delta = 2 is common in lubricated contacts; the paper's model is delta = 1)."""
from __future__ import annotations

from bench.effects.base import Context, Effect, check_known, explained_text, number
from bench.errors import InputError
from bench.fitting import Param


class StribeckShape(Effect):
    name = "stribeck_shape"
    signals = ("velocity",)
    summary = "Stribeck exponent delta"

    def variants(self, ctx: Context) -> list[dict]:
        return [{"delta": 1.0}]

    def params(self, init):
        return [Param("delta", init["delta"], log=True, lo=-2.5, hi=1.6)]

    def fd_step(self, key, ctx):
        return 1e-2

    def apply(self, values, extra, ev):
        pass  # delta is a LuGre parameter: the model reads values["delta"]

    def whole_only(self, values) -> str:
        # an exponent reshapes the map wherever the joint slides, so it takes a part of any
        # structure that varies over the cycle: a saturating torque constant was credited as
        # a Stribeck exponent beside a flagged residual (fresh seeds 8702, 8703; README known
        # limits).  A true exponent leaves nothing structured.
        return "a Stribeck exponent reshapes the whole friction-velocity map, so it is credited only as the whole story"

    def evidence(self, values, explained, ctx):
        d = values["delta"]
        shape = "sharper (more abrupt)" if d > 1 else "more gradual"
        return (f"the friction-velocity map's Stribeck dip is {shape} than exp(-alpha|v|): "
                f"exponent delta ~ {d:.2f}; {explained_text(explained)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("delta",), self.name)
        d = number(kw, "delta", self.name)
        if not 0.1 <= d <= 5:
            raise InputError("effect stribeck_shape: delta must lie in [0.1, 5]")
        return {"delta": d}
