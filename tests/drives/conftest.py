"""Fixtures: a virtual bench (in this process, or in a child over socketcand and a pty) and
drives opened through the real driver stack.  Everything is closed at the end of a test."""
from __future__ import annotations

import time

import pytest

from drivers.registry import open_drive
from virtual_drives.launch import VirtualBench


@pytest.fixture(params=["inproc", "subprocess"])
def process(request):
    return request.param


@pytest.fixture
def rig(process):
    """rig(joints, **bench_kwargs) -> (bench, [drive, ...]), cleaned up afterwards."""
    opened: list = []

    def make(joints, open_all=True, **kw):
        kw.setdefault("clock", "lockstep")
        vb = VirtualBench(joints, process=process, **kw)
        vb.start()
        opened.append(vb)
        drives = []
        if open_all:
            for j in vb.joints:
                d = open_drive(j)
                opened.append(d)
                drives.append(d)
        return vb, drives

    yield make
    for thing in reversed(opened):
        try:
            thing.close()
        except Exception:
            pass


@pytest.fixture
def wait_for():
    return _wait_for


def _wait_for(predicate, timeout=5.0, what="condition"):
    """Poll (not a timing assertion: the deadline only keeps a broken test from hanging)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.01)
    raise AssertionError(f"timed out waiting for {what}")
