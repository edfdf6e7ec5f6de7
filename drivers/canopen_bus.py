"""One CAN bus seen from the host, shared by every CiA 402 drive on it: the python-canopen
``Network``, the SYNC producer and the host's heartbeat.

SYNC policy: every drive on a bus samples at the same SYNC, one SYNC per tick of the
host's period grid (``drivers.pacing.Pacer``).  Calling ``cycle`` on each joint of a bus in
turn is one round and costs one SYNC; lock-step drives advance one period per SYNC.
"""
from __future__ import annotations

import threading
import time

import canopen

from drivers.protocols import DriveError

SYNC_ID = 0x80
_BUSES: dict[tuple, "SharedBus"] = {}
_BUSES_LOCK = threading.Lock()


def _key(j: dict) -> tuple:
    return (j["interface"], str(j["channel"]), j.get("host"), j.get("port")
            if j["interface"] == "socketcand" else None)


class SharedBus:
    @classmethod
    def acquire(cls, joint: dict) -> "SharedBus":
        with _BUSES_LOCK:
            bus = _BUSES.get(_key(joint))
            if bus is None:
                bus = _BUSES[_key(joint)] = cls(joint)
            bus.users += 1
            bus.heartbeat_s = min(bus.heartbeat_s, joint["heartbeat_ms"] / 1000.0)
            return bus

    def __init__(self, j: dict):
        self.key = _key(j)
        self.users = 0
        self.clock = j["clock"]
        self.dt = float(j["control_period"])
        self.host_node_id = j["host_node_id"]
        self.heartbeat_s = j["heartbeat_ms"] / 1000.0
        kwargs = {"interface": j["interface"], "channel": j["channel"]}
        if j["interface"] == "socketcand":
            kwargs.update(host=j["host"], port=j["port"], tcp_tune=True)
        elif j["interface"] not in ("virtual",):
            kwargs["bitrate"] = j["bitrate"]
        self.network = canopen.Network()
        try:
            self.network.connect(**kwargs)
        except Exception as exc:  # python-can raises CanError, OSError, ImportError, ...
            raise DriveError(f"cannot open CAN interface {j['interface']!r} channel "
                             f"{j['channel']!r}: {exc}") from exc
        self.sync_lock = threading.Lock()
        self.sync_seq = 0
        self.last_sync = 0.0           # perf_counter of the last SYNC
        self.t0 = time.perf_counter()
        self.synced_tick = -1
        self.silent = False            # test hook: the host "dies" (no heartbeat, no SYNC)
        self._stop = threading.Event()
        self._hb = threading.Thread(target=self._heartbeat, daemon=True,
                                    name=f"host-heartbeat-{j['channel']}")
        self._hb.start()

    def _heartbeat(self) -> None:
        # our own producer (not python-can's periodic task) so every frame goes through
        # Network.send_lock: socketcand is a TCP stream shared with the cyclic frames
        while not self._stop.wait(self.heartbeat_s):
            self.beat()

    def beat(self) -> None:
        """One host heartbeat (state operational), unless the host plays dead."""
        if not self.silent:
            try:
                self.network.send_message(0x700 + self.host_node_id, b"\x05")
            except Exception:
                pass

    def sync_for(self, tick: int) -> int:
        """Send the SYNC of pacer tick ``tick`` unless it went out already; return the SYNC
        number whose answers the caller must wait for."""
        with self.sync_lock:
            if self.synced_tick < tick and not self.silent:
                self.synced_tick = tick
                self.sync_seq += 1
                self.last_sync = time.perf_counter()
                self.network.send_message(SYNC_ID, b"")
            return self.sync_seq

    def sync_now(self) -> int:
        """One extra SYNC now, outside the tick grid (the e-stop's confirmation: every drive
        on the bus answers with its statusword; a lock-step drive advances one period,
        torque off).  Returns its number."""
        with self.sync_lock:
            self.sync_seq += 1
            self.last_sync = time.perf_counter()
            self.network.send_message(SYNC_ID, b"")
            return self.sync_seq

    def release(self) -> None:
        with _BUSES_LOCK:
            self.users -= 1
            if self.users > 0:
                return
            _BUSES.pop(self.key, None)
        self._stop.set()
        self._hb.join(1.0)
        try:
            self.network.disconnect()
        except Exception:
            pass

