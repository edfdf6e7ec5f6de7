"""Refitting a model with one more effect, and scoring a model on held-out cycles.

The diagnosis (``bench.diagnosis``) adds effects one at a time; each is fitted together with
LuGre and the effects already in (``refit``), its nested control is the same model refitted
without it (``refit_without``), and everything is compared on the held-out motion segments
(``evaluate``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bench.effects import Context, Effect
from bench.fitting import LUGRE_KEYS, FitData, FitResult, Param, cleaned, fit, predict
from bench.screening import CrossValidation, Model, model_columns


def effect_params(effect: Effect, init: dict, beta: dict) -> list[Param]:
    """The effect's parameters, started at the screened values.  A linear step can overshoot
    a positive (log-scale) parameter; it is then kept within a factor 4 of its start."""
    start = {k: init[k] + beta.get(k, 0.0) for k in init}
    positive = {p.name for p in effect.params(init) if p.log}
    for k in positive:
        start[k] = float(np.clip(start[k], init[k] / 4.0, init[k] * 4.0))
    params = effect.params(start)
    out = []
    for p in params:
        if p.name in effect.hyper:  # searched: refine locally only (within its own bounds)
            x = p.to_x(p.value)
            width = 0.2 if p.name.endswith("pitch") else 3.0
            p = Param(p.name, p.value, p.log, max(x - width, p.lo), min(x + width, p.hi))
        out.append(p)
    return out


def refit(data: FitData, model: Model, effect: Effect, init: dict, beta: dict,
          inertia: float, ctx: Context | None = None, rounds: int = 3,
          others: list[tuple[dict, dict]] = ()) -> tuple[Model, FitResult]:
    """Fit LuGre, the effects already added and ``effect`` together.

    A missing effect distorts the LuGre fit it was missing from, sometimes into another
    basin, and the screened (linearised) size of the effect is then only a rough guess.  So
    besides starting from the current values, LuGre is re-identified (Section III + start
    search) on the friction estimate with the effects' contribution removed, for the
    screened effect size and for the effect's own direct estimate if it has one; the
    cleaning is repeated with the refitted effect values until the cost stops falling.

    ``others``: more screened starts of the effect (init, beta), each refitted the same way;
    the lowest cost of all wins (``Effect.restarts``)."""
    fitted = [Param(p.name, model.values[p.name], p.log, p.lo, p.hi)
              for p in model.params if p.name not in LUGRE_KEYS]
    appliers = model.appliers + [effect.apply]
    direct = effect.direct_estimate(ctx) if ctx is not None else None
    best = None

    def attempt(new, start, values):
        nonlocal best
        lugre = [Param(k, start[k], True, math.log(start[k]) - 4, math.log(start[k]) + 4)
                 for k in LUGRE_KEYS]
        eff = [Param(p.name, values[p.name], p.log, p.lo, p.hi) for p in fitted + new]
        res = fit(data, lugre + eff, fixed=dict(values, **start), appliers=appliers, max_nfev=40)
        if best is None or res.cost < 0.99 * best[1].cost:
            best = (lugre + eff, res)
            return True
        return False

    for i, (init_i, beta_i) in enumerate([(init, beta), *others]):
        new = effect_params(effect, init_i, beta_i)
        screened = dict(model.values, **{p.name: p.value for p in new})
        own = direct if i == 0 else None      # the direct estimate does not depend on the start
        candidates = [screened] + ([dict(screened, **own)] if own else [])
        attempt(new, {k: model.values[k] for k in LUGRE_KEYS}, screened)
        if own and all(k in own for k in LUGRE_KEYS):   # an estimate with its own LuGre
            attempt(new, {k: own[k] for k in LUGRE_KEYS}, dict(screened, **own))
        # always re-identify as well: the screening's linearised promise can be far worse than
        # the true optimum, so a local refit that "meets" it may still sit in the wrong basin
        for values in candidates:
            for _ in range(rounds):
                improved = False
                for start in _cleaned_starts(data, values, appliers, inertia):
                    improved |= attempt(new, start, values)
                if not improved:
                    break
                values = dict(best[1].values)
    params, res = best
    owner = dict(model.owner, **{p.name: effect.name for p in new})
    return Model(values=res.values, effects=model.effects + [effect], params=params, result=res,
                 owner=owner), res


def _cleaned_starts(data: FitData, values: dict, appliers, inertia: float) -> list[dict]:
    """LuGre starting points identified on the friction estimate minus the effects."""
    from bench.identify import NotIdentifiable, lugre_starts, section3_estimates
    try:
        clean = cleaned(data, values, appliers)
        starts = lugre_starts(clean, section3_estimates(clean, inertia, revolute=data.revolute), inertia)
    except (NotIdentifiable, ValueError, FloatingPointError):
        return []
    # ...and each with the current presliding parameters: an effect distorts the map more
    # than the bristles, and the start search's sigma1 can be far off (36 for a true 8900 on j1
    # with a viscous warm-up: the fit from it fell into alpha = 2, Fc -28 %; from the current
    # sigma0/sigma1 it found the truth at half the cost; independent records, 2026-11-25)
    pre = {k: values[k] for k in ("sigma0", "sigma1")}
    return starts + [dict(s, **pre) for s in starts if any(s[k] != pre[k] for k in pre)]


@dataclass
class Evaluated:
    """A model scored on held-out cycles."""
    model: Model
    ctx: Context
    J: np.ndarray
    r: np.ndarray
    sse: np.ndarray
    rms: float


def evaluate(data: FitData, model: Model, cv: CrossValidation, meta: dict, inertia: float,
              chain_mse: float = 0.0) -> Evaluated:
    base = predict(data, model.values, model.appliers)
    ctx = Context(data=data, values=model.values, model=base, meta=meta, inertia=inertia, chain_mse=chain_mse)
    J = model_columns(data, model, base, cv.idx)
    r = ctx.residual[cv.idx]
    sse = cv.sse(J, r)
    return Evaluated(model, ctx, J, r, sse, math.sqrt(sse.sum() / cv.counts().sum()))


def without(data: FitData, model: Model, name: str) -> Model:
    """``model`` minus effect ``name``, the rest refitted locally from their current values."""
    gone = {k for k, owner in model.owner.items() if owner == name}
    base = Model(values={k: v for k, v in model.values.items() if k not in gone},
                 effects=[e for e in model.effects if e.name != name],
                 params=[p for p in model.params if p.name not in gone],
                 owner={k: o for k, o in model.owner.items() if o != name})
    return refit_without(data, base, base)


def polish_params(model: Model, values: dict) -> list[Param]:
    """``model``'s parameters started at ``values``, the positive ones bounded within e^4 of
    them: a local polish (``refit_without``, ``bench.structure_spread``)."""
    return [Param(p.name, values[p.name], p.log,
                  (math.log(values[p.name]) - 4 if p.log else p.lo),
                  (math.log(values[p.name]) + 4 if p.log else p.hi)) for p in model.params]


def refit_without(data: FitData, model: Model, with_effect: Model) -> Model:
    """``model``'s parameters refitted locally, started from the values ``with_effect``
    reached."""
    values = {k: with_effect.values[k] for k in model.values}
    params = polish_params(model, values)
    res = fit(data, params, fixed=values, appliers=model.appliers, max_nfev=20)  # a local polish
    return Model(values=res.values, effects=list(model.effects), params=params, result=res,
                 owner=dict(model.owner))
