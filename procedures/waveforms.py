"""Excitation waveforms: the unit torque of a trial as a function of its phase (in cycles).

``sine``       -cos(2 pi phase): the paper's test; starting at the negative peak centres the
               motion.  Every cycle repeats the same trajectory, so any mismatch locked to the
               cycle (a torque-dependent gain, a lag) is also locked to position and can pass
               for cogging or position-dependent friction.
``two_level``  the same sine whose amplitude alternates between 1 and ``ratio`` from one cycle to
               the next.  The switch happens at the torque's zero crossings (phase 1/4 + k),
               where the joint sits at an end of its swing: the torque stays continuous, the
               two lobes of a cycle share one amplitude (no net impulse, no drift), and a
               small cycle starts at an end of the large one's swing, so it stays inside the
               large one's excursion -- the workspace check of the sine still holds.  Each
               position is now crossed at two speeds and two torques, which breaks the cycle
               lock; the record still has one fundamental (weight (1 + ratio)/2 against
               sidebands at f/2 and 3f/2 of about (1 - ratio)/pi), so the analysis finds the
               cycles it deals into held-out folds.
"""
from __future__ import annotations

import math

import numpy as np

WAVEFORMS = ("sine", "two_level")


def check(kind: str, ratio: float, what: str = "waveform") -> None:
    from bench.errors import InputError
    if kind not in WAVEFORMS:
        raise InputError(f"{what} must be one of {', '.join(WAVEFORMS)}, got {kind!r}")
    if not 0.2 <= ratio <= 1.0:
        raise InputError(f"waveform ratio must be in [0.2, 1], got {ratio!r}")


def label(kind: str, ratio: float) -> str:
    """How records and reports name the waveform: "sine" or "two_level 0.6"."""
    return kind if kind == "sine" else f"{kind} {ratio:g}"


def level(phase, kind: str = "sine", ratio: float = 0.6):
    """Amplitude factor at ``phase`` (cycles since the start): 1, or ``ratio`` on every
    second cycle between torque zero crossings."""
    if kind == "sine":
        return np.ones_like(phase) if np.ndim(phase) else 1.0
    small = np.floor(np.asarray(phase) + 0.75) % 2 == 1
    return np.where(small, ratio, 1.0) if np.ndim(phase) else (ratio if small else 1.0)


def unit_torque(phase, kind: str = "sine", ratio: float = 0.6):
    """The waveform at ``phase`` with unit peak (scalar or array)."""
    if np.ndim(phase):
        return level(phase, kind, ratio) * -np.cos(2.0 * math.pi * np.asarray(phase))
    return level(phase, kind, ratio) * -math.cos(2.0 * math.pi * phase)


def torque(amplitude: float, frequency: float, t: np.ndarray, kind: str = "sine", ratio: float = 0.6,
           ramp_cycles: float = 0.05) -> np.ndarray:
    """A whole excitation, with the search's smooth amplitude ramp over ``ramp_cycles``
    (``virtual_drives.joint.sine_torque`` for ``sine``)."""
    phase = np.asarray(t, float) * frequency
    env = np.clip(phase / ramp_cycles, 0.0, 1.0) if ramp_cycles > 0 else np.ones_like(phase)
    env = env * env * (3.0 - 2.0 * env)
    return amplitude * env * unit_torque(phase, kind, ratio)
