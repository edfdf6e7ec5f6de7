"""numba's on-disk cache, stamped with every kernel file of this project, not only the
compiled function's own.

numba stamps a cached function with its own source file and does not see the kernels it
inlines from other files (numba's documented limit, "cache invalidation fails to recognise
changes in symbols defined in a different file"; numba PR #8396 was never merged).  Ours call
across files (``virtual_drives.physics.simulate`` -> ``bench.terms.motor_step`` ->
``bench.lugre.bristle_step``), so after a ``git pull`` that changed only ``terms.py`` an
editable install kept physics' old compiled loop: the virtual joint ran the old physics while
the fit ran the new.  Here numba's own locators are wrapped, for files of this project only,
and one digest of every kernel file joins the stamp: editing any kernel recompiles every
kernel once, and nothing else changes.

Kernel modules import ``njit`` from here, so the locator is in place before their first
decorator runs.  Without numba's ``CacheImpl`` (a release that renamed it) this does nothing,
and the old advice holds: delete the ``*.nbi``/``*.nbc`` caches after editing a kernel.
"""
from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

from numba import njit
from numba.core import caching

__all__ = ["njit"]

# the packages whose kernels call each other; tests/ keeps its independent simulator apart
_ROOTS = tuple(str(Path(__file__).resolve().parent.parent / name) for name in ("bench", "virtual_drives"))


@functools.cache
def kernels_digest() -> bytes:
    """SHA-256 over the source of every module that defines a kernel (a module counts once
    ``njit`` appears in it), read once per process: numba compiles or loads each kernel once."""
    h = hashlib.sha256()
    for root in _ROOTS:
        for path in sorted(Path(root).glob("*.py")):
            text = path.read_bytes()
            if b"njit" in text:
                h.update(str(path).encode() + b"\0" + text)
    return h.digest()


def _ours(py_file: str) -> bool:
    path = os.path.realpath(py_file)
    return any(os.path.dirname(path) == root for root in _ROOTS)


class KernelSetLocator:
    """numba's locator for the file, whose stamp also carries ``kernels_digest()``."""

    _inner_classes: list = []

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def get_source_stamp(self):
        return self._inner.get_source_stamp(), kernels_digest()

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _ours(py_file):
            return None
        for base in cls._inner_classes:
            inner = base.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner)
        return None


def _install() -> bool:
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if not isinstance(classes, list):
        return False
    if KernelSetLocator not in classes:
        KernelSetLocator._inner_classes = list(classes)
        classes.insert(0, KernelSetLocator)
    return True


INSTALLED = _install()
