"""Helpers of the API tests (imported by name: tests/api has no __init__.py, so that the
test modules never shadow the ``api`` package)."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass

import httpx

RUN_DEADLINE = 150.0     # s: no test waits longer for a run (a hang fails, it never blocks)
FINAL = ("succeeded", "failed", "cancelled", "interrupted")


@dataclass
class Live:
    url: str
    svc: object
    admin: str
    operator: str
    observer: str

    def client(self, key: str | None = None, timeout: float = 15.0) -> httpx.Client:
        headers = {"Authorization": f"Bearer {key}"} if key else {}
        return httpx.Client(base_url=self.url, headers=headers, timeout=timeout)


def wait_run(client: httpx.Client, run_id: str, deadline: float = RUN_DEADLINE, until=FINAL) -> dict:
    end = time.monotonic() + deadline
    while True:
        info = client.get(f"/runs/{run_id}").json()
        if info["state"] in until:
            return info
        if time.monotonic() > end:
            raise AssertionError(f"run {run_id} still {info['state']} after {deadline} s")
        time.sleep(0.25)


def sse_events(client: httpx.Client, path: str, stop=lambda ev: ev["event"] == "end", deadline: float = RUN_DEADLINE,
               on_event=None, params=None) -> list[dict]:
    """Read a server-sent event stream until ``stop(event)``; returns the events read."""
    events, cur = [], {}
    end = time.monotonic() + deadline
    with client.stream("GET", path, params=params, timeout=httpx.Timeout(10.0, read=30.0)) as r:
        assert r.status_code == 200, r.read()
        assert r.headers["content-type"].startswith("text/event-stream")
        for line in r.iter_lines():
            if time.monotonic() > end:
                raise AssertionError(f"SSE {path}: no end after {deadline} s")
            if line.startswith("event:"):
                cur["event"] = line[6:].strip()
            elif line.startswith("data:"):
                cur["data"] = json.loads(line[5:])
            elif line.startswith("id:"):
                cur["id"] = int(line[3:])
            elif line == "" and cur:
                events.append(cur)
                if on_event is not None:
                    on_event(cur)
                if stop(cur):
                    return events
                cur = {}
    return events
