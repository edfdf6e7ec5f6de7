"""Bounded requests: a body-size cap enforced before the body is read (and so before any
auth work), and a bounded rate of requests without a valid key.

``BodyLimit`` is plain ASGI middleware: a declared ``Content-Length`` over the route's cap is
answered 413 at once, without reading a byte; a body streamed without one (chunked) is
counted as it arrives and refused the moment it passes the cap, so the server never holds
more than the cap.  Caps: ``/analyze`` takes a record (``MAX_UPLOAD``), everything else a
small JSON document.

``AuthFailures`` is a token bucket per client address, charged by every request that fails
authentication (no key, unknown key): past its burst such a client gets 429 until the bucket
refills.  A request with a valid key is never charged nor refused, so a technician's client
is never throttled by a script on the same address that keeps getting its key wrong.  The
budget (burst 200, 50/s) is far above what a person or the fuzz test produces.
"""
from __future__ import annotations

import threading
import time

from starlette.exceptions import HTTPException

MAX_UPLOAD = 20 * 1024 * 1024     # bytes: a 1 kHz record of a few hours (POST /analyze)
MAX_JSON = 64 * 1024              # bytes: every other body (a run request is < 1 kB)
UPLOAD_PATHS = ("/analyze",)


def body_cap(path: str) -> int:
    return MAX_UPLOAD if path in UPLOAD_PATHS else MAX_JSON


def _too_large(cap: int, got: int | None = None) -> HTTPException:
    size = f"{got} bytes" if got is not None else "more"
    return HTTPException(413, f"request body too large: {size} (limit {cap} bytes for this endpoint)")


class BodyLimit:
    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        cap = body_cap(scope.get("path", ""))
        length = None
        for name, value in scope.get("headers", ()):
            if name == b"content-length":
                length = value
                break
        if length is not None:
            try:
                n = int(length)
            except ValueError:
                return await _answer(send, 400, "Content-Length is not a number")
            if n > cap:
                return await _answer(send, 413, str(_too_large(cap, n).detail), close=True)
        seen = 0

        async def counted():
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > cap:      # raised inside the route: the app's 413 JSON answer
                    raise _too_large(cap)
            return msg

        return await self.app(scope, counted, send)


async def _answer(send, status: int, detail: str, close: bool = False) -> None:
    import json
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if close:       # the body we did not read is not worth receiving
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class AuthFailures:
    """Token bucket per client address for failed authentications."""
    BURST = 200          # failed requests a client may make at once
    RATE = 50.0          # per second, refilled: key guessing is hopeless anyway (256-bit keys)

    def __init__(self, burst: int = BURST, rate: float = RATE, max_clients: int = 4096):
        self.burst, self.rate, self.max_clients = burst, rate, max_clients
        self._buckets: dict[str, tuple[float, float]] = {}     # client -> (tokens, at)
        self._lock = threading.Lock()

    def charge(self, client: str) -> float | None:
        """One failed authentication of ``client``; None if within its budget, else the seconds
        until the next one would be."""
        now = time.monotonic()
        with self._lock:
            tokens, at = self._buckets.get(client, (float(self.burst), now))
            tokens = min(float(self.burst), tokens + (now - at) * self.rate)
            if len(self._buckets) >= self.max_clients and client not in self._buckets:
                self._buckets.clear()        # bounded memory: forget everyone (rare)
            if tokens < 1.0:
                self._buckets[client] = (tokens, now)
                return (1.0 - tokens) / self.rate
            self._buckets[client] = (tokens - 1.0, now)
            return None
