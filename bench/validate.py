"""Checks shared by every layer that reads user configuration (drivers, procedures)."""
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
