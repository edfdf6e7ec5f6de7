"""Checks shared by every layer that reads user input: configuration (drivers, procedures),
the numbers of a virtual record (``bench simulate``), records before they reach numerics."""
from __future__ import annotations

import math
from numbers import Real

from bench.errors import InputError


def config_number(value, what: str, positive: bool = True) -> float:
    """``value`` as a float if it is a finite number (booleans refused) and, unless
    ``positive`` is False, greater than zero; else InputError naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise InputError(f"{what} must be a number, got {value!r}")
    if positive and value <= 0:
        raise InputError(f"{what} must be positive, got {value!r}")
    return float(value)


# --- the boundary of `bench simulate` (and of any command that builds a virtual record) ------
MAX_SAMPLES = 10_000_000     # a record of 2.8 h at 1 kHz: ~0.5 GB while it is simulated
MAX_RATE = 1e6               # Hz
MAX_MAGNITUDE = 1e12         # any physical setting (torque, stiffness, inertia): far beyond any joint


def in_range(value, what: str, lo: float | None = None, hi: float | None = None,
             lo_open: bool = False) -> float:
    """``value`` as a finite float within [lo, hi] (``lo_open``: > lo); else InputError
    naming ``what`` and the value."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise InputError(f"{what} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise InputError(f"{what} must be a finite number, got {x!r}")
    if lo is not None and (x <= lo if lo_open else x < lo):
        raise InputError(f"{what} must be {'>' if lo_open else '>='} {lo:g}, got {x:g}")
    if hi is not None and x > hi:
        raise InputError(f"{what} must be <= {hi:g}, got {x:g}")
    return x


def simulate_settings(amplitude: float, frequency: float, duration: float, rate: float, seed: int,
                      torque_noise: float | None = None, encoder_resolution: float | None = None,
                      declared_inertia: float | None = None) -> None:
    """Every number of a virtual record, checked before anything is allocated or simulated."""
    in_range(rate, "--rate", 0.0, MAX_RATE, lo_open=True)
    in_range(duration, "--duration", 0.0, None, lo_open=True)
    n = duration * rate
    if n > MAX_SAMPLES:
        raise InputError(f"--duration {duration:g} s at --rate {rate:g} Hz is {n:.3g} samples "
                         f"(limit {MAX_SAMPLES:.0e}); shorten the record or lower the rate")
    if n < 10:
        raise InputError(f"--duration {duration:g} s at --rate {rate:g} Hz is under 10 samples")
    in_range(amplitude, "--amplitude", 0.0, MAX_MAGNITUDE, lo_open=True)
    in_range(frequency, "--frequency", 0.0, rate / 2, lo_open=True)    # below Nyquist
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise InputError(f"--seed must be an integer in 0..2^63-1, got {seed!r}")
    if torque_noise is not None:
        in_range(torque_noise, "--torque-noise", 0.0, MAX_MAGNITUDE)
    if encoder_resolution is not None:
        in_range(encoder_resolution, "--encoder-resolution", 0.0, 1.0, lo_open=True)
    if declared_inertia is not None:
        in_range(declared_inertia, "--declared-inertia", 0.0, MAX_MAGNITUDE, lo_open=True)


# friction parameters a LuGre joint can have: what must be positive, what may be zero
_FRICTION = {"Fc": True, "Fs": True, "alpha": True, "sigma0": True, "sigma1": False, "sigma2": False,
             "delta": True}


def friction_parameter(name: str, value: float) -> float:
    """One LuGre parameter (``--param``): finite, positive (σ1 and σ2 may be 0), bounded."""
    what = f"--param {name}"
    x = in_range(value, what, 0.0, MAX_MAGNITUDE, lo_open=_FRICTION.get(name, True))
    if name == "delta" and x > 10:
        raise InputError(f"{what} (the Stribeck exponent) must be <= 10, got {x:g}")
    return x


def finite_arrays(what: str, **arrays) -> None:
    """Refuse a result with a NaN or an infinity in it (never write a NaN-filled file)."""
    import numpy as np
    for name, a in arrays.items():
        if a is not None and not np.all(np.isfinite(np.asarray(a, dtype=float))):
            raise InputError(f"{what}: {name} is not finite (the settings make the simulation diverge)")


# --- records, before they reach the numerics (bench analyze, POST /analyze) -------------------
# Physical bounds in SI units (s, N·m or N, rad or m, kg·m² or kg): a record outside them is a
# unit mistake or a corrupted file, and its numbers would overflow or vanish in the fit.
# The analysis holds ~1.5 kB a sample at its peak (a 30-minute log at ~500 Hz, 886 k samples:
# 1.33 GB resident, 57 s; 2026-11-26): past this a log is cut, not swapped to death or killed.
MAX_ANALYSED = 4_000_000
# The step's upper bound: below 5 samples a second no friction record can show presliding or
# the Stribeck dip (the paper's 0.25 Hz sine would get 20 samples a cycle), while a logger
# counting milliseconds, read as seconds, steps by 1-10 "s".
RECORD_BOUNDS = {"step": (1e-7, 0.2), "tau": (1e-9, 1e12), "q": (1e-9, 1e6), "inertia": (1e-9, 1e12)}


def _time_unit_hint(step: float, given: float = 1.0) -> str:
    """The time unit that makes a too long step a logger's (100 kHz to 5 Hz), as a hint: a
    1e6 "s" step is a 1 ms step counted in ns (rostopic's %time).  ``given``: the factor a
    unit the user gave applied, so the hint reads the file's own numbers."""
    from bench.units import TIME_UNITS
    for unit, k in TIME_UNITS.items():     # s first: never within, the step being too long
        if 1e-5 <= step / given * k <= RECORD_BOUNDS["step"][1]:
            return f" (is t in ms, us or ns? in {unit} it is a {step / given * k * 1e3:.3g} ms step: --time-unit {unit})"
    return " (is t in ms, us or ns? give the time unit)"


def _repeats_hint(t) -> str:
    """Why a step reads 0 when the times repeat: their digits lost, as a float32 loses an
    epoch's (128 s steps at 1.7e9 s), or a CSV printed with too few digits."""
    import numpy as np
    t = np.asarray(t, dtype=float)
    distinct = np.unique(t)
    if len(distinct) > len(t) / 2:
        return ""
    gap = float(np.median(np.diff(distinct))) if len(distinct) > 1 else 0.0
    f32 = float(np.spacing(np.float32(np.max(np.abs(t)))))
    if len(distinct) > 1:       # their spacing says which
        lost = f" (a float32's, which keeps only {f32:.3g} s steps at this magnitude)" if abs(gap / f32 - 1) < 0.01 else ""
    else:
        lost = f" (a float32 keeps only {f32:.3g} s steps at this magnitude; a text export may have written too few)"
    apart = f", {gap:.3g} s apart" if len(distinct) > 1 else ""
    return (f" ({len(distinct)} distinct times in {len(t)} rows{apart}: the time lost its digits{lost}; "
            f"log it in float64 with all its digits, or counted from the logger's start)")


def record_magnitudes(rec, inertia: float | None = None, name: str = "record",
                      with_inertia: bool = True) -> None:
    """Finite columns within ``RECORD_BOUNDS``: the time step, the torque's largest magnitude,
    the position's range (the joint moved by more than 1e-9) and its largest magnitude, and
    the inertia (0 stands for a record whose torque is the friction already)."""
    import numpy as np
    cols = {"t": rec.t, "tau": rec.tau, "q": rec.q, "qd": rec.qd}
    for col, a in cols.items():
        if a is not None and (len(a) == 0 or not np.all(np.isfinite(a))):
            raise InputError(f"{name}: column '{col}' is empty or holds NaN or infinite values")
    if len(rec.t) > MAX_ANALYSED:
        span = float(rec.t[-1] - rec.t[0])
        raise InputError(f"{name}: {len(rec.t):.3g} samples ({span / 60:.3g} min) would need about "
                         f"{1.5e-6 * len(rec.t):.0f} GB to analyse (limit {MAX_ANALYSED:.0e} samples); "
                         f"analyse the part with the excitation: --window START:END (seconds)")
    lo, hi = RECORD_BOUNDS["step"]
    if len(rec.t) > 1:
        step = float(np.median(np.diff(rec.t)))
        if not lo <= step <= hi:
            given = rec.reading.get("units", {}).get("time", {}).get("factor", 1.0)
            hint = _time_unit_hint(step, given) if step > hi else _repeats_hint(rec.t)
            raise InputError(f"{name}: sample step {step:.3g} s is outside {lo:g}..{hi:g} s{hint}")
    lo, hi = RECORD_BOUNDS["tau"]
    peak = float(np.max(np.abs(rec.tau)))
    if not lo <= peak <= hi:
        raise InputError(f"{name}: torque peaks at {peak:.3g}, outside {lo:g}..{hi:g} N·m or N (unit mistake?)")
    lo, hi = RECORD_BOUNDS["q"]
    travel, far = float(np.ptp(rec.q)), float(np.max(np.abs(rec.q)))
    if travel == 0:
        raise InputError(f"{name}: position is constant: the joint never moved")
    if travel < lo or far > hi:
        raise InputError(f"{name}: position spans {travel:.3g} (largest |q| {far:.3g}); it must move by at least "
                         f"{lo:g} and stay within {hi:g} rad or m (unit mistake?)")
    m = inertia if inertia is not None else rec.meta.get("inertia")
    if m is not None and with_inertia:
        lo, hi = RECORD_BOUNDS["inertia"]
        try:
            mv = float(m)
        except (TypeError, ValueError):
            raise InputError(f"{name}: inertia is not a number: {m!r}") from None
        if not math.isfinite(mv) or mv != 0 and not lo <= mv <= hi:
            raise InputError(f"{name}: inertia {mv:.3g} is outside {lo:g}..{hi:g} kg·m² or kg")
