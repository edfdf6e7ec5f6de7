"""Run a test's independent record analyses two at a time.

The tests that hold a verdict to "at most one wrong in ten (or twenty)" analyse their records
one after another, and on the slowest records the time goes to numba kernels on one core (a
load carrying friction through a gear: 80 % of the 209 s j2's saturating torque constant took,
seed 5903).  Two worker processes run them side by side: the ten nonlinear-viscous records of
test_outside_library in 119 s against 203 s serially (2026-11-28), every report equal field by
field to the serial run's -- each is the same code on the same record.

Workers are spawned (forking a process whose OpenMP and BLAS pools are running can hang) and
run one BLAS/OpenMP thread each: left at the libraries' defaults (two threads a worker on two
cores) the pool was slower than the serial run (the ten position-spring records: 113 s against
74 s; 51 s with the limit).

``job`` must be a module-level function (it is pickled by name); each item is the tuple of its
arguments, plain data like its result.
"""
from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, TypeVar

T = TypeVar("T")

WORKERS = max(1, min(2, os.cpu_count() or 1))


def one_thread() -> None:
    """Worker initializer (and each xdist worker's, tests/conftest.py): one thread for the
    libraries loaded from here on (the environment is read when they load) and for any
    already loaded."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    from threadpoolctl import threadpool_limits
    threadpool_limits(1)


def map_records(job: Callable[..., T], items: Iterable[tuple]) -> list[T]:
    """``[job(*item) for item in items]``, ``WORKERS`` at a time, in order."""
    items = list(items)
    if WORKERS < 2 or len(items) < 2:
        return [job(*it) for it in items]
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(WORKERS, mp_context=ctx, initializer=one_thread) as pool:
        return list(pool.map(job, *zip(*items)))
