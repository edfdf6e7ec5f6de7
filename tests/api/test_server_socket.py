"""The socket `bench serve` listens on gives connections without Nagle's algorithm: with it,
a response's body waited behind its headers for the client's delayed ACK (~40 ms)."""
from __future__ import annotations

import asyncio
import socket

from api.server import listen


def test_accepted_connections_have_tcp_nodelay():
    async def main() -> int:
        accepted: asyncio.Future = asyncio.get_running_loop().create_future()

        class Proto(asyncio.Protocol):
            def connection_made(self, transport):
                s = transport.get_extra_info("socket")
                accepted.set_result(s.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))

        sock = listen("127.0.0.1", 0)
        server = await asyncio.get_running_loop().create_server(Proto, sock=sock)   # as uvicorn does
        try:
            _, w = await asyncio.open_connection("127.0.0.1", sock.getsockname()[1])
            nodelay = await asyncio.wait_for(accepted, 5)
            w.close()
            return nodelay
        finally:
            server.close()

    assert asyncio.run(main()) != 0
