"""A kernel edited in one file reaches the cached kernels of other files that inline it.

numba alone keeps ``virtual_drives.physics.simulate`` compiled with the old
``bench.terms.motor_step`` / ``bench.lugre.stribeck_level`` when only those files change (its
cache is stamped with the function's own file).  Run on a copy of the two packages, in fresh
interpreters, as a ``git pull`` into an editable install would meet it.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# a joint at rest under a constant torque below Fs = 2, above Fc = 1: it sticks (presliding
# only) while Fc is 1; with Fc doubled and Fs unchanged it still sticks, so instead the edit
# halves the Stribeck level, and the joint breaks away and travels
PROBE = """
import numpy as np
from virtual_drives.physics import simulate
p = np.array([1.0, 2.0, 10.0, 1.0, 1e4, 100.0, 0.5])
from bench import terms
ev = terms.empty()
q, *_ = simulate(np.full(200, 1.5), 1e-3, 4, 0.1, p, ev, 0.0, 0.0, 0.0, 0.0)
print(repr(float(q[-1])))
"""


def _run(tree: Path) -> float:
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=tree, capture_output=True,
                         text=True, timeout=600, env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(tree)})
    assert out.returncode == 0, out.stderr[-2000:]
    return float(out.stdout.strip().splitlines()[-1])


def test_an_edit_to_an_inlined_kernel_recompiles_its_callers(tmp_path):
    for pkg in ("bench", "virtual_drives"):
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    stuck = _run(tmp_path)
    assert list((tmp_path / "virtual_drives" / "__pycache__").glob("physics.simulate-*.nbi")), \
        "simulate was not cached: the test would not test the cache"
    assert abs(stuck) < 1e-3          # presliding only

    lugre = tmp_path / "bench" / "lugre.py"
    text = lugre.read_text()
    head = "def stribeck_level(v, Fc, Fs, alpha, delta):\n"
    assert head in text, "stribeck_level's signature moved: update this test's edit"
    lugre.write_text(text.replace(head, head + "    Fc, Fs = 0.5 * Fc, 0.5 * Fs\n"))
    slid = _run(tmp_path)
    assert slid > 10 * abs(stuck) + 1e-2, (stuck, slid)   # the edited friction reached simulate

    # and an unchanged tree still loads it from the cache: the same answer again
    assert _run(tmp_path) == slid
