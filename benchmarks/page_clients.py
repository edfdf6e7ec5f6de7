"""The technician's pages' requests for bench_api.py --pattern page: light clients in their
own processes.

Real pages run in browsers on other machines: their HTTP costs the server's machine nothing,
and one page's work never waits for another's.  The benchmark's clients share the server's
machine, so they are made to cost it little and to wait for each other little:

* a minimal HTTP/1.1 client on asyncio streams (keep-alive connections per page, as a
  browser keeps them per origin; SSE read from the chunked body and counted by its
  ``event:`` lines).  httpx in one process cost ~3 ms of client CPU per request (SSE
  included; 2026-11-24, load average ~5), more than the server spent answering, all of it
  on the server's CPU; and it handled a page's four simultaneous answers one after the
  other, so the last of a page's four ``GET /joints/{id}`` measured ~15 ms where this
  client measures ~2.5 ms against the same server;
* ``procs`` worker processes, each running every ``procs``-th page: a slow moment of one
  event loop delays the requests of its pages only.

The workers keep the CPU placement the caller gives them (by default the server's CPU, so
that what the control loop sees under load is what the server costs it).
"""
from __future__ import annotations

import asyncio
import gc
import os
import resource
import time
from urllib.parse import urlsplit


class Page:
    """One page's connections to the server (a browser's keep-alive pool for one origin)."""

    def __init__(self, url: str, key: str):
        u = urlsplit(url)
        self.host, self.port = u.hostname, u.port
        self.head = (f"Host: {u.netloc}\r\nAuthorization: Bearer {key}\r\nAccept: */*\r\n").encode()
        self.idle: list = []

    async def _response_head(self, reader) -> tuple[int, dict]:
        raw = await reader.readuntil(b"\r\n\r\n")
        lines = raw.decode("latin-1").split("\r\n")
        status = int(lines[0].split(" ", 2)[1])
        headers = {}
        for line in lines[1:]:
            if ":" in line:
                k, v = line.split(":", 1)
                headers[k.strip().lower()] = v.strip()
        return status, headers

    async def get(self, path: str) -> int:
        """GET ``path``; its status (the body is read and dropped)."""
        conn = self.idle.pop() if self.idle else await asyncio.open_connection(self.host, self.port)
        reader, writer = conn
        try:
            writer.write(b"GET " + path.encode() + b" HTTP/1.1\r\n" + self.head + b"\r\n")
            status, headers = await self._response_head(reader)
            if "content-length" in headers:
                await reader.readexactly(int(headers["content-length"]))
            elif headers.get("transfer-encoding") == "chunked":
                while await self._chunk(reader):
                    pass
        except BaseException:
            writer.close()
            raise
        if headers.get("connection", "").lower() == "close":
            writer.close()
        else:
            self.idle.append(conn)
        return status

    @staticmethod
    async def _chunk(reader) -> bytes:
        size = int((await reader.readline()).split(b";")[0], 16)
        data = await reader.readexactly(size + 2)
        return data[:-2]

    async def events(self, path: str, on_event) -> int:
        """Read the event stream at ``path`` (its own connection, as the page's fetch() has)
        until the server ends it or the caller cancels; ``on_event()`` per event."""
        reader, writer = await asyncio.open_connection(self.host, self.port)
        try:
            writer.write(b"GET " + path.encode() + b" HTTP/1.1\r\n" + self.head.replace(
                b"Accept: */*", b"Accept: text/event-stream") + b"\r\n")
            status, headers = await self._response_head(reader)
            if status != 200:
                return status
            rest = b""
            while True:
                data = await self._chunk(reader)
                if not data:
                    return status
                lines = (rest + data).split(b"\n")
                rest = lines.pop()          # a line the next chunk completes
                for line in lines:
                    if line.startswith(b"event:"):
                        on_event()
        finally:
            writer.close()


async def pages_load(url: str, key: str, run_id: str, pages: list[int], total: int, joints: list[str],
                     poll: dict, start_at: float, seconds: float) -> dict:
    """Pages ``pages`` (indices out of ``total``): each polls /health; even ones watch the run
    (GET /runs/{id} + the event stream), odd ones show the bench (GET /joints/{id} per joint)."""
    lat: list[float] = []
    by_kind: dict[str, list[float]] = {}
    errors = 0
    sse_events = 0
    stop_at = start_at + seconds

    async def timed(page: Page, path: str):
        nonlocal errors
        t0 = time.perf_counter()
        try:
            ok = await page.get(path) == 200
        except (OSError, asyncio.IncompleteReadError, ValueError):
            ok = False
        lat.append(time.perf_counter() - t0)
        by_kind.setdefault(path.split("/")[1], []).append(lat[-1])
        errors += not ok

    async def every(page: Page, period_ms: float, offset: float, paths: list[str]):
        period = period_ms / 1e3
        await asyncio.sleep(max(0.0, start_at - time.monotonic()) + offset * period)   # pages were not opened in the same ms
        while time.monotonic() < stop_at:
            t0 = time.perf_counter()
            await asyncio.gather(*[timed(page, p) for p in paths])     # the page's Promise.all
            await asyncio.sleep(max(0.0, period - (time.perf_counter() - t0)))

    async def sse(page: Page):
        nonlocal sse_events, errors

        def count():
            nonlocal sse_events
            sse_events += 1
        await asyncio.sleep(max(0.0, start_at - time.monotonic()))
        try:
            async with asyncio.timeout(max(0.0, stop_at - time.monotonic())):
                errors += await page.events(f"/runs/{run_id}/events?after=-1&sample_hz={poll['sample_hz']:g}",
                                            count) != 200
        except TimeoutError:
            pass
        except (OSError, asyncio.IncompleteReadError, ValueError):
            errors += 1

    tasks = []
    for i in pages:
        offset = i / total
        polls, stream = Page(url, key), Page(url, key)
        tasks.append(every(polls, poll["health_ms"], offset, ["/health"]))
        if i % 2 == 0:
            tasks += [every(polls, poll["run_ms"], offset, [f"/runs/{run_id}"]), sse(stream)]
        else:
            tasks.append(every(polls, poll["joints_ms"], offset, [f"/joints/{j}" for j in joints]))
    await asyncio.gather(*tasks)
    return {"latencies": lat, "errors": errors, "sse_events": sse_events, "by_kind": by_kind}


def worker_init(cpus: set[int] | None) -> None:
    if cpus:
        os.sched_setaffinity(0, cpus)
    # allocations of the event loop would otherwise trigger full collections that pause all
    # of this worker's pages at once; a browser has no such shared pause
    gc.collect()
    gc.freeze()


def worker(*args) -> dict:
    """One worker's share of the pages (``pages_load``'s arguments); adds its CPU time."""
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    out = asyncio.run(pages_load(*args))
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    out["cpu"] = r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
    return out
