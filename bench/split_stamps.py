"""Time stamped in two integer columns, as ROS messages stamp it: ``sec`` + ``nanosec``
(ROS 2's builtin_interfaces/Time) or ``secs`` + ``nsecs`` (ROS 1), which a bag's CSV export
keeps side by side (``header.stamp.sec``, ``header.stamp.nanosec``).  Neither alone is a clock:
whole seconds repeat a thousand times at 1 kHz, nanoseconds go back at every second.  Mapped
as ``t``, the seconds column stacked each second's rows on one instant."""
from __future__ import annotations

import numpy as np

PAIRS = (("sec", "nanosec"), ("secs", "nsecs"))
_SEPARATORS = (".", "_", "/")


def fraction_of(col: str, names: list) -> str | None:
    """The nanoseconds column beside a seconds column (``a.sec`` -> ``a.nanosec``), if any."""
    col = str(col)
    for sec, nsec in PAIRS:
        if col == sec or any(col.endswith(sep + sec) for sep in _SEPARATORS):
            other = col[:len(col) - len(sec)] + nsec
            if other in names:
                return other
    return None


def stamp_column(names: list) -> str | None:
    """With no time column: a seconds column with its nanoseconds beside it (a message
    header's stamp before any other)."""
    found = sorted((n for n in names if fraction_of(n, names)), key=lambda n: ("header" not in str(n), len(str(n))))
    return found[0] if found else None


def joined(sec: np.ndarray, nsec: np.ndarray) -> np.ndarray | None:
    """Seconds from the first stamp, or None when the pair is not one (fractions outside
    [0, 1e9) or not whole)."""
    sec, nsec = np.asarray(sec, dtype=float), np.asarray(nsec, dtype=float)
    ok = np.isfinite(sec) & np.isfinite(nsec)
    if not ok.any():
        return None
    s, n = sec[ok], nsec[ok]
    if np.any(n < 0) or np.any(n >= 1e9) or np.any(n != np.round(n)) or np.any(s != np.round(s)):
        return None
    # from the first stamp, before the fraction is added: epoch seconds (1.7e9) plus
    # nanoseconds in one float would keep only 0.24 us
    return (sec - s[0]) + (nsec - n[0]) * 1e-9
