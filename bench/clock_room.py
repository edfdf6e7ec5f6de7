"""A merged stream's clock, known from its rows only to within a room: the offset inside it
fitted, and what is left of its uncertainty carried into the parameters'.

A stream merged onto another logger's rows (``bench.slow_stream``) shows each reading on the
first row at or after it; its own clock is a line through those windows, placed in the middle
of the room they leave it.  A clock in step with the rows leaves it most of a row: every
reading may be anywhere in that room, one steady offset between the stream and the rest,
which a joint whose torque and acceleration nearly cancel feels.  The rotary motor under a
6 Hz PID, its 200 Hz position 0.8 ms after the rows (independent simulator, tuning seed 1721):
Fc -55 % in the room's middle, reported determined (standard error 4 %); with the position
moved across the room, Fc -100 % ... +5 %.  The fit's own error tells the offset: it was
least 0.27-0.36 ms later (Fc -3 % ... +5 %), and for a 100 Hz torque 0.37 ms after the rows
(seed 1727) at the middle, where Fc was right (3000x and -63 % at the room's ends).  So
LuGre is fitted at five offsets across the room and at the least error's parabola; the record
goes on with the stream there.  The offset's uncertainty is where the error has grown by one
standard error's worth (the fit's effective samples), at least ``OFFSET_SE_ROWS``; the
parameters' change across it joins their standard errors, so a flat error over a sensitive
room leaves them undetermined.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.interpolate import CubicSpline

from bench.errors import InputError
from bench.fitting import LUGRE_KEYS
from bench.identify import Identification, identify, is_identifiable
from bench.reading_warnings import WHAT
from bench.records import Record


@dataclass
class ClockRoom:
    """Per column, the room [s], the offset fitted in it from its middle and that offset's
    standard error [s]; per LuGre value, the change across that error (None: not determined,
    a fit there refused)."""
    rooms: dict = field(default_factory=dict)
    offsets: dict = field(default_factory=dict)
    offset_se: dict = field(default_factory=dict)
    change: dict = field(default_factory=dict)

    def told(self, doc: dict) -> None:
        """The report ``doc`` with the offsets in its resampling and the change counted in its
        uncertainty, identifiable and warnings."""
        if not self.rooms:
            return
        newly = []
        for k in LUGRE_KEYS:
            se, d = doc["uncertainty"].get(k), self.change.get(k, 0.0)
            se = None if se is None or d is None else math.hypot(se, d)
            doc["uncertainty"][k] = se
            if doc["identifiable"].get(k) and not is_identifiable(doc["parameters"][k], se):
                doc["identifiable"][k] = False
                newly.append(k)
        if "filled_forward" in doc.get("resampling", {}):     # a copy: the record's reading stays
            doc["resampling"]["filled_forward"] = {
                col: dict(ff, **({"clock_offset_s": self.offsets[col], "clock_offset_se_s": self.offset_se[col]}
                                 if col in self.rooms else {}))
                for col, ff in doc["resampling"]["filled_forward"].items()}
        col = max(self.rooms, key=self.rooms.get)
        moved_by = (", ".join(f"{k} by {_share(self.change[k], doc['parameters'][k])}"
                              for k in ("Fc", "Fs", "sigma2")) if None not in self.change.values()
                    else "leaves the record not identifiable")
        doc["warnings"].append(
            f"the rows where the {WHAT[col]}'s readings show leave their instants {self.rooms[col] * 1e3:.2g} ms "
            f"of room: they were placed {self.offsets[col] * 1e3:+.2g} ms "
            f"from its middle, where the fit errs least (standard error {self.offset_se[col] * 1e3:.2g} ms); "
            f"moving them that much moves {moved_by}, counted in the uncertainty"
            + (f", so {', '.join(newly)} {'is' if len(newly) == 1 else 'are'} not determined by this "
               "record" if newly else ""))


def _share(change: float, value: float) -> str:
    if not value:
        return f"{change:.3g}"
    pct = 100.0 * change / abs(value)
    return f"{pct:.2g} %" if pct < 10 else f"{pct:.0f} %"


def rooms(rec: Record) -> dict:
    """Per column read between its readings on a clock of its own, the room [s] its rows leave
    it (``filled_forward`` gives a room to those alone)."""
    return {col: ff["clock_room_s"] for col, ff in rec.reading.get("filled_forward", {}).items()
            if ff.get("clock_room_s", 0.0) > 0.0}


def moved(rec: Record, col: str, d: float) -> Record:
    """``rec`` with column ``col`` read ``d`` [s] later (a spline through it: between the
    record's samples, as the stream's own readings were interpolated)."""
    x = np.asarray(getattr(rec, col), dtype=float)
    return replace(rec, **{col: CubicSpline(rec.t, x)(rec.t - d)})


# the offsets tried, as fractions of the room about its middle
GRID = (-0.5, -0.25, 0.0, 0.25, 0.5)
# The least error is not at the true offset exactly: the logger's chain (its jitter, the
# splines across it) biases it.  Found less true, in rows, on the jittered lossy logger
# (independent simulator, clocks in step 0.37-0.8 ms after the rows, tuning seeds 1720-1745):
# -0.05 to +0.07 on the linear stage, the rotary motor, j1-j3, -0.09 on the rotary motor's
# benchmark record (seed 7011, Fc -10 % against a standard error of 2.7 % from the offset's
# curvature alone), -0.15 for readings on their rows placed half a row early (1752); j4's
# error was flat (standard errors 0.2-0.3 of a row).  So the offset's standard error is at
# least a tenth of a row.
OFFSET_SE_ROWS = 0.1


def placed_in_room(ident: Identification, rec: Record, name: str
                   ) -> tuple[Identification, Record, ClockRoom]:
    """``ident`` and ``rec`` with each column on a clock of its own (``rooms``) moved to the
    offset in its room where LuGre's fit errs least, at the same band and inertia, and what
    is left of the offset's uncertainty (``ClockRoom``)."""
    out = ClockRoom(rooms=rooms(rec), change={k: 0.0 for k in LUGRE_KEYS})
    for col, room in out.rooms.items():
        fits = {0.0: ident}
        base = rec

        def at(d: float) -> Identification | None:
            if d not in fits:
                try:
                    fits[d] = identify(moved(base, col, d), inertia=ident.inertia,
                                       cutoff=ident.data.c.cutoff, name=name)
                except InputError:      # a probe (NotIdentifiable among them): refused there, not fatal
                    fits[d] = None
            return fits[d]

        grid = [f * room for f in GRID]
        err2 = np.array([_err(at(d)) ** 2 for d in grid])
        j = int(np.argmin(err2))
        i = min(max(j, 1), len(grid) - 2)
        three = slice(i - 1, i + 2)
        a, b, _ = np.polyfit(grid[three], err2[three], 2) if np.all(np.isfinite(err2[three])) else (0, 0, 0)
        best = grid[j]
        if a > 0:
            # the parabola's least, kept between the best point's neighbours
            near = float(np.clip(-b / (2 * a), grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]))
            if _err(at(near)) ** 2 < err2[j]:
                best = near
        fit = fits[best]
        # the offset's standard error: where the squared error has grown by its own share over
        # the fit's effective samples (one unit of chi-square); a flat error, the whole room
        n_eff = math.ceil(np.count_nonzero(fit.data.mask) / 3) * fit.result.n_eff_fraction
        se = math.sqrt(fit.result.rms ** 2 / (a * n_eff)) if a > 0 and n_eff > 0 else room
        se = min(max(se, OFFSET_SE_ROWS * rec.dt), room)
        out.offsets[col], out.offset_se[col] = float(best), float(se)
        for k in LUGRE_KEYS:
            out.change[k] = _change(fits, best, se, room, k, out.change[k])
        if best:
            ident, rec = fit, moved(base, col, best)
    return ident, rec, out


def _err(fit: Identification | None) -> float:
    return fit.result.rms if fit is not None else math.inf


def _change(fits: dict, best: float, se: float, room: float, k: str, before: float | None) -> float | None:
    """The largest change of LuGre value ``k`` from the fit at ``best`` to those ``se`` either
    side (interpolated between the offsets fitted, within the room); None where a fit in
    between was refused or ``before`` is None."""
    lo, hi = max(best - se, -0.5 * room), min(best + se, 0.5 * room)
    if before is None or any(f is None for d, f in fits.items() if lo <= d <= hi):
        return None
    ds = sorted(d for d, f in fits.items() if f is not None)
    vals = [fits[d].params.as_dict()[k] for d in ds]
    here = fits[best].params.as_dict()[k]
    return max(before, *(abs(float(np.interp(d, ds, vals)) - here) for d in (lo, hi)))
