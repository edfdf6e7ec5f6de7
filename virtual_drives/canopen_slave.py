"""An emulated CiA 402 torque drive: a python-canopen ``LocalNode`` with the object
dictionary of ``od/cia402_torque.eds`` around a ``DriveCore``.

``LocalNode`` gives us the SDO server, NMT slave, heartbeat and EMCY producers.  It does not
apply received PDOs to the dictionary nor send TPDOs, so this module does both from the
PDO configuration the host wrote by SDO (0x1400/0x1600, 0x1800/0x1A00): RPDOs are decoded
as they arrive (target torque latched at the next SYNC in CST mode 10), TPDOs with a
synchronous transmission type are sent on SYNC.  The CiA 402 state machine runs in the
controlword write callback; the heartbeat consumer 0x1016 feeds the core's watchdog.
"""
from __future__ import annotations

import struct
import threading
import time
from pathlib import Path

import canopen

from drivers.protocols import DriveState
from virtual_drives.drive_core import FAULT_WATCHDOG, DriveCore

EDS_PATH = str(Path(__file__).with_name("od") / "cia402_torque.eds")
SYNC_ID = 0x80
EMCY_HEARTBEAT = 0x8130          # life guard / heartbeat error
EMCY_INJECTED = 0x2310           # continuous over-current, the default injected fault
# statusword of each CiA 402 state (bits 0-3, 5, 6), the remote bit 9 always set
_SW = {"SOD": 0x40, "RTSO": 0x31, "SO": 0x33, "OE": 0x37, "QSA": 0x17, "F": 0x08}
_FMT = {(8, False): "B", (16, False): "H", (32, False): "I",
        (8, True): "b", (16, True): "h", (32, True): "i"}
CAN_FAULTS = ("drop_heartbeats", "emcy", "freeze_status", "mute", "late", "glitch")


def _range(bits: int, signed: bool) -> tuple[int, int]:
    return (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)


def _clamp(x: int, lo: int, hi: int) -> int:
    return lo if x < lo else hi if x > hi else x


class Cia402Slave:
    def __init__(self, core: DriveCore, network: canopen.Network,
                 supported_modes: tuple[int, ...] = (10, 4)):
        self.core = core
        self.network = network
        self.node_id = core.joint["node_id"]
        self.cpu = float(core.joint["counts_per_unit"])
        self.rated = float(core.joint["rated_torque"])
        self.supported_modes = tuple(supported_modes)
        self.node = canopen.LocalNode(self.node_id, EDS_PATH)
        self.lock = threading.RLock()
        self.sub = "SOD"              # 402 sub-state while the core is DISABLED
        self.cw = 0
        self.mode = 0
        self.target = 0.0
        self.sync_count = 0
        self.faults: dict[str, dict] = {}
        self._frozen: list | None = None
        self._hb_producer = None
        self._rpdo: dict[int, tuple[struct.Struct, list]] = {}
        self._tpdo: list = []
        self._dirty = True
        d = self.node.data_store
        d[0x6076] = {0: struct.pack("<I", int(round(self.rated * 1000)))}
        d[0x6072] = {0: struct.pack("<H", _clamp(int(round(core.max_torque / self.rated
                                                               * 1000)), *_range(16, False)))}
        lo, hi = (int(round(x * self.cpu)) for x in core.limits)
        d[0x607D] = {1: struct.pack("<i", _clamp(lo, *_range(32, True))),
                     2: struct.pack("<i", _clamp(hi, *_range(32, True)))}
        d[0x6502] = {0: struct.pack("<I", sum({4: 1 << 3, 10: 1 << 9}.get(m, 0)
                                              for m in self.supported_modes))}
        self.node.add_read_callback(self._on_read)
        self.node.add_write_callback(self._on_write)
        core.on_fault.append(self._on_core_fault)
        core.on_state.append(self._on_core_state)
        network.add_node(self.node)
        network.subscribe(SYNC_ID, self._on_sync)
        network.send_message(0x700 + self.node_id, [0])     # boot-up
        self.node.nmt.state = "PRE-OPERATIONAL"

    # --- fault injection -----------------------------------------------------------------
    def inject(self, fault: str, **args) -> None:
        if fault not in CAN_FAULTS:
            raise ValueError(f"unknown CANopen fault {fault!r}; known: {', '.join(CAN_FAULTS)}")
        with self.lock:
            if fault == "emcy":
                code = int(args.get("code", EMCY_INJECTED))
                self.core.fault(code, args.get("text", "injected EMCY"))
                return
            if fault == "glitch":
                self.core.glitch = int(args.get("counts", 1 << 16))
                self.core.glitch_samples = int(args.get("samples", 1))
                return
            self.faults[fault] = args
            if fault == "drop_heartbeats":
                self.node.nmt.stop_heartbeat()
            elif fault == "mute":
                self.node.nmt.stop_heartbeat()
                self.network.unsubscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)

    def clear(self, fault: str) -> None:
        with self.lock:
            if self.faults.pop(fault, None) is None:
                return
            if fault in ("drop_heartbeats", "mute"):
                ms = struct.unpack("<H", self.node.get_data(0x1017, 0))[0]
                self.node.nmt.start_heartbeat(ms)
            if fault == "mute":
                self.network.subscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)
            if fault == "freeze_status":
                self._frozen = None

    @property
    def muted(self) -> bool:
        return "mute" in self.faults

    # --- CiA 402 state machine ----------------------------------------------------------------
    def state402(self) -> str:
        s = self.core.state
        if s == DriveState.FAULT:
            return "F"
        if s == DriveState.QUICK_STOP:
            return "QSA"
        if s == DriveState.ENABLED:
            return "OE"
        return self.sub

    def statusword(self) -> int:
        st = self.state402()
        sw = _SW[st] | 0x0200
        if self.core.internal_limit:
            sw |= 0x0800
        if st == "OE" and self.mode == 10:
            sw |= 0x1000          # CST: drive follows the command value
        return sw

    def _on_core_state(self, old, new) -> None:
        if new == DriveState.DISABLED:
            self.sub = "SOD"

    def _controlword(self, cw: int) -> None:
        prev, self.cw = self.cw, cw
        st = self.state402()
        core = self.core
        if st == "F":
            if cw & 0x80 and not prev & 0x80:       # fault reset on the rising edge
                core.reset_fault()
                self.sub = "SOD"
                self._set_emcy_state(0)
                self.node.emcy.reset()
            return
        if cw & 0x82 == 0x00:                        # disable voltage
            core.disable()
            self.sub = "SOD"
        elif cw & 0x86 == 0x02:                      # quick stop
            if st == "OE":
                core.quick_stop()
            elif st in ("RTSO", "SO"):
                self.sub = "SOD"
        elif cw & 0x87 == 0x06:                      # shutdown
            if st in ("SOD", "SO", "OE"):
                core.disable()
                self.sub = "RTSO"
        elif cw & 0x8F == 0x07:                      # switch on / disable operation
            if st == "RTSO" or st == "OE":
                core.disable()
                self.sub = "SO"
        elif cw & 0x8F == 0x0F:                      # enable operation
            if st in ("SO", "RTSO") and self.mode in self.supported_modes:
                self.target = 0.0
                core.enable()
            # from QSA only with quick stop option codes 5..8, which this drive lacks

    # --- object dictionary callbacks ------------------------------------------------------------
    def _on_read(self, index, subindex, od):
        core = self.core
        if index == 0x6041:
            return self.statusword()
        if index == 0x6061:
            return self.mode
        if index == 0x6064:
            return _clamp(int(round(core.vj.measured_position() * self.cpu)), *_range(32, True))
        if index == 0x606C:
            return _clamp(int(round(core.vj.state.v * self.cpu)), *_range(32, True))
        if index == 0x6077:
            return _clamp(int(round(core.applied / self.rated * 1000)), *_range(16, True))
        if index == 0x2001:
            return int(round(core.vj.state.t * 1e6)) & 0xFFFFFFFF
        if index == 0x603F:
            return core.fault_code if isinstance(core.fault_code, int) else EMCY_HEARTBEAT
        if index == 0x1001:
            return 0x01 if core.state == DriveState.FAULT else 0
        return None

    def _on_write(self, index, subindex, od, data):
        value = od.decode_raw(data)
        with self.lock:
            if index == 0x6040:
                self._controlword(value)
            elif index == 0x6060:
                if value in self.supported_modes:
                    self.mode = value      # else: silently ignored, as many drives do
            elif index == 0x6071:
                self._target(value)
            elif index == 0x6072:
                self.core.max_torque = value * self.rated / 1000.0
            elif index == 0x6076 and value > 0:
                self.rated = value / 1000.0
            elif index == 0x607D and subindex in (1, 2):
                lim = list(self.core.limits)
                lim[subindex - 1] = value / self.cpu
                self.core.limits = tuple(lim)
            elif index == 0x1016 and subindex == 1:
                self._consumer(value)
            elif 0x1400 <= index <= 0x1BFF:
                self._dirty = True

    def _target(self, raw: int) -> None:
        self.target = raw * self.rated / 1000.0
        if self.mode == 4:           # profile torque: applies on receipt, not on SYNC
            self.core.set_command(self.target if self.core.state == DriveState.ENABLED else 0)

    def _consumer(self, value: int) -> None:
        if self._hb_producer is not None:
            self.network.unsubscribe(0x700 + self._hb_producer, self._on_host_heartbeat)
            self._hb_producer = None
        producer, ms = (value >> 16) & 0x7F, value & 0xFFFF
        self.core.watchdog_s = ms / 1000.0 if producer and ms else 0.0
        self.core.last_alive = None          # armed by the first heartbeat (CiA 301)
        if producer and ms:
            self._hb_producer = producer
            self.network.subscribe(0x700 + producer, self._on_host_heartbeat)

    def _on_host_heartbeat(self, can_id, data, timestamp) -> None:
        if not self.muted:
            self.core.feed()

    def _set_emcy_state(self, code: int) -> None:
        self.node.data_store.setdefault(0x603F, {})[0] = struct.pack("<H", code)

    def _on_core_fault(self, code, text) -> None:
        emcy = EMCY_HEARTBEAT if code == FAULT_WATCHDOG else int(code)
        self._set_emcy_state(emcy)
        if not self.muted:
            try:
                self.node.emcy.send(emcy, 0x01, text.encode("ascii", "replace")[:5])
            except Exception:      # bus gone while shutting down: nothing left to tell
                pass

    # --- PDOs --------------------------------------------------------------------------------------
    def _entries(self, map_index: int) -> list[tuple[int, int, int]]:
        g = self.node.get_data
        n = g(map_index, 0)[0]
        out = []
        for k in range(1, n + 1):
            e = struct.unpack("<I", g(map_index, k))[0]
            out.append((e >> 16, (e >> 8) & 0xFF, e & 0xFF))
        return out

    def _layout(self, entries) -> tuple[struct.Struct, list]:
        fmt = "<"
        for index, subindex, bits in entries:
            od = self.node.object_dictionary[index]
            if not isinstance(od, canopen.objectdictionary.ODVariable):
                od = od[subindex]
            signed = od.data_type in canopen.objectdictionary.SIGNED_TYPES
            fmt += _FMT[(bits, signed)]
        return struct.Struct(fmt), entries

    def _compile(self) -> None:
        g = self.node.get_data
        for cob in list(self._rpdo):
            self.network.unsubscribe(cob, self._on_rpdo)
        self._rpdo, self._tpdo = {}, []
        for i in range(512):
            if 0x1400 + i not in self.node.object_dictionary:
                break
            cob = struct.unpack("<I", g(0x1400 + i, 1))[0]
            if not cob & 0x80000000:
                self._rpdo[cob & 0x7FF] = self._layout(self._entries(0x1600 + i))
                self.network.subscribe(cob & 0x7FF, self._on_rpdo)
        for i in range(512):
            if 0x1800 + i not in self.node.object_dictionary:
                break
            cob = struct.unpack("<I", g(0x1800 + i, 1))[0]
            trans = g(0x1800 + i, 2)[0]
            if not cob & 0x80000000 and 1 <= trans <= 240:
                layout, entries = self._layout(self._entries(0x1A00 + i))
                self._tpdo.append((cob & 0x7FF, trans, layout, self._slots(layout, entries)))
        self._dirty = False

    def _on_rpdo(self, can_id, data, timestamp) -> None:
        if self.muted or self.node.nmt.state != "OPERATIONAL":
            return
        with self.lock:
            layout, entries = self._rpdo[can_id]
            if len(data) < layout.size:
                return
            for (index, subindex, _), value in zip(entries, layout.unpack_from(data)):
                if index == 0x6040:
                    if value != self.cw:
                        self._controlword(value)
                elif index == 0x6071:
                    self._target(value)
                else:
                    od = self.node._find_object(index, subindex)
                    self.node.set_data(index, subindex, od.encode_raw(value))

    def _on_sync(self, can_id, data, timestamp) -> None:
        if self.muted or self.node.nmt.state != "OPERATIONAL":
            return
        with self.lock:
            if self._dirty:
                self._compile()
            core = self.core
            cst = self.mode == 10 and core.state == DriveState.ENABLED
            if core.clock == "lockstep":
                if cst:
                    core.set_command(self.target)
                core.step()
            else:
                core.catch_up(time.monotonic(), command=True)
                if cst:
                    core.set_command(self.target)
            self.sync_count += 1
            frames = self._pack()
            if "freeze_status" in self.faults:
                self._frozen = self._frozen or frames
                frames = self._frozen
        late = self.faults.get("late")
        if late is not None:
            timer = threading.Timer(float(late.get("delay", 1.0)), self._send, (frames,))
            timer.daemon = True
            timer.start()
        else:
            self._send(frames)

    # objects the drive measures at each SYNC; anything else mapped is read from the
    # dictionary.  _compile turns each TPDO mapping into (slot or reader, bits, signed)
    _LIVE = {0x6041: 0, 0x6061: 1, 0x6064: 2, 0x606C: 3, 0x6077: 4, 0x2001: 5}

    def _pack(self) -> list[tuple[int, bytes]]:
        t, q, v, tau = self.core.measure()
        live = (self.statusword(), self.mode, int(round(q * self.cpu)), int(round(v * self.cpu)),
                int(round(tau / self.rated * 1000)), int(round(t * 1e6)) & 0xFFFFFFFF)
        frames = []
        for cob, trans, layout, slots in self._tpdo:
            if self.sync_count % trans:
                continue
            vals = [_clamp(live[src] if src.__class__ is int else src(), lo, hi)
                    for src, lo, hi in slots]
            frames.append((cob, layout.pack(*vals)))
        return frames

    def _slots(self, layout: struct.Struct, entries) -> list:
        out = []
        for (index, subindex, bits), code in zip(entries, layout.format[1:]):
            src = self._LIVE.get(index)
            if src is None:
                fmt = "<" + code
                src = (lambda i=index, s=subindex, f=fmt:
                       struct.unpack(f, self.node.get_data(i, s))[0])
            lo, hi = _range(bits, code.islower())
            out.append((src, lo, hi))
        return out

    def _send(self, frames) -> None:
        for cob, payload in frames:
            try:
                self.network.send_message(cob, payload)
            except Exception:          # bus shut down under a late timer
                return

    def close(self) -> None:
        self.node.nmt.stop_heartbeat()
        try:
            self.network.unsubscribe(SYNC_ID, self._on_sync)
        except (KeyError, ValueError):
            pass
