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


class ServeProcess:
    """``bench serve`` in its own process (a new session, so a test can kill it alone) on a
    free loopback port; ``stop()`` ends it.  For what an in-thread server cannot show:
    kill -9 and restart, the server's own memory, its children."""

    def __init__(self, bench: str, data, extra: tuple = (), env: dict | None = None, start_timeout: float = 60.0):
        import os
        import subprocess
        import sys

        from api.server import free_port
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.data = data
        self.log = open(f"{data}.serve.log", "ab")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "bench.cli", "serve", "--bench", bench, "--data", str(data), "--port",
             str(self.port), "--log-level", "warning", "--no-pin-cpus", *extra],
            stdout=self.log, stderr=subprocess.STDOUT, env={**os.environ, "BENCH_API_KEY": "", **(env or {})},
            start_new_session=True)
        end = time.monotonic() + start_timeout
        while True:
            try:
                if httpx.get(f"{self.url}/health", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if self.proc.poll() is not None or time.monotonic() > end:
                self.stop()
                raise AssertionError(f"bench serve did not start: {open(self.log.name).read()[-2000:]}")
            time.sleep(0.1)
        self.admin = (data / "admin.key").read_text().strip() if (data / "admin.key").exists() else None

    def client(self, key: str | None = None, timeout: float = 15.0) -> httpx.Client:
        key = key or self.admin
        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {key}"} if key else {},
                            timeout=timeout)

    def stop(self, timeout: float = 30.0) -> None:
        import signal
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout)
            except Exception:
                self.proc.kill()
                self.proc.wait(5)
        self.log.close()
