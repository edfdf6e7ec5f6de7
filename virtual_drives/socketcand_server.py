"""A socketcand-protocol server (raw mode) for a python-can ``virtual`` channel, so a host
in another process reaches emulated drives with python-can's ``socketcand`` interface.

Loopback only: the server refuses to bind anything but 127.0.0.1 / ::1.  Each TCP client
gets its own virtual-bus endpoint, so clients and emulators see each other as on one bus.

Protocol (https://github.com/linux-can/socketcand, raw mode), every message is "< ... >":
  server "< hi >"; client "< open <bus> >" -> "< ok >"; client "< rawmode >" -> "< ok >";
  then client "< send <id> <dlc> <byte> ... >" (hex) and server
  "< frame <id> <sec>.<usec> <hexdata> >"; "< echo >" is answered in kind.
python-can's client reads the handshake replies with single ``recv`` calls and compares
them whole, so the server waits a little after the last "< ok >" before streaming frames.
"""
from __future__ import annotations

import socket
import threading
import time

import can

LOOPBACK = ("127.0.0.1", "::1", "localhost")


class SocketcandServer:
    def __init__(self, virtual_channel: str, bus_name: str = "vcan0",
                 host: str = "127.0.0.1", port: int = 0):
        if host not in LOOPBACK:
            raise ValueError(f"socketcand server must stay on the loopback interface, not {host!r}")
        self.virtual_channel = virtual_channel
        self.bus_name = bus_name
        self.sock = socket.create_server((host, port))
        self.host, self.port = self.sock.getsockname()[:2]
        self._stop = threading.Event()
        self._sessions: list[_Session] = []
        self._thread = threading.Thread(target=self._accept, daemon=True,
                                        name="socketcand-accept")
        self._thread.start()

    def _accept(self) -> None:
        self.sock.settimeout(0.2)
        while not self._stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except socket.timeout:
                continue
            except OSError:
                return
            self._sessions = [s for s in self._sessions if s.alive]
            self._sessions.append(_Session(self, conn))

    def close(self) -> None:
        self._stop.set()
        self.sock.close()
        self._thread.join(2.0)
        for s in self._sessions:
            s.close()


class _Session:
    def __init__(self, server: SocketcandServer, conn: socket.socket):
        self.server = server
        self.conn = conn
        self.bus: can.BusABC | None = None
        self.alive = True
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._rx = threading.Thread(target=self._from_client, daemon=True, name="socketcand-rx")
        self._tx: threading.Thread | None = None
        self._rx.start()

    def _messages(self):
        buf = ""
        while self.alive:
            try:
                data = self.conn.recv(4096)
            except OSError:
                return
            if not data:
                return
            buf += data.decode("ascii", "replace")
            while True:
                start, end = buf.find("<"), buf.find(">")
                if start < 0 or end < 0:
                    break
                if end < start:             # stray '>' before a message: drop it
                    buf = buf[start:]
                    continue
                yield buf[start + 1:end].split()
                buf = buf[end + 1:]
            if len(buf) > 4096:
                buf = ""

    def _from_client(self) -> None:
        try:
            self.conn.sendall(b"< hi >")
            mode = "open"
            for words in self._messages():
                if not words:
                    continue
                if mode == "open" and words[0] == "open":
                    if len(words) != 2 or words[1] != self.server.bus_name:
                        self.conn.sendall(b"< error could not open bus >")
                        return
                    self.bus = can.Bus(interface="virtual", channel=self.server.virtual_channel,
                                       receive_own_messages=False)
                    self.conn.sendall(b"< ok >")
                    mode = "bcm"
                elif mode == "bcm" and words[0] == "rawmode":
                    self.conn.sendall(b"< ok >")
                    mode = "raw"
                    time.sleep(0.05)      # let the client read "< ok >" alone (see above)
                    self._tx = threading.Thread(target=self._to_client, daemon=True,
                                                name="socketcand-tx")
                    self._tx.start()
                elif mode == "raw" and words[0] == "send" and len(words) >= 3:
                    can_id = int(words[1], 16)
                    data = bytes(int(b, 16) for b in words[3:3 + int(words[2], 16)])
                    self.bus.send(can.Message(arbitration_id=can_id, data=data,
                                              is_extended_id=len(words[1]) > 3))
                elif words[0] == "echo":
                    self.conn.sendall(b"< echo >")
                else:
                    self.conn.sendall(b"< error unsupported command >")
        except (OSError, ValueError, can.CanError):
            pass
        finally:
            self.close()

    def _to_client(self) -> None:
        while self.alive:
            try:
                msg = self.bus.recv(0.2)
            except (can.CanError, AttributeError):
                return
            if msg is None or msg.is_error_frame:
                continue
            ident = f"{msg.arbitration_id:08X}" if msg.is_extended_id \
                else f"{msg.arbitration_id:03X}"
            line = f"< frame {ident} {msg.timestamp:.6f} {bytes(msg.data).hex().upper()} >"
            try:
                self.conn.sendall(line.encode("ascii"))
            except OSError:
                return

    def close(self) -> None:
        if not self.alive:
            return
        self.alive = False
        try:
            self.conn.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.conn.close()
        if self._tx is not None and self._tx is not threading.current_thread():
            self._tx.join(1.0)
        if self.bus is not None:
            self.bus.shutdown()
