"""Load the compiled kernels once, in the forkserver that run processes fork from.

A numba kernel's first call in a process loads it from the on-disk cache and imports
numba's array support: ~0.3 s of mostly GIL-holding work.  Done in a run's own control
process, that stalled its e-stop listener by hundreds of milliseconds right after the run
started.  Imported (preloaded) by the forkserver (``api.run_process.PRELOAD``), every run
process inherits the loaded kernels.
"""
from __future__ import annotations

import numpy as np

from bench import terms
from bench.lugre import friction_trace
from virtual_drives.joint import VirtualJoint
from virtual_drives.presets import preset


def warm() -> None:
    vj = VirtualJoint(preset("j1"), dt=0.002)
    vj.advance(0.0, periods=1)
    vj.advance(0.0, periods=2)
    ones, x = np.ones(4), np.linspace(-0.1, 0.1, 4)
    ev = terms.empty()
    terms.effect_terms(x, x, x, ev)
    terms.damping(x, ev)
    friction_trace(x, 0.002, 0.0, 1.0, 1.2, 1.0, 1.0, 1e5, 10.0, 1.0, ones, ones, ones)


warm()
