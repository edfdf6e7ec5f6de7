"""Start one emulated drive per joint and hand back the joint dicts ``open_drive`` needs.

    with VirtualBench(joints, clock="lockstep") as vb:
        drive = open_drive(vb.joints[0])
        vb.drive("j1").inject("emcy")          # fault injection, inspection: .snapshot()

CANopen joints share one virtual CAN bus; serial joints get a pty each; "simulated" joints
pass through untouched (``drivers.simulated`` runs them in the host).  process="inproc"
keeps the emulators in this process (python-can ``virtual`` interface); "subprocess" runs
them in a child (``python -m virtual_drives.launch``) reached over a socketcand server on
127.0.0.1 and over ptys, and talks to it by JSON lines on its stdin/stdout.
"""
from __future__ import annotations

import itertools
import json
import os
import select
import subprocess
import sys

from bench.errors import InputError
from drivers.joint_config import CLOCKS, complete_joint
from virtual_drives.drive_core import DriveCore, Ticker

_CHANNELS = itertools.count()


class Emulators:
    """The drive side of a bench, in the current process."""

    def __init__(self, joints: list[dict], clock: str, control_period: float, seed: int,
                 socketcand: bool = False):
        if clock not in CLOCKS:
            raise InputError(f"clock must be one of {', '.join(CLOCKS)}, got {clock!r}")
        self.ticker = Ticker()
        self.drives: dict[str, tuple[DriveCore, object]] = {}
        self.joints: list[dict] = []
        self.network = None
        self.server = None
        self.channel = f"friction-bench-{os.getpid()}-{next(_CHANNELS)}"
        try:
            self._start(joints, clock, control_period, seed, socketcand)
        except BaseException:
            self.close()
            raise

    def _start(self, joints, clock, control_period, seed, socketcand) -> None:
        ids, nodes = set(), set()
        if socketcand and any(j.get("transport") == "canopen" for j in joints):
            from virtual_drives.socketcand_server import SocketcandServer
            self.server = SocketcandServer(self.channel)
        for i, raw in enumerate(joints):
            j = dict(raw)
            if j.get("id") in ids:
                raise InputError(f"joint id {j.get('id')!r} appears twice")
            ids.add(j.get("id"))
            j.update(clock=clock, control_period=control_period)
            transport = j.get("transport", "simulated")
            if transport == "canopen":
                j.setdefault("node_id", i + 1)
                j.update(interface="virtual", channel=self.channel)
                j = complete_joint(j)
                if j["node_id"] in nodes:
                    raise InputError(f"joint {j['id']!r}: node_id {j['node_id']} already used")
                nodes.add(j["node_id"])
                adapter = self._canopen_slave(j, clock, seed + i)
                if socketcand:
                    j.update(interface="socketcand", host=self.server.host,
                             port=self.server.port, channel=self.server.bus_name)
            elif transport == "serial":
                from virtual_drives.odrive_responder import OdriveResponder
                j = complete_joint({**j, "port": j.get("port") or "pty"})
                core = DriveCore(j, clock=clock, seed=seed + i)
                adapter = OdriveResponder(core)
                self.drives[j["id"]] = (core, adapter)
                j["port"] = adapter.path
            else:
                j = complete_joint(j)
                adapter = None
            if adapter is not None:
                self.ticker.cores.append(self.drives[j["id"]][0])
            if adapter is not None:       # hidden physics stays on the drive side
                j.pop("extra", None)
                j.pop("physics", None)
                j.pop("effects", None)
            self.joints.append(j)
        self.ticker.start()

    def _canopen_slave(self, j: dict, clock: str, seed: int):
        import canopen
        from virtual_drives.canopen_slave import Cia402Slave
        if self.network is None:
            self.network = canopen.Network()
            self.network.connect(interface="virtual", channel=self.channel,
                                 receive_own_messages=False)
        core = DriveCore(j, clock=clock, seed=seed)
        slave = Cia402Slave(core, self.network,
                            supported_modes=tuple(j.get("supported_modes", (10, 4))))
        self.drives[j["id"]] = (core, slave)
        return slave

    def inject(self, joint: str, fault: str, **args) -> None:
        self._get(joint)[1].inject(fault, **args)

    def clear(self, joint: str, fault: str) -> None:
        self._get(joint)[1].clear(fault)

    def snapshot(self, joint: str) -> dict:
        core, adapter = self._get(joint)
        snap = core.snapshot()
        if hasattr(adapter, "statusword"):
            snap.update(statusword=adapter.statusword(), nmt=adapter.node.nmt.state,
                        syncs=adapter.sync_count, mode=adapter.mode)
        return snap

    def _get(self, joint: str):
        try:
            return self.drives[joint]
        except KeyError:
            raise InputError(f"no emulated drive for joint {joint!r} (simulated joints have "
                             f"none)") from None

    def close(self) -> None:
        self.ticker.stop()
        for core, adapter in self.drives.values():
            adapter.close()
        if self.server is not None:
            self.server.close()
        if self.network is not None:
            self.network.disconnect()
        self.drives = {}


class DriveHandle:
    """Fault injection into and inspection of one emulated drive, in either process mode."""

    def __init__(self, call, joint: str):
        self._call, self.joint = call, joint

    def inject(self, fault: str, **args) -> None:
        """CANopen: drop_heartbeats, emcy(code), freeze_status, mute, late(delay), glitch(counts,
        samples).  Serial: mute, corrupt_checksum(count), late(delay, count), glitch, fault(code),
        garbage(count)."""
        self._call("inject", self.joint, fault=fault, args=args)

    def clear(self, fault: str) -> None:
        self._call("clear", self.joint, fault=fault)

    def snapshot(self) -> dict:
        return self._call("snapshot", self.joint)


class VirtualBench:
    def __init__(self, joints: list[dict], clock: str = "lockstep",
                 control_period: float = 0.001, seed: int = 0, process: str = "inproc",
                 start_timeout: float = 60.0):
        if process not in ("inproc", "subprocess"):
            raise InputError(f"process must be 'inproc' or 'subprocess', got {process!r}")
        self.spec = {"joints": [dict(j) for j in joints], "clock": clock,
                     "control_period": float(control_period), "seed": int(seed)}
        self.process = process
        self.timeout = start_timeout
        self.joints: list[dict] = []
        self._emu: Emulators | None = None
        self._child: subprocess.Popen | None = None

    def __enter__(self) -> "VirtualBench":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        if self.process == "inproc":
            self._emu = Emulators(**self.spec)
            self.joints = self._emu.joints
            return
        self._child = subprocess.Popen([sys.executable, "-m", "virtual_drives.launch"],
                                       stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                       env={**os.environ, "PYTHONUNBUFFERED": "1"})
        try:
            reply = self._rpc(self.spec, self.timeout)
        except BaseException:
            self.close()
            raise
        self.joints = reply

    def drive(self, joint: str) -> DriveHandle:
        return DriveHandle(self._call, joint)

    def _call(self, op: str, joint: str, **kw):
        if self._emu is not None:
            if op == "inject":
                return self._emu.inject(joint, kw["fault"], **kw["args"])
            if op == "clear":
                return self._emu.clear(joint, kw["fault"])
            return self._emu.snapshot(joint)
        return self._rpc({"op": op, "joint": joint, **kw}, 10.0)

    def _rpc(self, message: dict, timeout: float):
        child = self._child
        if child is None or child.poll() is not None:
            raise RuntimeError("the emulator process is not running")
        child.stdin.write((json.dumps(message) + "\n").encode())
        child.stdin.flush()
        if not select.select([child.stdout], [], [], timeout)[0]:
            raise TimeoutError(f"emulator process did not answer {message.get('op', 'start')!r} "
                               f"within {timeout:g} s")
        line = child.stdout.readline()
        if not line:
            raise RuntimeError("the emulator process exited")
        reply = json.loads(line)
        if not reply.get("ok"):
            raise (InputError if reply.get("kind") == "input" else RuntimeError)(reply["error"])
        return reply.get("value")

    def close(self) -> None:
        if self._emu is not None:
            self._emu.close()
            self._emu = None
        child, self._child = self._child, None
        if child is not None:
            try:
                child.stdin.close()          # EOF: the child shuts its drives down
                child.wait(5.0)
            except (OSError, subprocess.TimeoutExpired):
                child.kill()
                child.wait(5.0)
            child.stdout.close()


def _child_main() -> None:
    """Emulators in a child process: the first stdin line is the bench spec, the reply the
    completed joints; then one JSON request per line until EOF."""
    out = os.fdopen(os.dup(sys.stdout.fileno()), "w")
    sys.stdout = sys.stderr                   # nothing else may write on the protocol pipe

    def reply(ok: bool, value=None, error: str = "", kind: str = "") -> None:
        out.write(json.dumps({"ok": ok, "value": value, "error": error, "kind": kind}) + "\n")
        out.flush()

    emu = None
    try:
        for line in sys.stdin:
            msg = json.loads(line)
            try:
                if emu is None:
                    emu = Emulators(msg["joints"], msg["clock"], msg["control_period"],
                                    msg["seed"], socketcand=True)
                    reply(True, emu.joints)
                elif msg["op"] == "inject":
                    reply(True, emu.inject(msg["joint"], msg["fault"], **msg.get("args", {})))
                elif msg["op"] == "clear":
                    reply(True, emu.clear(msg["joint"], msg["fault"]))
                elif msg["op"] == "snapshot":
                    reply(True, emu.snapshot(msg["joint"]))
                else:
                    reply(False, error=f"unknown request {msg.get('op')!r}")
            except InputError as exc:
                reply(False, error=str(exc), kind="input")
            except Exception as exc:      # report, keep serving: the parent decides
                reply(False, error=f"{type(exc).__name__}: {exc}")
    finally:
        if emu is not None:
            emu.close()


if __name__ == "__main__":
    _child_main()
