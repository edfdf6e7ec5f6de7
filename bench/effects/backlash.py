"""backlash: a dead zone of total width ``width`` in the gear between motor and load.  Each
time the torque the load needs changes sign, the teeth part and the motor turns through
the gap before they meet on the other flank (at a reversal of the motion when the load has
friction of its own; at the velocity peaks of a sine when, as here, the gear's friction is
on the motor).

With the encoder on the motor, eq. 5 leaves M_load (qdd_load - qdd_motor) in the friction
estimate: the load's acceleration is what it gets through the gear, so the term is computed
by running the gear (``bench.terms.load_step``, the virtual joint's own) along the measured
motor trajectory.  The load inertia is linear in the term (screened); the width is searched
on a grid and refined by the joint fit.

With the encoder on the load (``encoder: load``) the load coasts in the gap while the motor
crosses it on its own inertia (``bench.load_side.gap_slip``): eq. 5 then leaves the motor's
friction on its own velocity and its inertia term; the width and the motor's inertia are
fitted, and on a light direct drive, where the two trade off, the verdict says so."""
from __future__ import annotations

import math

import numpy as np

from bench import terms
from bench.effects.base import Context, check_known, explained_text, number
from bench.effects.gear import GearEffect, best_gaps, best_gears, format_angle, gear_scorer
from bench.effects.joint_flexibility import MAX_DAMPING
from bench.errors import InputError
from bench.fitting import LUGRE_KEYS, Param
from bench.gear_model import gear_unit_term
from bench.load_side import gap_friction, gap_slip


# A mesh's contact rings or is at most critically damped (the oil film), and is stiffer than
# the joint's band, yet within what 1 kHz resolves (250 Hz: 7 sub-steps of the load; a 1 kHz
# contact took 25 and made a refit ten times slower).  Left free, the contact's damping ran to
# 4.6 on j3 with half its friction beyond 3.5 mrad of backlash (independent simulator, seed
# 9133), trading against Fc and alpha.
CONTACT_HZ_RANGE = (20.0, 250.0)
CONTACT_DAMPING_RANGE = (0.02, 1.0)
# Seen from a load-side encoder the motor's inertia sets how fast it crosses the gap.  It is a
# share of the joint's: a motor with all of it would float in a wide gap and "predict" the
# measurement itself (tau - M qdd_l; on tuning seed 1511, before the model's load coasted in
# the gap, 0.0 % of Fc was left at 1.25x the width and 2x the motor's inertia).  The geared
# presets carry 50 %; a rotor reflected through a high ratio can carry most of a light arm's.
MOTOR_SHARE = (0.02, 0.9)


# Seen from the load, a light motor crosses the gap in a time set by play x inertia: the two are
# then not separated.  Twice the play with half the motor's inertia (and half with twice) left
# 3.9-126x the error on the geared presets and 1.04-1.8x on the direct drives (rotary motor,
# linear stage, whose fitted widths came out up to 2.7x the truth), tuning seeds 1511-1522
SEPARABLE = 2.0


def width_inertia_trade(values: dict, ctx: Context) -> float:
    """How much worse the fit gets when the play and the motor's inertia trade against each
    other (x2 and x0.5, each way, the rest of the model held): the smaller ratio of held-out
    rms, 1 when they cannot be told apart."""
    data, m = ctx.data, ctx.data.mask
    w, motor = values["bl_width"], values["bl_motor"]
    _, unit, along = gap_slip(data, w, motor)
    base = ctx.residual[m]
    rms = float(np.sqrt(np.mean(base ** 2))) or 1e-300
    ratios = []
    for fw, fm in ((2.0, 0.5), (0.5, 2.0)):
        _, u2, a2 = gap_slip(data, w * fw, motor * fm)
        r = base + (along + motor * unit)[m] - (a2 + motor * fm * u2)[m]
        ratios.append(float(np.sqrt(np.mean(r ** 2))) / rms)
    return min(ratios)


# A gear that is both loose and compliant (a spur or planetary stage whose teeth and shafts
# bend) has its flanks meet through a spring in the joint's band, not a stiff contact: tried
# around the stiff contact's best width (compliant_gears).  The spring may lie above the
# comparison band (up to SOFT_BAND x its edge): each meeting of the flanks kicks it, and what
# the kick leaves shows inside the band (12 Hz springs in j1's and j3's 10 Hz bands, tuning
# seeds 1726, 1741)
SOFT_HZ_MIN = 1.0
SOFT_BAND = 2.0
SOFT_GAIN, SOFT_LEFT = 1.2, 0.5
# ...searched only when the stiff contact already explains this share (0.25-0.83 on the
# compliant gears of tuning seeds 1726-1764): the search is some 1,400 gear runs, most of a
# 60 s record's analysis on a record with no gear at all
SOFT_MIN_STIFF = 0.15
SOFT_DAMPINGS = (0.05, 0.1, 0.2, 0.4)
# ...and only with play that matters: the same spring without it (its load refitted) must
# leave this much more error.  A 4 Hz spring with no play (j2, tuning seed 1806) was fitted as
# 3 µrad of play in front of it: 1.01x; 1.5-3 mrad of play before 5-12 Hz springs, 7.6-26x
# (independent simulator, tuning seeds 1726, 1773, 1776)
PLAY_MATTERS = 1.5


def compliant_gears(ctx: Context, pick: tuple) -> list[tuple]:
    """At most two (width, spring frequency, damping, kappa) of a compliant gear around
    ``pick``'s width (a stiff contact's), each explaining ``SOFT_GAIN`` times the share or
    leaving ``SOFT_LEFT`` of what the stiff one leaves (j3, seed 1741: 0.96 against 0.80)."""
    c = ctx.data.c
    lo, hi = max(2.0 * c.frequency, SOFT_HZ_MIN), min(SOFT_BAND * c.cutoff, CONTACT_HZ_RANGE[0])
    if hi <= lo:
        return []
    w0, _, _, k = pick
    if k > 0:       # with friction beyond the gear: not handled
        return []
    score = gear_scorer(ctx)
    stiff = score(pick)
    if stiff < SOFT_MIN_STIFF:
        return []
    # (the spring winds up beyond the play, so a stiff contact's width comes out wide: 4.0
    # mrad for 2.5 behind a 5 Hz spring on j4, seed 1764)
    grid = [(w0 * fw, f, z, k) for fw in np.geomspace(0.5, 1.25, 13)
            for f in np.geomspace(lo, hi, 20) for z in SOFT_DAMPINGS]
    # a lightly damped spring rattles in the gap: the score is sharp in all three, so the
    # best few of the coarse grid are refined on a local one (j3, seed 1763: 9 Hz, damping
    # 0.15, between the coarse grid's points); the two best, as the grid's score on the
    # baseline's residual can rank a neighbouring optimum first (j2, seed 1744: 9 Hz for 8)
    coarse = sorted(((score(g), g) for g in grid), key=lambda s: -s[0])[:3]
    refined = []
    for sc, (w, f, z, _) in coarse:
        local = [(w * a, f * b, z * d, k) for a in np.geomspace(0.94, 1.06, 5)
                 for b in np.geomspace(0.88, 1.13, 5) for d in np.geomspace(0.6, 1.6, 5)]
        refined.append(max([(sc, (w, f, z, k))] + [(score(x), x) for x in local], key=lambda s: s[0]))
    out = []
    for sc, g in sorted(refined, key=lambda s: -s[0]):
        if not (sc > SOFT_GAIN * stiff or 1.0 - sc < SOFT_LEFT * (1.0 - stiff)):
            continue
        if all(abs(g[0] / o[0] - 1) > 0.03 or abs(g[1] / o[1] - 1) > 0.05 for o in out):
            out.append(g)
    return out[:2]


def compliant(values: dict) -> bool:
    """Do these values (or a variant's) describe a compliant gear, a spring below a contact's?
    A contact pinned at the range's soft edge is one too: 0.004 mrad of "play" before a 20 Hz
    contact was a 14 Hz spring with 40 % of the friction beyond it (j4, independent
    simulator, tuning seed 1972), and its play must matter like a compliant gear's."""
    return values.get("bl_contact", terms.CONTACT_HZ) < 1.01 * CONTACT_HZ_RANGE[0]


def play_matters(values: dict, ctx: Context) -> float:
    """How much more error the fitted compliant gear leaves with its play taken out (the same
    spring, the load's inertia refitted): 1 when the play is not measured."""
    data, m = ctx.data, ctx.data.mask
    lugre = {k: values[k] for k in LUGRE_KEYS}
    lugre["delta"] = values.get("delta", 1.0)
    spring = (values["bl_contact"], values["bl_contact_damping"], values.get("bl_kappa", 0.0))
    with_play = gear_unit_term(data, lugre, values["bl_width"], *spring)[m]
    without = gear_unit_term(data, lugre, 0.0, *spring)[m]
    r = ctx.residual[m]
    y = r + values["bl_load"] * with_play
    tt = float(without @ without)
    left = y - (float(without @ y) / tt if tt > 0 else 0.0) * without
    return float(np.sqrt(np.mean(left ** 2)) / max(np.sqrt(np.mean(r ** 2)), 1e-300))


def _contact_params(init: dict, hz: tuple[float, float]) -> list[Param]:
    """The flanks' contact (or a compliant gear's spring) within ``hz``, and its damping."""
    return [Param("bl_contact", init.get("bl_contact", terms.CONTACT_HZ), log=True,
                  lo=math.log(hz[0]), hi=math.log(hz[1])),
            Param("bl_contact_damping", init.get("bl_contact_damping", terms.CONTACT_DAMPING), log=True,
                  lo=math.log(CONTACT_DAMPING_RANGE[0]), hi=math.log(CONTACT_DAMPING_RANGE[1]))]


class Backlash(GearEffect):
    name = "backlash"
    signals = ("travel_since_reversal",)
    summary = "dead zone in the gear between motor and load"
    # the width is searched, the contact between the flanks refined by the joint fit from the
    # virtual joint's (terms.CONTACT_HZ, CONTACT_DAMPING): a real mesh rings (an independent
    # simulator's 60 Hz, damping 0.15 contact left 0.4 % of Fc structured beside 2 mrad of
    # backlash with the friction beyond it, none once fitted)
    hyper = ("bl_width", "bl_kappa", "bl_contact", "bl_contact_damping", "bl_motor", "bl_joint")
    load_key = "bl_load"
    kappa_key = "bl_kappa"

    def variants(self, ctx: Context) -> list[dict]:
        # a geared joint's play is a small fraction of its travel: 0.03 % to 3 %
        span = float(np.ptp(ctx.data.c.q_full))
        widths = [f * span for f in np.geomspace(3e-4, 3e-2, 13)]
        if ctx.data.load_encoder:
            # (the joint's inertia rides along, unscreened, to bound the motor's share)
            return [{"bl_width": w, "bl_motor": m, "bl_slip": 0.0, "bl_joint": ctx.inertia}
                    for w, m in best_gaps(ctx, widths)]
        grid = [(w, 0.0, 0.0) for w in widths]
        picks = best_gears(ctx, grid)
        out = [dict({"bl_width": w, "bl_load": 0.0, "bl_kappa": k},
                    **({"bl_contact": terms.CONTACT_HZ, "bl_contact_damping": terms.CONTACT_DAMPING} if k > 0 else {}))
               for w, _, _, k in picks]
        for w, f, z, k in compliant_gears(ctx, picks[0]) if picks else []:
            out.append({"bl_width": w, "bl_load": 0.0, "bl_kappa": k, "bl_contact": f, "bl_contact_damping": z})
        return out

    def params(self, init):
        if "bl_motor" in init:      # seen from the load: the motor's inertia drives the lead
            M = init["bl_joint"]
            return [Param("bl_width", init["bl_width"], log=True),
                    Param("bl_motor", init["bl_motor"], log=True, lo=math.log(MOTOR_SHARE[0] * M),
                          hi=math.log(MOTOR_SHARE[1] * M))]
        out = [Param("bl_width", init["bl_width"], log=True), self.load_param(init)] + self.kappa_params(init)
        if compliant(init):     # (compliant_gears): its spring is what the fit is after
            return out + _contact_params(init, (SOFT_HZ_MIN, CONTACT_HZ_RANGE[0]))
        if init.get(self.kappa_key, 0.0) > 0:
            # with friction beyond the gear the load sticks and the contact's ringing shows;
            # with all of it on the motor the contact is flat in the fit, and a flat direction
            # unsettles the held-out scoring's linear correction (j2, test seed 5090: 0.70 in
            # sample, 24.6 held out): the virtual joint's contact is kept there
            out += _contact_params(init, CONTACT_HZ_RANGE)
        return out

    def direct_estimate(self, ctx: Context) -> dict | None:
        # seen from the load: LuGre as fitted in contact (load_side.gap_friction), and the
        # motor's inertia at half the joint's (the geared presets' share) beside the grid's
        # pick.  From the screened values alone j2 (tuning seed 1518) settled at Fc -2 % and
        # 5 % of the inertia with structure left, where the contact fit leaves 0.1 % of Fc
        if not ctx.data.load_encoder:
            return None
        lugre = gap_friction(ctx.data)
        return {**{k: lugre[k] for k in LUGRE_KEYS}, "bl_motor": 0.5 * ctx.inertia}

    def credible(self, values, ctx):
        if "bl_motor" in values:    # (its share is bounded in the fit)
            return True
        if compliant(values):
            # a compliant gear's spring as a gear spring's (joint_flexibility): near the
            # comparison band, and ringing rather than a smooth low-pass
            if values["bl_contact"] > SOFT_BAND * ctx.data.c.cutoff or values["bl_contact_damping"] > MAX_DAMPING:
                return False
        return self.gear_credible(values, ctx)

    def holds(self, values, ctx):
        return not compliant(values) or play_matters(values, ctx) >= PLAY_MATTERS

    def apply(self, values, extra, ev):
        extra["backlash"] = values["bl_width"]
        if "bl_motor" in values:        # seen from the load (bench.fitting.predict)
            extra["motor_inertia"] = values["bl_motor"]
            # the term's share: screened from 0, not a fitted parameter, so 1 once refitted
            extra["gap_slip"] = values.get("bl_slip", 1.0)
            return
        extra["load_inertia"] += values["bl_load"]
        extra["contact_frequency"] = values.get("bl_contact", 0.0)
        extra["contact_damping"] = values.get("bl_contact_damping", 0.0)
        self.apply_kappa(values, extra)

    def evidence(self, values, explained, ctx):
        w = values["bl_width"]
        if "bl_motor" in values:
            return self.load_side_evidence(values, explained, ctx)
        return (f"backlash of {format_angle(w, ctx.position_unit)}: each time the gear's torque "
                f"reverses the motor turns {format_angle(w, ctx.position_unit)} before the load "
                f"follows ({self.load_share(values, ctx)}{self.friction_text(values)}{self.contact_text(values)}); "
                f"check the gear's play and preload; "
                f"{explained_text(explained)}")

    def load_side_evidence(self, values, explained, ctx):
        w, motor = values["bl_width"], values["bl_motor"]
        angle = format_angle(w, ctx.position_unit)
        trade = width_inertia_trade(values, ctx)
        if trade < SEPARABLE:
            return (f"backlash seen from the load's encoder: each time the gear's torque reverses the load "
                    f"coasts while the motor crosses the gap; here the play and the motor's inertia trade "
                    f"off (doubling one and halving the other leaves as little as {trade:.2g}x the error), so "
                    f"the fitted {angle} with {motor:.3g} of the joint's {ctx.inertia:.3g} inertia on the "
                    f"motor is one of many; record the motor's encoder to measure the play; "
                    f"{explained_text(explained)}")
        share = motor / ctx.inertia
        # at a bound of its share the motor's inertia is not measured (under process noise it
        # ran to 2-3 % on tuning seeds 1561-1564 while the width stayed within 2 %)
        inertia = ("the motor's share of the inertia not resolved"
                   if share < 1.05 * MOTOR_SHARE[0] or share > 0.95 * MOTOR_SHARE[1]
                   else self.load_share(values, ctx))
        return (f"backlash of {angle}: each time the gear's torque reverses the motor turns {angle} "
                f"before the load follows (seen from the load's encoder: the load coasts meanwhile; "
                f"{inertia}); check the gear's play and preload; "
                f"{explained_text(explained)}")

    def contact_text(self, values) -> str:
        f, z = values.get("bl_contact", terms.CONTACT_HZ), values.get("bl_contact_damping", terms.CONTACT_DAMPING)
        if compliant(values):
            return (f"; the gear is compliant as well (joint_flexibility, one spring with the play): the "
                    f"flanks meet through a {f:.3g} Hz spring (locked rotor), damping ratio {z:.2g}, so keep "
                    f"the position loop's bandwidth well below it (about {f / 3:.2g} Hz)")
        if abs(f / terms.CONTACT_HZ - 1) < 0.2 and abs(z / terms.CONTACT_DAMPING - 1) < 0.2:
            return ""
        return f"; the flanks meet through a {f:.3g} Hz contact, damping ratio {z:.2g}"

    def inject(self, kw, ev, spec):
        check_known(kw, ("width", "load_fraction", "load_friction", "contact", "contact_damping"), self.name)
        w = number(kw, "width", self.name)
        if not w > 0:
            raise InputError("effect backlash: width must be positive")
        ev[terms.BACKLASH] = w
        if "contact" in kw or "contact_damping" in kw:
            # the flanks meet through a spring of their own (a flexibility's slots; one spring)
            f = number(kw, "contact", self.name, terms.CONTACT_HZ)
            z = number(kw, "contact_damping", self.name, terms.CONTACT_DAMPING)
            if not (f > 0 and 0 < z < 5):
                raise InputError("effect backlash: contact must be a positive frequency [Hz] and "
                                 "contact_damping a damping ratio in (0, 5)")
            if ev[terms.FLEX_FREQ] > 0:
                raise InputError("effect backlash: give the contact or a joint_flexibility, not both")
            ev[terms.FLEX_FREQ], ev[terms.FLEX_DAMP] = f, z
        self.inject_load(kw, ev)
        return {}
