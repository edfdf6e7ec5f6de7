"""After the forward search: drop what a later effect made unnecessary (``backward_pass``) and
what only absorbed part of a structure its physics does not explain (``drop_absorbers``)."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

from bench.effects import get
from bench.fitting import FitData
from bench.refit import Evaluated, evaluate, without
from bench.screening import MIN_EXPLAINED

if TYPE_CHECKING:
    from bench.diagnosis import Diagnosis, Step


def backward_pass(data, cur: Evaluated, steps: list[Step], cv, meta, inertia, baseline_rms,
                   chain: float = 0.0) -> Evaluated:
    """Forward selection can add an effect that a later one makes unnecessary (an inertia
    error mimicking part of a Stribeck shape, say).  Try removing each automatically added
    effect; drop it when it no longer explains MIN_EXPLAINED of the held-out variance."""
    for step in [s for s in steps if not s.forced]:
        trial = evaluate(data, without(data, cur.model, step.effect), cv, meta, inertia, chain)
        if cur.rms ** 2 > (1.0 - MIN_EXPLAINED) * trial.rms ** 2:
            step.removed = True
            step.evidence += f" — but not needed once {', '.join(e.name for e in trial.model.effects)} " \
                             f"was added (held-out rms {trial.rms:.3g} without it)"
            cur = trial
    rechain(steps, baseline_rms, cur.rms)
    return cur


def rechain(steps: list[Step], baseline_rms: float, final_rms: float) -> None:
    """The reported chain of errors follows the effects that stayed."""
    kept = [s for s in steps if not s.removed]
    if len(kept) < len(steps):
        before = baseline_rms
        for s in kept:
            s.rms_before = before
            before = s.rms_after
        if kept:
            kept[-1].rms_after = final_rms


# An effect that must be the whole story (``Effect.whole_only``: a gear with friction on both
# sides) is not credited when the structure left beside it is this share of what it removed.
# A saturating torque constant partly taken for such a gear (test seeds 5902, 5903, 5909) left
# 0.63-0.68 of what the gear removed; 2 mrad of backlash with all the friction beyond it, from
# an independent simulator with a bouncier contact than ours (tests/diagnosis/
# test_independent_records.py, seed 9132), 0.07.
WHOLE_LEFT = 0.25


def drop_absorbers(data: FitData, diag: Diagnosis, meta: dict, inertia: float, leftover) -> Diagnosis:
    """No wrong story: an effect that only absorbed part of a structure it does not explain is
    not credited.  ``leftover(residual)`` names the state signals a *structured* final
    residual depends on (empty when nothing is left).  If what the final model leaves still
    depends on an added effect's own signals (cogging fitted to a cubic in position, say), its
    physics did not hold: it is dropped and the verdict speaks of physics outside the
    library.  So is an effect that removed less than the structure left behind: it took a
    part of something larger, not its cause.  Effects the user forced with --add stay."""
    while True:
        relies, left = leftover(data.friction - diag.contexts[-1].model)
        top = set(relies[:2])

        def removed(s):
            return math.sqrt(max(s.rms_before ** 2 - (s.rms_after or 0.0) ** 2, 0.0))
        kept = [s for s in diag.steps if not s.removed and not s.forced]
        suspects = [s for s in kept if top & set(get(s.effect).signals)] if relies else []
        suspects += [s for s in kept if relies and removed(s) < left and s not in suspects]
        whole = [s for s in kept if relies and get(s.effect).whole_only(s.values)
                 and left >= WHOLE_LEFT * removed(s) and s not in suspects]
        suspects += whole
        broken = {id(s): why for s in kept if s not in suspects
                  and (why := get(s.effect).fails_at_end(diag.model.values, diag.contexts[-1]))}
        suspects += [s for s in kept if id(s) in broken]
        if not suspects:
            return diag
        step = suspects[-1]
        trial = evaluate(data, without(data, diag.model, step.effect), diag.cv, meta, inertia, diag.chain_mse)
        if not trial.model.effects and diag.start is not None:
            # nothing credited: LuGre alone, as the baseline had it unless the polish without
            # the effects did better (a load-side spring on j3, tuning seed 1529: the polish
            # from a dropped Stribeck exponent's values left 12.6 where the baseline had 8.7)
            alone = evaluate(data, diag.start, diag.cv, meta, inertia, diag.chain_mse)
            trial = alone if alone.rms < trial.rms else trial
        step.removed = True
        own = sorted(top & set(get(step.effect).signals))
        step.evidence += (" — but not credited: " + (
            broken[id(step)] if id(step) in broken else
            f"what the model leaves with it still depends on {' and '.join(own)}" if own else
            f"{get(step.effect).whole_only(step.values)}, and it left a structure of {left:.3g} "
            f"beside the {removed(step):.3g} it removed" if step in whole else
            f"it removed {removed(step):.3g}, less than the structure left behind ({left:.3g})")
            + ", so it only absorbed part of a structure its physics does not explain")
        diag.model, diag.final_rms = trial.model, trial.rms
        diag.contexts.append(trial.ctx)
        rechain(diag.steps, diag.baseline_rms, trial.rms)
