"""A file without times: a drive's scope or a DAQ export writes its samples one row each and
states the rate once (``# sample_rate: 1000``, ``# sample_period: 0.001``, or the user's
``--sample-rate``).  Its rows are read at ``row / rate`` seconds.  A rate only stands in for a
time column that is not there: the file's own times, where it has them, are the better clock."""
from __future__ import annotations

import math

from bench.errors import InputError
from bench.records import column_index

RATE_KEYS = ("sample_rate", "sampling_rate", "rate_hz")
PERIOD_KEYS = ("sample_period", "sample_interval", "dt")


def sample_rate_of(option, meta: dict, mapping: dict, names: list, name: str, plain: bool) -> float | None:
    """The rows' rate [Hz] when the record's times come from it, else None."""
    t = mapping.get("t")
    has_t = column_index(t, names) is not None
    stated = _stated(meta, name)
    if option is not None:
        rate = _positive(option, "--sample-rate", name)
        if has_t:
            raise InputError(f"{name}: has a time column ({t!r}) and a sample rate was given: give one of them")
    elif stated is not None and not has_t:
        rate = stated
    else:
        return None
    if not plain:
        raise InputError(f"{name}: a sample rate gives times to a table's rows; this file's signals "
                         f"have times of their own (or a MATLAB file's): map them instead")
    return rate


def _stated(meta: dict, name: str) -> float | None:
    for key in RATE_KEYS:
        if key in meta:
            return _positive(meta[key], key, name)
    for key in PERIOD_KEYS:
        if key in meta:
            return 1.0 / _positive(meta[key], key, name)
    return None


def _positive(v, what: str, name: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name}: {what} must be a number, got {v!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise InputError(f"{name}: {what} must be positive, got {v!r}")
    return x
