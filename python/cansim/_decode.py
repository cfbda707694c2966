"""What a node's frames mean: PDOs by their mapping, and one monitor line per
frame in ``cansimctl monitor``'s words (src/ctl/frame_decoder.cpp).

The mapping comes from Node1.GetPdoMapping (docs/control-api.md): entries in
frame order, each (index, sub, bits, name, data type, scale, unit);
engineering value = raw x scale, in unit.
"""

from __future__ import annotations

import math
import struct
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

from ._wire import Frame

# CiA 301 predefined connection set (§7.3.3, Table 43); CiA 305 §6.
_NMT, _SYNC, _EMCY, _SDO_TX, _SDO_RX, _HEARTBEAT = 0x000, 0x080, 0x080, 0x580, 0x600, 0x700
_LSS_MASTER, _LSS_SLAVE = 0x7E5, 0x7E4
_EXTENDED_FLAG = 1 << 29

#: NMT command specifiers (CiA 301 §7.2.8.3.1) as cansimctl and Node.nmt() name them
NMT_COMMANDS = {0x01: "start", 0x02: "stop", 0x80: "pre-operational", 0x81: "reset-node",
                0x82: "reset-communication"}
#: heartbeat states (CiA 301 Table 58)
NMT_STATES = {0x04: "stopped", 0x05: "operational", 0x7F: "pre-operational"}

_INTEGER_BYTES = {"INTEGER8": 1, "INTEGER16": 2, "INTEGER24": 3, "INTEGER32": 4, "INTEGER40": 5, "INTEGER48": 6,
                  "INTEGER56": 7, "INTEGER64": 8}
_UNSIGNED_BYTES = {"UNSIGNED8": 1, "UNSIGNED16": 2, "UNSIGNED24": 3, "UNSIGNED32": 4, "UNSIGNED40": 5,
                   "UNSIGNED48": 6, "UNSIGNED56": 7, "UNSIGNED64": 8}

Value = Union[int, float, bool, bytes]


@dataclass(frozen=True)
class MappedEntry:
    """One object mapped into a PDO (a dummy entry has index 0, name "")."""

    index: int
    sub: int
    bits: int
    name: str
    type: str
    scale: float
    unit: str


class PdoMapping(NamedTuple):
    """A PDO as the node's engine runs it (GetPdoMapping)."""

    name: str
    can_id: int
    extended: bool
    valid: bool
    transmission_type: int
    entries: Tuple[MappedEntry, ...]


def pdo_mappings(raw: Sequence[Any]) -> List[PdoMapping]:
    """GetPdoMapping's reply as PdoMappings."""
    out = []
    for name, cob, valid, ttype, entries in raw:
        out.append(PdoMapping(str(name), int(cob) & ~_EXTENDED_FLAG, bool(int(cob) & _EXTENDED_FLAG), bool(valid),
                              int(ttype), tuple(MappedEntry(*e) for e in entries)))
    return out


def _decimals(scale: float) -> Optional[int]:
    """d for a scale of 10^-d (0 < d <= 9), None otherwise."""
    if scale <= 0 or scale >= 1:
        return None
    d = round(-math.log10(scale))
    return d if 0 < d <= 9 and math.isclose(scale, 10.0 ** -d, rel_tol=1e-9) else None


def engineering(raw: Value, scale: float) -> Value:
    """raw x scale, rounded to the decimals of a 10^-d scale (350 x 0.01 = 3.5)."""
    if scale == 1 or isinstance(raw, (bytes, bool)):
        return raw
    value = raw * scale
    d = _decimals(scale)
    return round(value, d) if d is not None else value


def _bits(data: bytes, first: int, count: int) -> int:
    """Bits [first, first + count) of the frame's data, little-endian (CiA 301 §7.4.8.2)."""
    return (int.from_bytes(data, "little") >> first) & ((1 << count) - 1)


def _typed(type_name: str, raw: int, bits: int) -> Optional[Value]:
    if type_name == "BOOLEAN":
        return bool(raw)
    if type_name in _UNSIGNED_BYTES:
        return raw
    if type_name in _INTEGER_BYTES:
        return raw - (1 << bits) if bits and raw >> (bits - 1) & 1 else raw
    if type_name == "REAL32" and bits == 32:
        return float(struct.unpack("<f", raw.to_bytes(4, "little"))[0])
    if type_name == "REAL64" and bits == 64:
        return float(struct.unpack("<d", raw.to_bytes(8, "little"))[0])
    return None


def decode_pdo(mapping: PdoMapping, data: bytes) -> Tuple[Dict[str, Value], Dict[str, str], Optional[str]]:
    """The mapped objects' values in their units ({name: value}), their
    units ({name: unit}), and an error when the frame is shorter than the
    mapping (then only the entries that fit are decoded)."""
    values: Dict[str, Value] = {}
    units: Dict[str, str] = {}
    first = 0
    for e in mapping.entries:
        end = first + e.bits
        if end > len(data) * 8:
            return values, units, f"frame too short for the mapping (DLC {len(data)})"
        if e.name:
            raw = _bits(data, first, e.bits)
            typed = _typed(e.type, raw, e.bits)
            name = e.name if e.name not in values else f"{e.name} (0x{e.index:04X}:{e.sub:02X})"
            values[name] = engineering(typed, e.scale) if typed is not None else raw.to_bytes((e.bits + 7) // 8, "little")
            units[name] = e.unit
        first = end
    return values, units, None


# ---------------------------------------------------------------- the monitor

@dataclass
class NodeView:
    """What the monitor knows of a node: its key, label, bus, node-ID, PDOs."""

    key: str
    label: str
    interface: str
    node_id: int
    pdos: List[PdoMapping] = field(default_factory=list)
    emcy_codes: Dict[int, str] = field(default_factory=dict)


def _hex(v: int, digits: int) -> str:
    return f"0x{v:0{digits}X}"


def _clock(t: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(t)) + f".{int(round((t % 1) * 1e6)) % 1000000:06d}"


def _show(value: Value, unit: str) -> str:
    if isinstance(value, bytes):
        text = value.hex(" ") or "(none)"
    elif isinstance(value, float):
        text = f"{value:.6g}"
    else:
        text = str(value)
    return f"{text} {unit}" if unit else text


class Monitor:
    """Frames as ``cansimctl monitor`` lines: "12:03:04.123456 vcan0 190
    pt/0 TPDO1 AI input PV 1 = 3.5 bar, AI status 1 = 0"."""

    def __init__(self, nodes: Sequence[NodeView]) -> None:
        self._by_id: Dict[Tuple[str, int], NodeView] = {(n.interface, n.node_id): n for n in nodes}
        self._pdos: Dict[Tuple[str, int, bool], Tuple[NodeView, PdoMapping]] = {}
        for n in nodes:
            for p in n.pdos:
                if p.valid:
                    self._pdos[(n.interface, p.can_id, p.extended)] = (n, p)

    def line(self, f: Frame) -> str:
        ident = f"{f.can_id:08X}" if f.extended else f"{f.can_id:03X}"
        node, kind, fields = self._decode(f)
        text = f"{_clock(f.timestamp)} {f.channel} {ident} {node.label if node else '-'} {kind}"
        return text + (" " + fields if fields else "")

    def _decode(self, f: Frame) -> Tuple[Optional[NodeView], str, str]:
        pdo = self._pdos.get((f.channel, f.can_id, f.extended))
        if pdo is not None:
            return pdo[0], pdo[1].name, self._pdo_text(pdo[1], f)
        if f.extended:
            return None, "raw", _raw_text(f)
        node_id, function = f.can_id & 0x7F, f.can_id & ~0x7F
        if f.can_id == _NMT:
            return self._nmt(f)
        if f.can_id == _SYNC:
            return None, "SYNC", f"counter = {f.data[0]}" if f.data else ""
        if f.can_id in (_LSS_MASTER, _LSS_SLAVE):
            return None, "LSS", f"command {_hex(f.data[0], 2)}" + (" (response)" if f.can_id == _LSS_SLAVE else "") \
                if f.data else ""
        node = self._by_id.get((f.channel, node_id)) if node_id else None
        if node is None:
            return None, "raw", _raw_text(f)
        if function == _EMCY:
            return node, "EMCY", self._emcy_text(node, f)
        if function == _HEARTBEAT:
            return (node,) + _heartbeat(f)
        if function in (_SDO_TX, _SDO_RX):
            return node, "SDO", _sdo_text(f, request=function == _SDO_RX)
        return None, "raw", _raw_text(f)

    def _nmt(self, f: Frame) -> Tuple[Optional[NodeView], str, str]:
        if not f.data:
            return None, "NMT", ""
        command = NMT_COMMANDS.get(f.data[0], _hex(f.data[0], 2))
        if len(f.data) < 2:
            return None, "NMT", command
        target = f.data[1]
        node = self._by_id.get((f.channel, target)) if target else None
        return node, "NMT", f"{command}, node-ID = {'all' if target == 0 else _hex(target, 2)}"

    @staticmethod
    def _pdo_text(p: PdoMapping, f: Frame) -> str:
        if f.rtr:
            return "RTR"
        values, units, error = decode_pdo(p, f.data)
        parts = [f"{name} = {_show(v, units[name])}" for name, v in values.items()]
        if error:
            parts.append(f"error = {error}")
        return ", ".join(parts)

    @staticmethod
    def _emcy_text(node: NodeView, f: Frame) -> str:
        if len(f.data) < 3:
            return _raw_text(f)
        code = int.from_bytes(f.data[:2], "little")
        meaning = node.emcy_codes.get(code, "")
        text = f"code = {_hex(code, 4)}" + (f", meaning = {meaning}" if meaning else "")
        text += f", register = {_hex(f.data[2], 2)}"
        return text + (f", vendor = {f.data[3:].hex(' ')}" if len(f.data) > 3 else "")


def _raw_text(f: Frame) -> str:
    return "RTR" if f.rtr else f"data = {f.data.hex(' ') or '(none)'}"


def _heartbeat(f: Frame) -> Tuple[str, str]:
    if f.rtr:
        return "heartbeat", "node guarding RTR"
    if not f.data:
        return "raw", _raw_text(f)
    state = f.data[0] & 0x7F
    if state == 0:
        return "boot-up", ""
    text = NMT_STATES.get(state, _hex(state, 2))
    return "heartbeat", text + (", toggle = 1" if f.data[0] & 0x80 else "")


_SDO_REQUESTS = {1: "download request", 0: "download segment", 2: "upload request", 3: "upload segment request",
                 5: "block upload request", 6: "block download request"}
_SDO_RESPONSES = {2: "upload response", 0: "upload segment", 3: "download response", 1: "download segment response",
                  5: "block download response", 6: "block upload response"}


def _sdo_text(f: Frame, request: bool) -> str:
    """The command, the object and an expedited value's bytes (the full
    SDO decoding with object names and types is cansimctl monitor's)."""
    if len(f.data) != 8:
        return f"error = DLC {len(f.data)}, expected 8"
    cmd = f.data[0]
    cs = cmd >> 5
    obj = f"0x{int.from_bytes(f.data[1:3], 'little'):04X}:{f.data[3]:02X}"
    if cs == 4:
        return f"abort {obj}, code = {_hex(int.from_bytes(f.data[4:8], 'little'), 8)}"
    name = (_SDO_REQUESTS if request else _SDO_RESPONSES).get(cs, "unknown command")
    if "segment" in name:
        return f"{name}, data = {f.data[1:8 - ((cmd >> 1) & 7)].hex(' ')}"
    if cs in (1, 2) and (request == (cs == 1)) and cmd & 0x02:
        unused = (cmd >> 2) & 3 if cmd & 0x01 else 0
        return f"{name} {obj} = {f.data[4:8 - unused].hex(' ')}"
    return f"{name} {obj}"
