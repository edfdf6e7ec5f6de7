"""CPU placement and real-time priority of a control process (drivers.realtime), checked in
a child process so this one keeps its own scheduling."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from drivers import realtime

PROBE = r"""
import json, os, threading
from drivers import realtime
cpu = min(os.sched_getaffinity(0))
realtime.pin({cpu})
why_not = realtime.set_priority(int(os.environ["PRIO"]))
seen = {}
def later():              # a thread started afterwards inherits both
    tid = threading.get_native_id()
    seen.update(policy=os.sched_getscheduler(tid), cpus=sorted(os.sched_getaffinity(tid)))
t = threading.Thread(target=later); t.start(); t.join()
after = realtime.describe()
realtime.set_priority(0)
print(json.dumps({"why_not": why_not, "main": after, "thread": seen, "cpu": cpu,
                  "fifo": os.SCHED_FIFO, "back": realtime.describe()["policy"]}))
"""


def _probe(priority: int) -> dict:
    r = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=60,
                       env={**os.environ, "PRIO": str(priority)})
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="Linux scheduling calls")
def test_fifo_and_pinning_reach_every_thread_or_say_why_not():
    out = _probe(20)
    assert out["main"]["cpus"] == [out["cpu"]] and out["thread"]["cpus"] == [out["cpu"]]
    if out["why_not"] is None:
        assert out["main"] == {"policy": "fifo", "priority": 20, "cpus": [out["cpu"]]}
        assert out["thread"]["policy"] == out["fifo"]
        assert out["back"] == "normal"
    else:                    # no privilege: one line, and the process runs on unchanged
        assert os.geteuid() != 0
        assert "not permitted" in out["why_not"] and "\n" not in out["why_not"]
        assert out["main"]["policy"] == "normal"


@pytest.mark.parametrize("bad", [-1, 99, 1000])
def test_priority_out_of_range_is_refused(bad):
    with pytest.raises(ValueError, match="0 \\(off\\) to 98"):
        realtime.set_priority(bad)


def test_describe_a_process_that_is_gone():
    assert realtime.describe(2 ** 22 + 12345)["policy"] == "unknown"
