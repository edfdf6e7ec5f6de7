"""Where a long analysis can be stopped by whoever started it.

An analysis fits for seconds to minutes with the joints parked (a load carrying friction
through a gear: 80 s for j1's saturating-torque-constant record, 2026-11-28).  A run cancelled
meanwhile -- by a technician, or by the death of the server that owned it -- used to finish
the fit first: 11-36 s after a kill -9 of the server, traced with py-spy.  The caller says
what "stop" means (``stoppable``); the fit asks at every residual evaluation
(``bench.fitting.fit``), a contextvar read against the milliseconds an evaluation costs,
the residual's held-out learner before each fold (``bench.predictability``, ~1 s a fold),
and ``analyze_record`` once more before it returns: a run stopped at any point of its
analysis keeps no model.
"""
from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from typing import Callable, Iterator

_SHOULD_STOP: ContextVar[Callable[[], bool] | None] = ContextVar("bench_should_stop", default=None)


class Stopped(BaseException):
    """Raised at a checkpoint once the caller asked to stop.  Not an ``Exception``: the
    analysis treats a failed refit (a ``BenchError``, a ``ValueError``) as a candidate that
    did not fit, and a stop must not pass for one."""


@contextmanager
def stoppable(should_stop: Callable[[], bool]) -> Iterator[None]:
    """Within this block (this thread or task), fits stop with ``Stopped`` once
    ``should_stop()`` is true."""
    token = _SHOULD_STOP.set(should_stop)
    try:
        yield
    finally:
        _SHOULD_STOP.reset(token)


def checkpoint() -> None:
    should_stop = _SHOULD_STOP.get()
    if should_stop is not None and should_stop():
        raise Stopped()
