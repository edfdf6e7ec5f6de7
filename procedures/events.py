"""A run as a stream of documents: ``start``, ``event``s, ``stop``.

Every document is a small JSON-able dict {run_id, seq, time, doc, name, data}.  An emitter
fans each document out to its sinks: the store (persistence), a caller's callback (the API's
SSE stream, a progress bar).  A sink that raises is dropped from that emitter, never allowed
to stop a moving joint mid-trial.  ``Cancel`` is the token a caller sets to stop a run.
"""
from __future__ import annotations

import logging
import threading
import time
from contextlib import contextmanager
from typing import Callable, Iterator

from bench.errors import BenchError

Sink = Callable[[dict], None]
log = logging.getLogger(__name__)


class Cancelled(BenchError):
    """The run was cancelled by its caller; the joints were stopped."""


class ProcedureFailed(BenchError):
    """A procedure could not complete for one joint; the message says why."""


class Cancel:
    """Cancellation token (thread-safe)."""

    def __init__(self):
        self._ev = threading.Event()
        self.reason = ""

    def set(self, reason: str = "cancelled by request") -> None:
        self.reason = reason
        self._ev.set()

    def is_set(self) -> bool:
        return self._ev.is_set()

    def check(self) -> None:
        if self._ev.is_set():
            raise Cancelled(self.reason)

    @contextmanager
    def during_fit(self) -> Iterator[None]:
        """Within this block a cancel stops the analysis at its next fit evaluation
        (``bench.checkpoint``) and is raised as ``Cancelled``; the record is already saved."""
        from bench.checkpoint import Stopped, stoppable
        try:
            with stoppable(self.is_set):
                yield
        except Stopped:
            raise Cancelled(self.reason) from None


class Emitter:
    def __init__(self, run_id: str, sinks: list[Sink] | None = None, first_seq: int = 0):
        self.run_id = run_id
        self.sinks = [s for s in (sinks or []) if s is not None]
        self.seq = first_seq

    def _send(self, doc: str, name: str | None, data: dict) -> dict:
        d = {"run_id": self.run_id, "seq": self.seq, "time": time.time(), "doc": doc,
             "name": name, "data": data}
        self.seq += 1
        for s in list(self.sinks):
            try:
                s(d)
            except Exception:  # a broken listener must not break a run
                log.exception("event sink failed; dropping it")
                self.sinks.remove(s)
        return d

    def start(self, **data) -> dict:
        return self._send("start", None, data)

    def event(self, name: str, **data) -> dict:
        return self._send("event", name, data)

    def stop(self, state: str, **data) -> dict:
        return self._send("stop", state, data)

    def child(self, run_id: str, first_seq: int = 0) -> "Emitter":
        return Emitter(run_id, list(self.sinks), first_seq)
