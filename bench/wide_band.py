"""A gear spring above the comparison band.

The comparison low-pass sits at 40x the excitation (``bench.signals.choose_cutoff``: 10 Hz for
a 0.25 Hz sine), low enough to keep the double differentiation's noise in check.  A harmonic
drive's resonance at 11-20 Hz then rings beyond it: the filter leaves too little of it for the
diagnosis to name, yet enough to bend LuGre (independent simulator, tuning seeds 1859-1918:
Fc 16-89 % low on j3, 10-17 % on j1 with most of the inertia beyond the spring, reported
identifiable, and "nothing left to explain").  Analysed at 3x the cutoff the same records
name the spring within 1 % and Fc, Fs and sigma2 within 3 %.

So, unless the user set the cutoff or a gear was already named (``gear_settled``): LuGre is
identified again at a wider band and a gear spring's term scored against what it leaves,
between 0.8x the cutoff and the wider band's edge.  Only when such a spring takes a clear
share does the whole analysis run again at the wider band, and it is kept only if it names
the spring and leaves no structure that the default band did not already leave.  A spring
with part of the friction beyond it is scored as well (``gear.spring_beyond``); when the
analysis without friction beyond the gear leaves structure, or tells it as an inertia error
or gravity (which such a spring passes for under a sine), it runs once more with it.
"""
from __future__ import annotations

import numpy as np

from bench.effects.base import Context
from bench.effects.gear import SPRING_DAMPINGS, gear_scorer, spring_beyond
from bench.fitting import predict
from bench.identify import Identification, identify
from bench.perfect_model import replay
from bench.records import Record
from bench.slow_stream import slowest_reading_rate
from bench.terms import CONTACT_HZ

WIDEN = 3.0            # the wider band, as a multiple of the default cutoff...
MAX_BAND = 0.1         # ...at most this fraction of the sample rate (twice choose_cutoff's cap)...
# ...and of the rate of a stream read between its readings (bench.slow_stream), five readings
# a period of the band's edge: a 200 Hz position on 1 kHz rows (the linear stage under a 6 Hz PID,
# independent simulator, tuning seed 1720) was widened to 100 Hz and its splines' corners
# named an 86 Hz spring, while its default band of 40 Hz read Fc within 1 %; at a tenth of
# the rate a position with its own sampling scattered by 0.3 of a row was widened to 18.6 Hz
# and named an 8.3 Hz spring on j1 (seed 1722), which 30 Hz, beyond it, did not
MAX_READING_BAND = 0.2
MIN_WIDER = 1.5        # below this ratio the wider band adds too little to be worth a fit
# A spring's term must explain this share of what LuGre leaves at the wider band.  Tuning
# seeds (1904-1995): gear springs at 11-80 Hz 0.58-0.85 (0.38 on j3 under coloured process
# noise); clean joints under white and coloured process noise, a friction log, PD tracking and
# 2 kHz 0.001-0.05; a coarse encoder's staircase 0.13-0.55, which the replay test below turns
# away.
MIN_SHARE = 0.3
GEAR_EFFECTS = ("backlash", "joint_flexibility")
# What friction beyond a gear spring passes for under a sine: an inertia error, and gravity
# (over a short travel sin q ~ q ~ -qdd / w^2)
SPRING_MIMICS = ("inertia_error", "gravity")


def wider_band(rec: Record, ident: Identification, min_size: float, artifact_rms: float,
               name: str = "record") -> tuple[Identification, bool] | None:
    """LuGre identified at the wider band when a gear spring above the default one explains
    ``MIN_SHARE`` of what it leaves, at least ``min_size`` (a fraction of the Coulomb level)
    in rms and ``artifact_rms`` times what the perfect-model replay leaves, with whether that
    spring has friction beyond it; None otherwise, or when the band cannot be widened."""
    data = ident.data
    c = data.c
    wide = min(WIDEN * c.cutoff, MAX_BAND / c.dt, MAX_READING_BAND * slowest_reading_rate(rec))
    if wide < MIN_WIDER * c.cutoff or data.load_encoder:
        return None
    wide_ident = identify(rec, inertia=ident.inertia, cutoff=wide, name=name)
    d = wide_ident.data
    values = wide_ident.result.values
    ctx = Context(data=d, values=values, model=predict(d, values), meta=rec.meta, inertia=wide_ident.inertia)
    freqs = np.geomspace(0.8 * c.cutoff, wide, 12)
    score = gear_scorer(ctx)
    share = max(score((0.0, f, z, 0.0)) for f in freqs for z in SPRING_DAMPINGS)
    explained = float(np.sqrt(share)) * score.residual_rms
    beyond = False
    # friction beyond the spring (gear.spring_beyond): its signature seen once LuGre and an
    # inertia error, which it mimics under a sine, have taken their part, and beside LuGre
    # alone as well: around a LuGre fit bent by a large inertia error (the linear stage, 17 %
    # off, tuning seed 1304) the first reached 0.35 at 32 Hz where the term took 0.25 of what
    # LuGre alone leaves (j1's 12 Hz spring with 40 % of the friction beyond it, seed 1941:
    # 0.61 and 0.97)
    kshare, beside, size, _ = spring_beyond(ctx, freqs)
    if min(kshare, beside) >= MIN_SHARE and size > explained:
        share, explained, beyond = kshare, size, True
    if share < MIN_SHARE or explained < min_size * data.coulomb:
        return None
    # ...and more than the measurement chain leaves there: a coarse encoder's staircase takes
    # 0.13-0.55 of it on tuning seeds (1953-1998), explaining 0.5-1.4x what a perfect model
    # replayed on the record leaves (springs: 50-300x)
    twin, twin_residual = replay(rec, d, values, wide_ident.inertia, wide, name)
    if explained < artifact_rms * float(np.sqrt(np.mean(twin_residual[twin.mask] ** 2))):
        return None
    return wide_ident, beyond


def names_a_gear(diag) -> bool:
    return any(name in GEAR_EFFECTS for name in diag.model.names())


def names_a_mimic(diag) -> bool:
    """Was something credited that friction beyond a gear spring passes for?"""
    return any(name in SPRING_MIMICS for name in diag.model.names())


def gear_settled(diag) -> bool:
    """Was a gear named that the wider band need not question?  Not a backlash with friction
    beyond it that acts as a spring with friction beyond it above the default band, which
    passes for one: its play narrower than its contact winds up under that friction (j2,
    independent simulator, 17.5 and 16.9 Hz springs with 18-20 % of the inertia and 33-37 %
    of the friction beyond, tuning seeds 1968 and 1664: 0.06 mrad of play through a 25-27 Hz
    contact winding up 1.4 mrad), or beside what such a spring passes for (1966, 17 Hz: 3.4
    mrad of play beside an inertia error, 22 % of j2's).  True backlashes with 30-60 % of the
    friction beyond them, whose probe costs 2.6x their analysis, were named alone with plays
    34-240x the wind-up (j1-j4, fresh seeds 5634-5639)."""
    names, values = diag.model.names(), diag.model.values
    if not names_a_gear(diag):
        return False
    if "backlash" not in names or values.get("bl_kappa", 0.0) <= 0:
        return True
    # the friction beyond (kappa M_load Fs) over the contact's stiffness (M_load w^2)
    wind_up = values["bl_kappa"] * values["Fs"] / (2 * np.pi * values.get("bl_contact", CONTACT_HZ)) ** 2
    return bool(values["bl_width"] >= wind_up) and not names_a_mimic(diag)


def widened_warning(default_cutoff: float, wide: float, frequency: float) -> str:
    if frequency < default_cutoff:
        # the probe searches from 0.8x the band, and the wider analysis's fit may settle below
        # it (a j2 spring under a felt disturbance, tuning seed 1975: 9.68 Hz for a 12 Hz band)
        return (f"a gear resonance was named at {frequency:.3g} Hz only at a band wider than the "
                f"default one ({default_cutoff:.3g} Hz, 40x the excitation), whose edge it sits "
                f"near: the record was analysed at {wide:.3g} Hz instead")
    return (f"a gear resonance at {frequency:.3g} Hz lies above the default comparison band "
            f"({default_cutoff:.3g} Hz, 40x the excitation), where it bends LuGre without being "
            f"seen: the record was analysed at {wide:.3g} Hz instead")
