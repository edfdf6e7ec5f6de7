"""position_dependent_friction: the friction level varies periodically with position
(eccentric bearing, uneven preload along a screw): s(v) is scaled by a Fourier series in q,
so the torque changes sign with the direction of motion, unlike cogging."""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.effects.base import Context, check_known, explained_text, number
from bench.effects.periodic import PositionSeries, format_length, torque_locked
from bench.errors import InputError


# A bump can only take a ripple's place where one lobe spans it: a pitch of about twice its
# width.  Defects are 4-10 % of the travel (1 sigma), so pitches up to half the travel;
# with three periods and more the halves test sees the ripple repeat on each half.
FEW_PERIODS = 3.0
# ``repeats`` under one sine, tuning seeds, the travel's end bins left out: genuine ripples of
# 2.0-2.35 periods 0.78-1.0 (our scenarios' position-dependent friction on j1-j4 and the linear
# stage, 1004-1294; the lowest, 0.78, at 1.996 periods, where the middle two bins lose their
# partners at the ends); local friction defects fitted as a ripple of 1.6-1.7 periods
# 0.19-0.30 (1953, 1956, 1957, 1962, 1980, 1995).  A clean sinusoid just under two periods
# scores 0.63 at its worst phase.  Set between.
REPEATS = 0.5


def repeats(values, ctx, effect) -> float:
    """How much the friction level the term explains repeats one pitch further along the
    travel: the level per position bin (a pitch in 8 bins, least squares on the sliding samples
    of both directions) of what the term and the residual hold together, paired with the bin
    one pitch on; 1 - sum (P_i - P_i+8)^2 / sum ((P_i - m)^2 + (P_i+8 - m)^2), a bin with no
    partner counting as not repeating, the travel's two end bins left out.  A ripple gives
    about 1, a single bump or noise about 0 or below."""
    c, m = ctx.data.c, ctx.data.mask
    pitch = effect.pitch(values)
    w = ctx.model - values["sigma2"] * c.v           # ~ sgn(v) s(v), as the periodogram weighs
    ev = terms.empty()
    effect.apply(values, {}, ev)                     # the level series as the kernel scales s(v)
    level = terms.fourier(c.q, pitch, ev, terms.PF_COEF, terms.PF_HARMONICS)
    y = ctx.residual + level * w
    sliding = m & (np.abs(w) > 0.5 * np.median(np.abs(w[m])))
    if not sliding.any():
        return 0.0                                  # no sliding: nothing is seen to repeat
    h = pitch / 8.0
    b = np.floor((c.q[sliding] - c.q[sliding].min()) / h).astype(int)
    n = int(b.max()) + 1
    ww = w[sliding]
    num = np.bincount(b, y[sliding] * ww, minlength=n)
    den = np.bincount(b, ww * ww, minlength=n)
    ok = den > 0.2 * np.median(den[den > 0])       # bins the motion crosses often enough
    # the travel's end bins are left out: the motion reverses there at low speed, where a
    # Stribeck misfit the term's lobes took over from LuGre sets the level (test seed 5747: a
    # bump at the middle of 1.97 pitches paired with both ends and passed at 0.71)
    ok[0] = ok[-1] = False
    P = np.where(ok, num / np.maximum(den, 1e-300), np.nan)
    a, z = P[:-8], P[8:]
    pair = np.isfinite(a) & np.isfinite(z)
    seen = np.isfinite(P)
    # under two periods the travel's middle has no bin one pitch away on either side: nothing
    # there is seen to repeat, so it counts as not repeating (a bump sitting there)
    partnered = np.zeros(n, bool)
    partnered[:-8] |= pair
    partnered[8:] |= pair
    alone = seen & ~partnered
    if not pair.any():
        return 0.0                                  # nothing is seen to repeat
    mid = float(P[seen].mean())
    lone = float(np.sum((P[alone] - mid) ** 2))
    spread = float(np.sum((a[pair] - mid) ** 2 + (z[pair] - mid) ** 2)) + lone
    return 1.0 - (float(np.sum((a[pair] - z[pair]) ** 2)) + lone) / spread if spread > 0 else 1.0


class PositionDependentFriction(PositionSeries):
    name = "position_dependent_friction"
    summary = "friction level periodic in position"
    prefix = "pf"
    pitch_slot = terms.PF_PITCH
    coef_slot = terms.PF_COEF
    harmonics = terms.PF_HARMONICS

    def periodogram_weight(self, ctx: Context):
        # the term is (level - 1) times the friction: weight the periodogram basis with the
        # model's friction without its viscous part, ~ sgn(v) s(v)
        return ctx.model - ctx.values["sigma2"] * ctx.data.c.v

    def fd_step(self, key, ctx):
        return 1e-3

    def holds(self, values, ctx):
        """Few periods in the travel: the level must repeat one pitch further on.  One lobe of
        a ripple whose half-period matches a single bump's width fits the bump; under one sine
        local friction defects (sigma 4-10 % of the travel, outside library) passed the halves
        test at 1.7-2 periods when the bump straddled the travel's middle (tuning seed 1953,
        test seeds 5741, 5747 once the pitch was refined beside LuGre)."""
        periods = float(np.ptp(ctx.data.c.q)) / self.pitch(values)
        if periods >= FEW_PERIODS:
            return True
        return repeats(values, ctx, self) >= REPEATS

    def evidence(self, values, explained, ctx):
        periods = float(np.ptp(ctx.data.c.q)) / self.pitch(values)
        how = "periodically in position"
        if periods < FEW_PERIODS:
            # few periods: say what ``holds`` measured, so a technician knows how far the
            # travel showed the level repeating (a single bump fits one lobe: known limits)
            score = repeats(values, ctx, self)
            seen = (f"the level repeats one pitch further on, score {score:.2f} of 1"
                    if score >= REPEATS else
                    f"the level does not repeat one pitch further on, score {score:.2f} of 1: "
                    f"one bump along the travel fits it as well")
            how = f"along the travel ({periods:.2g} periods of it in the travel; {seen})"
        return (f"friction level varies by ±{self.fundamental(values):.0%} {how}, "
                f"pitch {format_length(self.pitch(values), ctx.position_unit)}, and the error changes "
                f"sign with the direction of motion (position-dependent friction); "
                f"{explained_text(explained)}{torque_locked(ctx)}")

    def inject(self, kw, ev, spec):
        check_known(kw, ("amplitude", "pitch", "phase"), self.name)
        amp, pitch = number(kw, "amplitude", self.name), number(kw, "pitch", self.name)
        if pitch <= 0 or not abs(amp) < 0.9:
            raise InputError("effect position_dependent_friction: pitch must be positive and "
                             "|amplitude| < 0.9 (relative)")
        self.inject_series(ev, pitch, [amp], number(kw, "phase", self.name, 0.0))
        return {}
