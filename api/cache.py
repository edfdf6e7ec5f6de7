"""Answers to the technician's page's polls, kept in memory while the run store is unchanged.

Every open page polls ``/joints/{id}`` and ``/runs/{id}`` and streams ``/runs/{id}/events``;
most of those reads find the store as it was a moment ago.  ``StoreVersion`` says whether it
is: SQLite's ``PRAGMA data_version`` on a read-only connection of its own changes whenever
any other connection commits (this server's threads, a run's control process, a CLI), and
costs microseconds, so a handler can ask it on the event loop and go to a worker thread (and
the store) only when something was written.  Nothing is stale: an answer is reused only
while the store is exactly as it was when the answer was read.
"""
from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import anyio

from bench.compensation import get_compensation
from bench.errors import InputError


class StoreVersion:
    """``current()``: a number that changes whenever the store has changed; None when it
    cannot tell (then the caller reads the store)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._conn: sqlite3.Connection | None = None
        self._lock = threading.Lock()    # tests serve one app from several event loops

    def current(self) -> int | None:
        with self._lock:
            try:
                if self._conn is None:
                    # read-only and never in a transaction: it can neither block a writer nor
                    # be blocked for long (WAL readers do not wait for writers)
                    self._conn = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True,
                                                 timeout=0.05, isolation_level=None, check_same_thread=False)
                return int(self._conn.execute("PRAGMA data_version").fetchone()[0])
            except sqlite3.Error:
                self.close()
                return None

    def close(self) -> None:
        if self._conn is not None:
            try:
                self._conn.close()
            except sqlite3.Error:
                pass
            self._conn = None


def _stored_joint(store, joint_id: str) -> tuple[dict, dict | None]:
    """The joint's compensation switch and its model (the one compensation uses, else the
    newest), as plain dicts: a worker thread's store read."""
    comp = get_compensation(store, joint_id)
    m = None
    if comp.get("model_id"):
        try:
            m = store.get_model(comp["model_id"])
        except InputError:
            m = None
    if m is None:
        models = store.list_models(joint_id)
        m = models[0] if models else None
    model = None if m is None else {"id": m["id"], "run_id": m.get("run_id"), "created": m["created"],
                                    "parameters": {k: float(v) for k, v in m["params"].items()}}
    return comp, model


class JointCache:
    """Each joint's stored part (compensation switch, model) as of a store version."""

    def __init__(self, store, version: StoreVersion):
        self.store = store
        self.version = version
        self._stored: dict[str, tuple[int, dict, dict | None]] = {}

    async def stored(self, joint_id: str) -> tuple[dict, dict | None]:
        # the version is read before the store: a commit in between makes the next call
        # read again, never keeps an answer older than its version
        v = self.version.current()
        hit = self._stored.get(joint_id)
        if v is not None and hit is not None and hit[0] == v:
            return hit[1], hit[2]
        comp, model = await anyio.to_thread.run_sync(_stored_joint, self.store, joint_id)
        if v is not None:
            self._stored[joint_id] = (v, comp, model)
        return comp, model
