"""Running the app on uvicorn: in the foreground (``bench serve``) or in a background thread
(tests, benchmarks) with a clean, bounded shutdown."""
from __future__ import annotations

import os
import socket
import sys
import threading
import time
from contextlib import contextmanager

import uvicorn

# The GIL is handed between threads every 5 ms by default.  The control loops run in their
# own processes now (api.run_child sets the same interval there); in the server a shorter
# interval keeps the e-stop handler and the runs' status relays prompt while handlers are busy.
SWITCH_INTERVAL = float(os.environ.get("BENCH_SWITCH_INTERVAL", "0.0005"))   # s; a tuning knob


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def uvicorn_config(app, host: str, port: int, log_level: str = "warning") -> uvicorn.Config:
    return uvicorn.Config(app, host=host, port=port, log_level=log_level, access_log=False,
                          timeout_graceful_shutdown=3, lifespan="on")


def listen(host: str, port: int) -> socket.socket:
    """The listening socket, bound now: a busy port is the caller's one-line error (OSError),
    not uvicorn's log and exit status 3."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # proto named: asyncio turns Nagle off (TCP_NODELAY) only on connections whose socket says
    # IPPROTO_TCP, and a proto-0 listener's connections say 0.  With Nagle on, uvicorn's two
    # writes per answer (head, body) waited for the client's delayed ACK: +40 ms per poll
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(2048)
    except OSError:
        sock.close()
        raise
    sock.set_inheritable(True)
    return sock


def serve_forever(app, host: str, port: int, log_level: str = "info", sock: socket.socket | None = None) -> None:
    sys.setswitchinterval(SWITCH_INTERVAL)
    uvicorn.Server(uvicorn_config(app, host, port, log_level)).run(sockets=[sock] if sock is not None else None)


@contextmanager
def serve_in_thread(app, host: str = "127.0.0.1", port: int | None = None, start_timeout: float = 30.0):
    """Yield the base URL of ``app`` served by uvicorn in a daemon thread; stop it on exit."""
    sys.setswitchinterval(SWITCH_INTERVAL)
    port = port or free_port(host)
    server = uvicorn.Server(uvicorn_config(app, host, port))
    server.install_signal_handlers = lambda: None      # not the main thread
    thread = threading.Thread(target=server.run, name="uvicorn", daemon=True)
    thread.start()
    deadline = time.monotonic() + start_timeout
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            server.should_exit = True
            raise RuntimeError("uvicorn did not start")
        time.sleep(0.02)
    try:
        yield f"http://{host}:{port}"
    finally:
        server.should_exit = True
        thread.join(60.0)
