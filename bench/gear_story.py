"""Which story a diagnosis tells of a geared joint: the checks that send the analysis for a
second pass with friction beyond the gear (``bench.effects.gear.friction_beyond_gear``), and
the rule that keeps that pass.  Under a repeated sine a gear's hysteresis is cycle-locked and
so position-locked, and friction beyond a spring acts like an inertia error: without these a
gear was told as cogging or as an inertia error (``bench.analysis._diagnose_from``)."""
from __future__ import annotations

from bench.diagnosis import Diagnosis
from bench.effects.gear import spring_beyond
from bench.effects.joint_flexibility import searched_frequencies
from bench.effects.periodic import PositionSeries
from bench.unexplained import structured
from bench.wide_band import MIN_SHARE, names_a_gear, names_a_mimic


def inertia_like_spring(diag: Diagnosis) -> bool:
    """Was an inertia error (or gravity) credited, and does a gear spring with friction beyond
    it take a clear share of what is left (``gear.spring_beyond``, below the band as the
    flexibility's variants are)?  Friction beyond a spring acts like an inertia error under a
    sine, plus the ringing an inertia error leaves (j2, independent simulator, 30 % of the
    friction beyond a 12 Hz spring, tuning seed 1986: told as an inertia error 11 % low,
    nothing left; j4, 40 % beyond 11 Hz, seed 1970: as gravity)."""
    if not names_a_mimic(diag):
        return False
    ctx = diag.contexts[-1]
    freqs = searched_frequencies(ctx.data.c)
    return len(freqs) > 0 and spring_beyond(ctx, freqs)[0] >= MIN_SHARE


def mimic_without_gear(diag: Diagnosis) -> bool:
    """Was an inertia error or gravity credited, and no gear?"""
    return names_a_mimic(diag) and not names_a_gear(diag)


def beyond_wins(second: Diagnosis, first: Diagnosis, data) -> bool:
    """Is the pass with friction beyond the gear kept over the one without it?  Only when it
    leaves nothing structured and predicts the held-out motion better."""
    return not left_structured(second, data) and second.final_rms < first.final_rms


def left_structured(diag: Diagnosis, data) -> bool:
    """Does the verdict call what the final model leaves structured?"""
    p, floor = diag.final_predictability, diag.noise_floor
    return p is None or structured(p, data.coulomb, diag.replay_rms,
                                   diag.final_rms / floor if floor > 0 else None)


# A position series that is real explains the other direction of motion about as well as its
# own: 0.99-1.0 of it (cogging and position-dependent friction on j1-j4, tuning seeds 1901-1904
# and 7001); a gear's hysteresis taken for cogging, 0.45 (j3, independent simulator, 30 % of
# the friction beyond 3 mrad of backlash, tuning seed 1722)
ACROSS_SHARE = 0.8


def position_series_credited(diag: Diagnosis) -> bool:
    """Was a position series (cogging, position-dependent friction) credited that explains the
    other direction clearly less well than its own?  Under a repeated sine a gear's hysteresis
    is cycle-locked, so position-locked too: backlash with 30 % of the friction beyond it was
    told as cogging and position-dependent friction with nothing left (seed 1722), where the
    gear leaves less, held out."""
    series = {e.name for e in diag.model.effects if isinstance(e, PositionSeries)}
    for step in diag.steps:
        for sc in step.screens:
            if step.effect in series and sc.effect == step.effect \
                    and sc.explained_across < ACROSS_SHARE * sc.explained:
                return True
    return False


def gear_hysteresis_left(diag: Diagnosis, data) -> bool:
    """Is the final residual structured, and does it follow the travel since the last reversal
    among its first three signals?  (Under a repeated sine, position is the phase and comes
    first, velocity often next: j1-j3 with the friction beyond their backlash, independent
    simulator, seeds 9131-9133; with 30 % of it beyond, tuning seed 1721, travel came third.)"""
    p = diag.final_predictability
    if p is None or "travel_since_reversal" not in p.get("relies_on", [])[:3]:
        return False
    return left_structured(diag, data)
