"""The suite runs on pytest-xdist workers (the README's test command: ``-n auto``, two on
this machine), and the tests that time something against the wall clock run alone.

Most of the suite's time is analyses, CPU-bound on one core each (or a record pool of two),
and two workers run them side by side.  A ``solo`` test (a stop's latency, a watchdog, a drive
running in real time, a killed service's deadline, a browser's wait: everything in ``SOLO``)
must not share the cores with them: on a busy machine its deadlines measure the neighbour,
not the code.  So:

- the solo tests are moved to the front of the run (then the diagnosis's, the longest, then
  the rest, which fill the gaps at the end); xdist's ``load`` scheduling keeps that order on
  each worker;
- a lock shared by the run's workers (two ``flock`` files, writer-preferring) lets any number
  of other tests run together but a solo test only when nothing else runs.  A worker keeps it
  from one solo test to its next, so the solo tests run as blocks at the start;
- the controller checks at the end that no solo test overlapped another test.

(``--dist loadgroup`` would send them to one worker, but with pytest 9.2 xdist 3.8's groups
are not applied: it renames ``item._nodeid``, which pytest no longer reads.)

Without xdist (plain ``pytest``, or ``-n 0``) tests run one at a time and nothing is locked.
"""
from __future__ import annotations

import fcntl
import os
import time
from pathlib import Path

import pytest

from tests.record_pool import one_thread

_state: dict = {"run": None, "files": None, "held": None}


def pytest_configure(config):
    if hasattr(config, "workerinput"):
        # one BLAS/OpenMP thread a worker, as in the record pool: the verdict's learner and
        # BLAS otherwise start a thread per core in each worker, and with two workers on two
        # cores the spinning threads took a third of the CPU time as system time (top, 2026-11-28)
        one_thread()
    config.addinivalue_line("markers", "solo: times something against the wall clock; runs "
                                       "with no other test beside it (tests/conftest.py)")


# the folders whose tests start servers, drives or browsers and wait on them in real time
SOLO = ("tests/api/", "tests/drives/", "tests/procedures/")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.nodeid.startswith(SOLO):
            item.add_marker(pytest.mark.solo)
    items.sort(key=lambda it: 0 if it.get_closest_marker("solo")
               else 1 if it.nodeid.startswith("tests/diagnosis/") else 2)   # stable sort


def _files(config):
    """(turnstile, room): the run's two lock files, or None outside an xdist worker.  They sit
    in the run's temporary directory (each worker's basetemp is a folder of it), which pytest
    removes with its old runs."""
    if not hasattr(config, "workerinput"):
        return None
    if _state["files"] is None:
        run = _state["run"] = Path(config.option.basetemp).parent
        _state["files"] = tuple(os.open(run / f"solo-lock.{name}", os.O_RDWR | os.O_CREAT, 0o600)
                                for name in ("turnstile", "room"))
    return _state["files"]


def _log(item, solo: bool, start: float) -> None:
    """One line per test: when it ran (the system's monotonic clock, one for all processes)
    and whether it was solo; the controller checks them at the end (``pytest_sessionfinish``)."""
    if _files(item.config) is not None:
        with open(_state["run"] / f"solo-log.{item.config.workerinput['workerid']}", "a") as f:
            f.write(f"{start!r} {time.monotonic()!r} {int(solo)} {item.nodeid}\n")


def pytest_sessionfinish(session, exitstatus):
    """On the controller: a solo test that overlapped any other test fails the run (the lock
    is what the solo tests' deadlines rely on)."""
    if hasattr(session.config, "workerinput") or session.config.getoption("dist", "no") == "no":
        return
    run = session.config._tmp_path_factory.getbasetemp()
    spans = []
    for log in run.glob("solo-log.*"):
        for line in log.read_text().splitlines():
            a, b, solo, nodeid = line.split(" ", 3)
            spans.append((float(a), float(b), solo == "1", nodeid))
    spans.sort()
    clash = [(x[3], y[3]) for i, x in enumerate(spans) for y in spans[i + 1:]
             if y[0] < x[1] and (x[2] or y[2])]
    if clash:
        tw = session.config.get_terminal_writer()
        tw.line()
        tw.line(f"solo tests overlapped other tests: {clash[:3]}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def _acquire(config, solo: bool) -> None:
    files = _files(config)
    if files is None or _state["held"] == "solo":
        return
    turnstile, room = files
    # a solo test holds the turnstile while it waits for the room: no new test gets in
    # ahead of it, so it waits for the tests already running only
    fcntl.flock(turnstile, fcntl.LOCK_EX)
    fcntl.flock(room, fcntl.LOCK_EX if solo else fcntl.LOCK_SH)
    if not solo:
        fcntl.flock(turnstile, fcntl.LOCK_UN)
    _state["held"] = "solo" if solo else "shared"


def _release(config) -> None:
    files = _files(config)
    if files is None or _state["held"] is None:
        return
    turnstile, room = files
    fcntl.flock(room, fcntl.LOCK_UN)
    if _state["held"] == "solo":
        fcntl.flock(turnstile, fcntl.LOCK_UN)
    _state["held"] = None


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    solo = item.get_closest_marker("solo") is not None
    _acquire(item.config, solo)
    start = time.monotonic()
    try:
        yield
    finally:
        _log(item, solo, start)
        # a solo test keeps the room for the next solo test (the group runs as one block); a
        # shared test lets a waiting solo test in
        if not (solo and nextitem is not None and nextitem.get_closest_marker("solo")):
            _release(item.config)
