#!/usr/bin/python3
"""Print CANopen traffic decoded: NMT, SYNC, TIME, EMCY, PDO, SDO, heartbeat
and boot-up, LSS.

usage: scripts/decode.py [--seconds N] [--count N] [--ready-file F] [IFACE]
       scripts/decode.py --candump FILE     # a 'candump -L' log ('-' = stdin)

Reads IFACE (default vcan0) with python3-can (Debian's /usr/bin/python3) until
--seconds or --count is reached or Ctrl-C, then prints a summary line. With
--ready-file, touches F once the socket is open (so a script can start traffic
only when nothing will be missed). Exit status 0 if any frame was seen, 1 if
none, 2 on usage or interface errors.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import struct
import sys
import time
from collections import Counter

NMT_COMMANDS = {
    0x01: "start remote node",
    0x02: "stop remote node",
    0x80: "enter pre-operational",
    0x81: "reset node",
    0x82: "reset communication",
}
STATES = {0x00: "boot-up", 0x04: "stopped", 0x05: "operational", 0x7F: "pre-operational"}
EMCY_CODES = {
    0x0000: "error reset / no error",
    0x1000: "generic error",
    0x2000: "current",
    0x3000: "voltage",
    0x4000: "temperature",
    0x4200: "device temperature",
    0x5000: "device hardware",
    0x6100: "internal software",
    0x8110: "CAN overrun",
    0x8120: "CAN error passive",
    0x8130: "heartbeat/guarding error",
    0x8140: "bus-off recovered",
    0x8210: "PDO not processed (length)",
    0x8220: "PDO length exceeded",
    0x8240: "unexpected SYNC length",
    0x8250: "RPDO timeout",
    0xFF00: "device specific",
}
SDO_ABORTS = {
    0x05030000: "toggle bit not altered",
    0x05040000: "SDO protocol timed out",
    0x05040001: "command specifier not valid",
    0x05040002: "invalid block size",
    0x05040003: "invalid sequence number",
    0x05040004: "CRC error",
    0x05040005: "out of memory",
    0x06010000: "unsupported access",
    0x06010001: "read of a write-only object",
    0x06010002: "write of a read-only object",
    0x06020000: "object does not exist",
    0x06040041: "object cannot be mapped",
    0x06040042: "PDO length exceeded",
    0x06040043: "general parameter incompatibility",
    0x06040047: "general internal incompatibility",
    0x06060000: "hardware error",
    0x06070010: "data type / length mismatch",
    0x06070012: "length too high",
    0x06070013: "length too low",
    0x06090011: "sub-index does not exist",
    0x06090030: "invalid value",
    0x06090031: "value too high",
    0x06090032: "value too low",
    0x06090036: "max less than min",
    0x060A0023: "resource not available",
    0x08000000: "general error",
    0x08000020: "cannot transfer or store",
    0x08000021: "cannot transfer: local control",
    0x08000022: "cannot transfer: device state",
    0x08000023: "no object dictionary",
    0x08000024: "no data available",
}
LSS_CS = {
    0x04: "switch state global",
    0x11: "configure node-ID",
    0x13: "configure bit timing",
    0x15: "activate bit timing",
    0x17: "store configuration",
    0x40: "switch selective: vendor",
    0x41: "switch selective: product",
    0x42: "switch selective: revision",
    0x43: "switch selective: serial",
    0x44: "switch selective: confirmed",
    0x46: "identify: vendor",
    0x47: "identify: product",
    0x48: "identify: revision low",
    0x49: "identify: revision high",
    0x4A: "identify: serial low",
    0x4B: "identify: serial high",
    0x4C: "identify non-configured",
    0x4F: "identify slave (reply)",
    0x50: "identify non-configured slave (reply)",
    0x51: "fastscan",
    0x5A: "inquire vendor",
    0x5B: "inquire product",
    0x5C: "inquire revision",
    0x5D: "inquire serial",
    0x5E: "inquire node-ID",
}


class Frame:
    __slots__ = ("t", "can_id", "data", "rtr", "dlc", "ext", "err")

    def __init__(self, t, can_id, data, rtr=False, dlc=None, ext=False, err=False):
        self.t, self.can_id, self.data, self.rtr = t, can_id, bytes(data), rtr
        self.dlc = len(self.data) if dlc is None else dlc
        self.ext, self.err = ext, err


def hexs(b: bytes) -> str:
    return " ".join(f"{x:02X}" for x in b)


def u(b: bytes, off: int, n: int) -> int:
    return int.from_bytes(b[off:off + n], "little")


def mux(d: bytes) -> str:
    return f"0x{u(d, 1, 2):04X}:{d[3]:02X}" if len(d) >= 4 else "?"


def interpret(payload: bytes) -> str:
    """Little-endian readings of a small payload, for humans."""
    n = len(payload)
    if n == 1:
        return f"u8={payload[0]}"
    if n == 2:
        return f"i16={struct.unpack('<h', payload)[0]}"
    if n == 4:
        i = struct.unpack("<i", payload)[0]
        f = struct.unpack("<f", payload)[0]
        return f"i32={i} f32={f:.6g}"
    return ""


def initiate(prefix: str, d: bytes) -> str:
    """An SDO initiate (download request or upload response): expedited data or the size."""
    cs = d[0]
    e, s, n = cs & 2, cs & 1, (cs >> 2) & 3
    if e:
        data = d[4:8 - n] if s else d[4:8]
        return f"{prefix} {mux(d)} = {hexs(data)}  {interpret(data)}".rstrip()
    return f"{prefix} {mux(d)} segmented" + (f", {u(d, 4, 4)} bytes" if s else "")


def decode_sdo(node: int, to_server: bool, d: bytes) -> str:
    who = f"SDO {'req ' if to_server else 'resp'}"
    if len(d) != 8:
        return f"{who} (DLC {len(d)}, expected 8)"
    cs = d[0]
    if cs == 0x80:
        code = u(d, 4, 4)
        return f"{who} ABORT {mux(d)} 0x{code:08X} {SDO_ABORTS.get(code, '')}".rstrip()
    ccs = cs >> 5
    if to_server:
        if ccs == 1:  # download initiate
            return initiate(f"{who} write", d)
        if ccs == 0:  # download segment
            n = (cs >> 1) & 7
            return f"{who} write segment t={(cs >> 4) & 1}{' last' if cs & 1 else ''}: {hexs(d[1:8 - n])}"
        if ccs == 2:
            return f"{who} read {mux(d)}"
        if ccs == 3:
            return f"{who} read segment t={(cs >> 4) & 1}"
        if ccs == 6:
            return f"{who} block download {mux(d)}" if cs & 1 == 0 else f"{who} block download end"
        if ccs == 5:
            return f"{who} block upload {mux(d)}"
        return f"{who} cs=0x{cs:02X}"
    scs = ccs
    if scs == 3:
        return f"{who} write {mux(d)} ok"
    if scs == 1:
        return f"{who} write segment t={(cs >> 4) & 1} ok"
    if scs == 2:  # upload initiate
        return initiate(who, d)
    if scs == 0:  # upload segment
        n = (cs >> 1) & 7
        seg = d[1:8 - n]
        txt = "".join(chr(c) if 32 <= c < 127 else "." for c in seg)
        return f"{who} segment t={(cs >> 4) & 1}{' last' if cs & 1 else ''}: {hexs(seg)}  \"{txt}\""
    if scs in (5, 6):
        return f"{who} block transfer cs=0x{cs:02X}"
    return f"{who} cs=0x{cs:02X}"


def decode(f: Frame) -> tuple[str, str]:
    """(category, text) for one frame."""
    i, d = f.can_id, f.data
    if f.err:
        return "error", "error frame"
    if f.ext:
        return "other", "extended frame"
    fn, node = i & 0x780, i & 0x7F
    if i == 0x000:
        if len(d) >= 2:
            target = "all nodes" if d[1] == 0 else f"node {d[1]}"
            return "nmt", f"NMT {NMT_COMMANDS.get(d[0], f'command 0x{d[0]:02X}')} -> {target}"
        return "nmt", "NMT (short frame)"
    if i == 0x080:
        return "sync", "SYNC" + (f" counter {d[0]}" if d else "")
    if i == 0x100:
        return "time", "TIME"
    if i == 0x7E5:
        return "lss", f"LSS req  {LSS_CS.get(d[0], f'cs 0x{d[0]:02X}') if d else '?'} {hexs(d[1:])}"
    if i == 0x7E4:
        return "lss", f"LSS resp {LSS_CS.get(d[0], f'cs 0x{d[0]:02X}') if d else '?'} {hexs(d[1:])}"
    if node == 0:
        return "other", ""
    if fn == 0x080:
        if len(d) >= 3:
            code, reg = u(d, 0, 2), d[2]
            return "emcy", (f"node {node:3d} EMCY 0x{code:04X} {EMCY_CODES.get(code, EMCY_CODES.get(code & 0xFF00, ''))}"
                            f" reg 0x{reg:02X} mfr {hexs(d[3:])}")
        return "emcy", f"node {node:3d} EMCY (short)"
    if fn in (0x180, 0x280, 0x380, 0x480):
        n = (fn - 0x080) // 0x100
        if f.rtr:
            return "pdo", f"node {node:3d} TPDO{n} remote request"
        return "pdo", f"node {node:3d} TPDO{n} {hexs(d)}  {interpret(d)}".rstrip()
    if fn in (0x200, 0x300, 0x400, 0x500):
        n = (fn - 0x100) // 0x100
        return "pdo", f"node {node:3d} RPDO{n} {hexs(d)}  {interpret(d)}".rstrip()
    if fn == 0x580:
        return "sdo", f"node {node:3d} " + decode_sdo(node, False, d)
    if fn == 0x600:
        return "sdo", f"node {node:3d} " + decode_sdo(node, True, d)
    if fn == 0x700:
        if f.rtr:
            return "guard", f"node {node:3d} node guarding request"
        if len(d) == 1:
            if d[0] == 0:
                return "bootup", f"node {node:3d} BOOT-UP"
            st = STATES.get(d[0] & 0x7F, f"state 0x{d[0] & 0x7F:02X}")
            toggle = " (toggle)" if d[0] & 0x80 else ""
            return "heartbeat", f"node {node:3d} heartbeat {st}{toggle}"
        return "heartbeat", f"node {node:3d} heartbeat (DLC {len(d)})"
    return "other", ""


def raw(f: Frame) -> str:
    if f.rtr:
        return f"{f.can_id:03X}   [{f.dlc}] {'remote request':<23}"
    return f"{f.can_id:03X}   [{len(f.data)}] {hexs(f.data):<23}"


CANDUMP_RE = re.compile(r"^\((\d+\.\d+)\)\s+\S+\s+([0-9A-Fa-f]+)#(R\d?|[0-9A-Fa-f]*)\s*$")


def frames_from_candump(path: str):
    stream = sys.stdin if path == "-" else open(path)
    for line in stream:
        m = CANDUMP_RE.match(line.strip())
        if not m:
            continue
        t, ident, payload = float(m.group(1)), m.group(2), m.group(3)
        can_id = int(ident, 16)
        ext = len(ident) > 3
        if payload.startswith("R"):
            yield Frame(t, can_id, b"", rtr=True, dlc=int(payload[1:] or 0), ext=ext)
        else:
            yield Frame(t, can_id, bytes.fromhex(payload), ext=ext)


def frames_from_bus(iface: str, seconds: float | None, ready_file: str | None):
    try:
        import can
    except ImportError:
        print("decode: python3-can is missing (apt-get install python3-can; run with /usr/bin/python3)",
              file=sys.stderr)
        sys.exit(2)
    try:
        bus = can.Bus(interface="socketcan", channel=iface)
    except OSError as e:
        print(f"decode: cannot open {iface}: {e}", file=sys.stderr)
        sys.exit(2)
    if ready_file:
        with open(ready_file, "w") as fh:
            fh.write("ready\n")
    deadline = None if seconds is None else time.monotonic() + seconds
    try:
        while True:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return
            m = bus.recv(timeout=0.5 if left is None else min(left, 0.5))
            if m is None:
                continue
            yield Frame(m.timestamp, m.arbitration_id, m.data, rtr=m.is_remote_frame,
                        dlc=m.dlc, ext=m.is_extended_id, err=m.is_error_frame)
    finally:
        bus.shutdown()


def main() -> int:
    ap = argparse.ArgumentParser(description="Decode CANopen traffic.")
    ap.add_argument("iface", nargs="?", default="vcan0")
    ap.add_argument("--seconds", type=float, help="stop after this many seconds")
    ap.add_argument("--count", type=int, help="stop after this many frames")
    ap.add_argument("--candump", metavar="FILE", help="decode a 'candump -L' log instead ('-' = stdin)")
    ap.add_argument("--ready-file", help="write this file once listening")
    ap.add_argument("--quiet", action="store_true", help="only the summary")
    a = ap.parse_args()

    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt))
    counts: Counter = Counter()
    t0 = None
    src = frames_from_candump(a.candump) if a.candump else frames_from_bus(a.iface, a.seconds, a.ready_file)
    if not a.quiet:
        print(f"{'time':>8}  {'id':<3}  dlc data                     decoded", flush=True)
    try:
        for f in src:
            if t0 is None:
                t0 = f.t
            cat, text = decode(f)
            counts[cat] += 1
            if not a.quiet:
                print(f"{f.t - t0:8.3f}  {raw(f)}  {text}", flush=True)
            if a.count and sum(counts.values()) >= a.count:
                break
    except KeyboardInterrupt:
        pass
    total = sum(counts.values())
    parts = ", ".join(f"{k} {counts[k]}" for k in
                      ("bootup", "heartbeat", "nmt", "pdo", "sdo", "emcy", "sync", "time", "lss", "guard",
                       "error", "other") if counts[k])
    print(f"decode: {total} frames" + (f" ({parts})" if parts else ""), flush=True)
    return 0 if total else 1


if __name__ == "__main__":
    sys.exit(main())
