"""Where the diagnosis starts when the LuGre fit ran a friction level to the edge of its search.

Identification keeps LuGre's least-squares optimum; physics outside LuGre can make that
optimum a level LuGre cannot hold.  j4 under PD with its encoder beyond a backlash of 3 mrad
or more: at each reversal the load rests while the motor crosses the gap, and the fit made
the bristles a spring there by running Fs to e^9 times its start (the bound of
``bench.identify._fit_lugre``'s search, 8200x the truth), with Fc 5 % high.  Screened against
that fit the backlash was never significant.  Section III's estimates read the levels off the
friction-velocity map itself, so the diagnosis also runs from them, and the final model with
the lower held-out error stands (``bench.analysis._diagnose``).  Tuning seeds 1503, 1505,
1830-1837 (j4, widths 2.8-5.0 mrad, in memory): the fit hit the bound on 9 of 10; backlash was
named on 6 of those 9 (widths within 1.1 %, Fc within 2.4 %, the error down to 0.22-0.28x),
on none before.  From CSV (1800-1809) j4 gained 1808 and 1809; j2, whose fit hit the bound
too, kept all it named (the fit's own diagnosis stood where it was better: 1808).
"""
from __future__ import annotations

from dataclasses import replace

from bench.fitting import LUGRE_KEYS, FitResult
from bench.identify import section3_complete

# a value within e^0.05 of a bound of the search sits on it (the solver stays strictly inside).
# Where measured (j4 and j2 from the load under PD, tuning 1830-1837) the fits' Fs sat either
# on the edge (e^9.0 from its start) or e^3.2-4.3 from it, none between
ON_BOUND = 0.05
# the levels Section III reads off the map; alpha and the bristles are not compared: a record
# that never traverses the Stribeck decay leaves alpha free to run (the report says so)
LEVELS = ("Fc", "Fs", "sigma2")


def levels_on_bound(res: FitResult) -> list[str]:
    """The friction levels the fit left on a bound of its search."""
    out = []
    for p in res.params:
        if p.name in LEVELS and p.log:
            x = p.to_x(res.values[p.name])
            if x >= p.hi - ON_BOUND or x <= p.lo + ON_BOUND:
                out.append(p.name)
    return out


def measured_start(res: FitResult, initial: dict) -> tuple[FitResult, str | None]:
    """``res``, or -- when it left a level on a bound and Section III estimated every LuGre
    value (``initial``) -- those estimates in its place, and the warning that says so."""
    pinned = levels_on_bound(res)
    if not pinned or not section3_complete(initial):
        return res, None
    ratios = ", ".join(f"{k} {res.values[k] / initial[k]:.3g}x" for k in pinned)
    note = (f"the LuGre fit ran {' and '.join(pinned)} to the edge of its search ({ratios} the "
            "value read off the friction-velocity map): LuGre alone cannot hold what the record "
            "shows, so the diagnosis started from Section III's estimates")
    return replace(res, values=dict(res.values, **{k: float(initial[k]) for k in LUGRE_KEYS})), note
