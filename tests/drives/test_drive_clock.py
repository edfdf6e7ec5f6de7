"""The real-time clock of an emulated drive: it advances its physics to the wall clock on
each host command and counts the periods it had to catch up.  Fed with explicit times here
(no sleeping), so the test is exact and fast."""
from __future__ import annotations

import numpy as np
import pytest

from drivers.joint_config import complete_joint
from virtual_drives import drive_core
from virtual_drives.drive_core import DriveCore

DT = 1e-3


def _core() -> DriveCore:
    j = complete_joint({"id": "q", "preset": "j3", "transport": "simulated",
                        "clock": "realtime", "control_period": DT})
    return DriveCore(j, clock="realtime", seed=3)


def _feed(core: DriveCore, arrivals: np.ndarray) -> None:
    for t in arrivals:
        core.catch_up(float(t), command=True)


def _arrivals(n: int, phase: float, jitter: float, seed: int = 0) -> np.ndarray:
    """Host commands one period apart, ``phase`` periods after the drive's grid, jittered."""
    rng = np.random.default_rng(seed)
    k = np.arange(1, n + 1)
    return 100.0 + (k + phase + rng.uniform(-jitter, jitter, n)) * DT


@pytest.mark.parametrize("phase", [0.0, 0.3, 0.45, -0.45])
def test_jittered_commands_on_time_are_no_overruns(phase):
    """Commands that come every period, whatever their phase against the drive's first
    command and with +-0.15 period of jitter, are on time: the drive's grid locks onto them."""
    core = _core()
    core.catch_up(100.0, command=True)            # the first command anchors the grid
    arrivals = _arrivals(3000, phase, 0.15)
    _feed(core, arrivals)
    assert core.overruns <= 2                     # at most while the grid locks on
    # the physics kept pace with the wall clock: one period per command, none lost or doubled
    assert abs(core.steps - 3000) <= 1


def test_a_late_command_is_counted_and_caught_up():
    core = _core()
    core.catch_up(100.0, command=True)
    arrivals = list(_arrivals(500, 0.0, 0.05))
    arrivals = arrivals[:200] + [t + 3 * DT for t in arrivals[200:]]   # the host stalls 3 periods
    _feed(core, np.array(arrivals))
    assert core.overruns == 3
    assert abs(core.steps - 503) <= 1


def test_without_the_grid_lock_edge_phase_jitter_reads_as_overruns(monkeypatch):
    """Why the lock exists: with it off, commands near a rounding edge of the drive's grid
    count hundreds of phantom overruns (and step the physics unevenly)."""
    monkeypatch.setattr(drive_core, "PLL_GAIN", 0.0)
    core = _core()
    core.catch_up(100.0, command=True)
    _feed(core, _arrivals(3000, 0.45, 0.15))
    assert core.overruns > 100
