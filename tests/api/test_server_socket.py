"""``bench serve``'s own listening socket (``api.server.listen``) gives connections with Nagle
off, as uvicorn's own sockets have: uvicorn writes an answer's head and body separately, and
with Nagle on the body waited for the client's delayed ACK (40 ms on Linux) -- a poll of
/health took ~45 ms on an idle server, and the page benchmark's p99 sat at ~50 ms."""
from __future__ import annotations

import socket
import statistics
import time

from api_helpers import ServeProcess


def test_bench_serve_answers_polls_on_a_kept_connection_without_the_delayed_ack(tmp_path):
    srv = ServeProcess("macro4", tmp_path / "data")
    try:
        with socket.create_connection(("127.0.0.1", srv.port), timeout=10) as s:
            request = f"GET /health HTTP/1.1\r\nHost: 127.0.0.1:{srv.port}\r\n\r\n".encode()
            took = []
            for _ in range(15):        # back to back, as a page's Promise.all on one connection
                t0 = time.perf_counter()
                s.sendall(request)
                got = b""
                while b"\r\n\r\n" not in got:
                    got += s.recv(65536)
                head, body = got.split(b"\r\n\r\n", 1)
                length = int(next(ln.split(b":")[1] for ln in head.split(b"\r\n") if ln.lower().startswith(b"content-length")))
                while len(body) < length:
                    body += s.recv(65536)
                took.append(time.perf_counter() - t0)
                time.sleep(0.01)
        assert head.startswith(b"HTTP/1.1 200")
        # with Nagle on, every answer after the first few waited >= 40 ms
        assert statistics.median(took) < 0.025, [round(1e3 * t, 1) for t in took]
    finally:
        srv.stop()
