"""The e-stop's answer comes once the latch is written (a client told "latched" finds it
latched after a crash), even while a run process holds the store's write lock for a while;
a store that stays locked delays the answer by ``KEEP_WAIT`` at most.  Real SQLite store;
the lock is held by another connection, as a run process's write would hold it."""
from __future__ import annotations

import sqlite3
import threading
import time

from api import safety
from api.safety import EStop
from bench.store import Store


def _hold_write_lock(path, seconds: float) -> threading.Thread:
    """Another connection takes the store's write lock for ``seconds``; returns once it holds it."""
    held = threading.Event()

    def hold():
        c = sqlite3.connect(path, isolation_level=None)
        c.execute("BEGIN IMMEDIATE")
        held.set()
        time.sleep(seconds)
        c.execute("COMMIT")
        c.close()
    t = threading.Thread(target=hold, daemon=True)
    t.start()
    assert held.wait(5)
    return t


def test_answer_waits_for_the_latch_write(tmp_path):
    store = Store(tmp_path)
    estop = EStop(store=store)
    holder = _hold_write_lock(store.path, 0.3)
    t0 = time.monotonic()
    estop.trigger("test")
    assert time.monotonic() - t0 >= 0.25                 # it waited for the lock ...
    assert Store(tmp_path).get_latch()["reason"] == "test"   # ... and the latch is on disk
    holder.join(5)


def test_a_store_locked_for_long_delays_the_answer_by_keep_wait_at_most(tmp_path, monkeypatch):
    monkeypatch.setattr(safety, "KEEP_WAIT", 0.2)
    store = Store(tmp_path)
    estop = EStop(store=store)
    holder = _hold_write_lock(store.path, 1.5)
    t0 = time.monotonic()
    assert estop.trigger("test")["active"] is True
    assert time.monotonic() - t0 < 1.0
    holder.join(5)
    deadline = time.monotonic() + 5                       # written once the lock is free
    while Store(tmp_path).get_latch() is None:
        assert time.monotonic() < deadline
        time.sleep(0.05)
