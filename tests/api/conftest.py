"""A real service for the API tests: uvicorn on 127.0.0.1 (free port) in a thread of this
process, a real SQLite store in a temporary directory, and the macro4 bench behind it on
emulated drives reached over the real CANopen / ODrive-serial stacks (VirtualBench +
drivers.registry.open_drive).  Clients are real httpx clients with timeouts.

One server per session keeps the suite short; each test uses its own joints and waits for
its runs to end, so the order of the tests does not matter.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass

import httpx
import pytest

from api.app import ServiceConfig, build_service, create_app
from api.server import serve_in_thread

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


@pytest.fixture(scope="session")
def live(tmp_path_factory):
    data = tmp_path_factory.mktemp("api-data")
    conf = ServiceConfig(bench="macro4", data_dir=data, transport="virtual", api_key="", shutdown_timeout=20.0)
    svc, admin_file = build_service(conf)
    admin = admin_file.read_text().strip()
    with serve_in_thread(create_app(conf, svc)) as url:
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {admin}"}, timeout=10) as c:
            operator = c.post("/keys", json={"role": "operator", "name": "tech"}).json()["key"]
            observer = c.post("/keys", json={"role": "observer", "name": "viewer"}).json()["key"]
        yield Live(url, svc, admin, operator, observer)
        svc.runs.shutdown(20.0)
    assert not svc.runs.handles, "runs still active after shutdown"


@pytest.fixture
def operator(live):
    with live.client(live.operator) as c:
        yield c


@pytest.fixture
def observer(live):
    with live.client(live.observer) as c:
        yield c


@pytest.fixture
def admin(live):
    with live.client(live.admin) as c:
        yield c
