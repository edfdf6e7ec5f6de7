"""A run's live event streams (``GET /runs/{id}/events``): one feed per run, shared by all of
its open streams.

Every open page on a run's live view holds a stream, each at its own sample rate.  Each used
to read the store in a worker thread at every tick (ten pages at 10 Hz: a hundred thread
hops and SQLite reads a second) and to encode every document for itself.  The run's
``RunFeed`` reads the store only when it has changed (``api.cache.StoreVersion``), once for
all its streams, and encodes each document, progress and sample once; a stream's tick is
then a few memory reads, and what it has to send goes out as one chunk.
"""
from __future__ import annotations

import asyncio
import bisect
import json
import time

import anyio
from fastapi import Request

from bench.store import FINAL

SSE_POLL = 0.2          # s between a stream's looks at the feed (at most; 1/sample_hz when faster)


def sse(event: str, data: dict, event_id: int | None = None) -> str:
    head = f"id: {event_id}\n" if event_id is not None else ""
    return f"{head}event: {event}\ndata: {json.dumps(data, default=str)}\n\n"


class RunFeed:
    """The run's documents as encoded events, read from the store as it changes."""

    def __init__(self, store, version, run_id: str):
        self.store, self.version, self.run_id = store, version, run_id
        self.seqs: list[int] = []      # the documents' sequence numbers, ascending
        self.texts: list[str] = []     # their events, encoded
        self.read_version: int | None = None
        self.read_once = False
        self.subscribers = 0
        self._lock = asyncio.Lock()    # one store read at a time; the others use its result
        self._progress: tuple[float | None, str] = (None, "")
        self._sample: tuple[object, str | None] = (None, None)

    def _stale(self, v: int | None) -> bool:
        return not self.read_once or v is None or v != self.read_version

    async def after(self, seq: int) -> tuple[int, str]:
        """(the newest sequence number, the encoded documents after ``seq``)."""
        if self._stale(self.version.current()):
            async with self._lock:
                v = self.version.current()      # before the read: a later commit reads again
                if self._stale(v):
                    last = self.seqs[-1] if self.seqs else -1
                    docs = await anyio.to_thread.run_sync(self.store.events, self.run_id, last)
                    for d in docs:
                        name = d["doc"] if d["doc"] in ("start", "stop") else (d["name"] or d["doc"])
                        self.seqs.append(d["seq"])
                        self.texts.append(sse(name, d, d["seq"]))
                    self.read_version, self.read_once = v, True
        i = bisect.bisect_right(self.seqs, seq)
        if i == len(self.seqs):
            return seq, ""
        return self.seqs[-1], "".join(self.texts[i:])

    def progress(self, value: float) -> str:
        if self._progress[0] != value:
            self._progress = (value, sse("progress", {"run_id": self.run_id, "progress": value}))
        return self._progress[1]

    def samples(self, handle) -> str | None:
        # the handle's dict is replaced by each status message from the run's process, never
        # changed in place: the same dict is the same event
        live = handle.live
        if live is not self._sample[0]:
            self._sample = (live, sse("sample", {"run_id": self.run_id, "samples": dict(live)}) if live else None)
        return self._sample[1]


def subscribe(svc, run_id: str) -> RunFeed:
    feed = svc.feeds.get(run_id)
    if feed is None:
        feed = svc.feeds[run_id] = RunFeed(svc.store, svc.version, run_id)
    feed.subscribers += 1
    return feed


def unsubscribe(svc, feed: RunFeed) -> None:
    feed.subscribers -= 1
    if feed.subscribers <= 0 and svc.feeds.get(feed.run_id) is feed:
        del svc.feeds[feed.run_id]


async def stream(request: Request, svc, run_id: str, after: int, sample_hz: float):
    """Documents from the store (the run's process writes them), the progress when it
    changes, and at most ``sample_hz`` live samples per second relayed by the run's process."""
    last, progress, next_sample, state = after, None, 0.0, None
    period = min(SSE_POLL, 1.0 / sample_hz) if sample_hz > 0 else SSE_POLL
    ending = False
    begun = after >= 0      # the run's start document has been sent (or the client has it)
    feed = subscribe(svc, run_id)
    try:
        while not getattr(request.app.state, "closing", False):
            newest, out = await feed.after(last)
            if newest != last:
                last, begun = newest, True
            if ending:
                yield out + sse("end", {"run_id": run_id, "state": state})
                return
            h = svc.runs.handles.get(run_id)
            if h is not None:
                if begun:           # before "start" its process is still starting: nothing to show
                    if h.progress != progress:
                        progress = h.progress
                        out += feed.progress(progress)
                    now = time.monotonic()
                    if sample_hz > 0 and now >= next_sample:
                        next_sample = now + 1.0 / sample_hz
                        out += feed.samples(h) or ""
            else:
                run = await anyio.to_thread.run_sync(svc.store.get_run, run_id)
                state = run["state"]
                # not (or no longer) ours: over, or queued by someone who never started it
                if state in FINAL or state == "queued":
                    ending = True      # one more read drains the documents written at the end
                    if out:
                        yield out
                    continue
            if out:
                yield out
            if await request.is_disconnected():
                return
            await asyncio.sleep(period)
    finally:
        unsubscribe(svc, feed)
