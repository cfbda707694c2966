#!/usr/bin/env python3
"""Writes the seed corpus of fuzz/node_fuzz.cpp into fuzz/corpus/.

Each seed is a meaningful master-side conversation in the record format
documented in node_fuzz.cpp: most with the generic-404 node (node-ID 0x10),
one per device profile (device_<profile>.bin: start, then reads and writes
of its vendor objects, addressed by whatever node-ID the variant has). The
fuzz run puts the variant byte in front (scripts/fuzz-run).
Run: /usr/bin/python3 fuzz/make_seeds.py   (the seeds are committed)."""
import os
import struct

import yaml

NMT, SYNC, SDO, LSS, RPDO, TPDO, HB, RAW, SDO_ANY, EMCY, FAULT, POWER = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 14, 15
SILENT, POWER_CYCLE, BUS_OFF, HEARTBEAT_STOP, SLOW_SDO, SDO_BLOCK_DROP = range(6)
RTR = 0x80


def rec(step_ms, sel, data=b"", param=0, dlc=None):
    data = bytes(data)
    if dlc is None:
        dlc = len(data)
    step = int(step_ms * 100)
    if step > 0xFFFF:  # longer waits: use several records
        raise ValueError("step too long")
    return struct.pack("<HBBB", step, sel, param, dlc) + data.ljust(8, b"\0")[:8]


def sdo(*b, step=1):
    return rec(step, SDO, bytes(b).ljust(8, b"\0"))


def crc16(data):
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def u32(v):
    return list(struct.pack("<I", v))


seeds = {}

seeds["nmt_sync"] = b"".join(
    [rec(10, NMT, [0x01, 0x10])]
    + [rec(100, SYNC, []) for _ in range(20)]
    + [rec(5, NMT, [0x02, 0x00]), rec(500, SYNC, []), rec(5, NMT, [0x80, 0x10]), rec(5, NMT, [0x82, 0x10]),
       rec(50, NMT, [0x81, 0x00]), rec(600, SYNC, []), rec(600, SYNC, [])])

seeds["sdo_expedited"] = b"".join([
    sdo(0x40, 0x00, 0x10, 0x00), sdo(0x40, 0x18, 0x10, 0x04), sdo(0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01),
    sdo(0x22, 0x12, 0x61, 0x01, 0x02), sdo(0x2F, 0x32, 0x61, 0x01, 0x05), sdo(0x40, 0x25, 0x61, 0x01),
    sdo(0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4), sdo(0x40, 0x34, 0x12, 0x00), sdo(0xE0),
    sdo(0x40, 0x30, 0x61, 0x01), sdo(0x40, 0x03, 0x10, 0x00), sdo(0x2F, 0x03, 0x10, 0x00, 0x00)])

seg_up = [sdo(0x40, 0x08, 0x10, 0x00)] + [sdo(0x60 if i % 2 == 0 else 0x70) for i in range(6)]
seeds["sdo_segmented_upload"] = b"".join(seg_up + [sdo(0x40, 0x00, 0x20, 0x00), sdo(0x60), sdo(0x60)])

text = b"fuzz seed string"
seg_dn = [sdo(0x21, 0x00, 0x20, 0x00, *u32(len(text)))]
toggle = 0
for pos in range(0, len(text), 7):
    chunk = text[pos:pos + 7]
    last = pos + 7 >= len(text)
    cs = toggle | ((7 - len(chunk)) << 1) | (1 if last else 0)
    seg_dn.append(sdo(cs, *chunk))
    toggle ^= 0x10
seeds["sdo_segmented_download"] = b"".join(seg_dn + [sdo(0x21, 0x00, 0x20, 0x00, 5), rec(600, SYNC, []), rec(600, SYNC, [])])

blk = bytes(range(40))
bd = [sdo(0xC6, 0x01, 0x20, 0x00, *u32(len(blk)))]
segs = [blk[i:i + 7] for i in range(0, len(blk), 7)]
for n, chunk in enumerate(segs, 1):
    if n == 3:
        bd.append(sdo(0x04, *segs[3]))  # gap, then resend
        for m, again in enumerate(segs[2:], 1):
            bd.append(sdo(m | (0x80 if m == len(segs) - 2 else 0), *again))
        break
    bd.append(sdo(n, *chunk))
unused = (7 - len(blk) % 7) % 7
c = crc16(blk)
bd.append(sdo(0xC1 | (unused << 2), c & 0xFF, c >> 8))
seeds["sdo_block_download"] = b"".join(bd)

seeds["sdo_block_upload"] = b"".join([
    sdo(0xA4, 0x00, 0x20, 0x00, 5, 0), sdo(0xA3), sdo(0xA2, 3, 5), sdo(0xA2, 5, 127),
    sdo(0xA2, 127, 127), sdo(0xA1), sdo(0xA4, 0x00, 0x10, 0x00, 10, 8), sdo(0xA4, 0x08, 0x10, 0x00, 0, 0),
    sdo(0xA4, 0x01, 0x20, 0x00, 2, 0), sdo(0xA3), rec(600, SYNC, []), rec(600, SYNC, [])])

seeds["lss"] = b"".join([
    rec(1, LSS, [0x04, 0x01]), rec(1, LSS, [0x5A]), rec(1, LSS, [0x5B]), rec(1, LSS, [0x5E]),
    rec(1, LSS, [0x11, 0x22]), rec(1, LSS, [0x13, 0x00, 0x04]), rec(1, LSS, [0x15, 0x10, 0x00]),
    rec(30, LSS, [0x17]), rec(1, LSS, [0x04, 0x00]), rec(1, NMT, [0x82, 0x00]), rec(10, SDO_ANY, [0x40, 0, 0x10, 0], 0x22),
    rec(1, LSS, [0x40] + u32(0x00CA5D00)), rec(1, LSS, [0x41] + u32(0x404)), rec(1, LSS, [0x42] + u32(0x10000)),
    rec(1, LSS, [0x43] + u32(1)), rec(1, LSS, [0x4C]), rec(1, LSS, [0x51, 0, 0, 0, 0, 0x80, 0, 0])])

seeds["pdo"] = b"".join(
    [rec(1, NMT, [0x01, 0x10]), rec(1, RPDO, [1, 2, 3, 4, 5, 6]), rec(1, RPDO, [1, 2]),
     rec(1, TPDO | RTR, [], 2, 0),  # RTR on TPDO3
     sdo(0x2F, 0x01, 0x18, 0x02, 0x00), sdo(0x23, 0x01, 0x18, 0x01, *u32(0x80000290)),
     sdo(0x2F, 0x01, 0x1A, 0x00, 0), sdo(0x23, 0x01, 0x1A, 0x01, *u32(0x61300120)), sdo(0x2F, 0x01, 0x1A, 0x00, 1),
     sdo(0x23, 0x01, 0x18, 0x01, *u32(0x290))]
    + [rec(100, SYNC, []) for _ in range(10)])

seeds["heartbeat_consumer"] = b"".join(
    [sdo(0x23, 0x16, 0x10, 0x01, *u32((5 << 16) | 200)), rec(10, HB, [0x05], 5), rec(100, HB, [0x05], 5),
     rec(500, SYNC, []), rec(500, SYNC, []), sdo(0x2B, 0x17, 0x10, 0x00, 50, 0), rec(300, SYNC, []),
     sdo(0x2B, 0x0C, 0x10, 0x00, 100, 0), sdo(0x2F, 0x0D, 0x10, 0x00, 3),
     rec(10, RAW | RTR | (7 << 4), [], 0x10, 0), rec(500, SYNC, []), rec(500, SYNC, [])])  # guarding RTR 0x710

seeds["store_restore_power"] = b"".join(
    [sdo(0x2B, 0x17, 0x10, 0x00, 0xD0, 0x07), sdo(0x23, 0x10, 0x10, 0x01, *b"save"), rec(10, POWER, []),
     sdo(0x40, 0x17, 0x10, 0x00), sdo(0x23, 0x11, 0x10, 0x01, *b"load"), rec(10, NMT, [0x81, 0x10]),
     sdo(0x40, 0x17, 0x10, 0x00)])

seeds["emcy_errors"] = b"".join(
    [sdo(0x40, 0x03, 0x10, 0x01), sdo(0x2F, 0x03, 0x10, 0x00, 0), sdo(0x2B, 0x15, 0x10, 0x00, 10, 0),
     rec(1, SYNC, [1, 2]), rec(1, EMCY, [0, 0x10, 0, 0, 0, 0, 0, 0], 5)])


def fault(kind, duration_ms=0, delay_ms=0, drop_every=0, drop_p=0, step=1):
    return rec(step, FAULT, [duration_ms & 0xFF, duration_ms >> 8, delay_ms, drop_every, drop_p], kind, dlc=0)


# Communication faults during SDO traffic: a slow server, a block upload with
# lost segments, bus-off and a power cycle with a stored value.
seeds["comm_faults"] = b"".join(
    [fault(SLOW_SDO, 500, 20), sdo(0x40, 0x00, 0x10, 0x00), rec(30, SYNC, []),
     fault(SDO_BLOCK_DROP, 2000, 0, 3), sdo(0xA4, 0x01, 0x20, 0x00, 127), sdo(0xA3), rec(5, SYNC, []),
     sdo(0xA2, 1, 127), rec(5, SYNC, []), sdo(0xA1),
     fault(HEARTBEAT_STOP, 1500), rec(600, SYNC, []), fault(BUS_OFF, 300), rec(400, NMT, [0x01, 0x10]),
     sdo(0x2B, 0x17, 0x10, 0x00, 0x64, 0x00), sdo(0x23, 0x10, 0x10, 0x01, *b"save"),
     fault(POWER_CYCLE, 50), rec(100, SYNC, []), fault(SILENT, 200), sdo(0x40, 0x17, 0x10, 0x00),
     rec(300, SYNC, [])])

def default_bytes(row, size):
    """A profile default as little-endian bytes ($NODEID terms dropped)."""
    d = str(row.get("default", 0)).replace("$NODEID", "0").replace(" ", "")
    try:
        v = sum(int(t, 0) for t in d.split("+") if t)
    except ValueError:
        return None
    return list((v & ((1 << (8 * size)) - 1)).to_bytes(size, "little"))


SIZES = {"UNSIGNED8": 1, "INTEGER8": 1, "BOOLEAN": 1, "UNSIGNED16": 2, "INTEGER16": 2,
         "UNSIGNED32": 4, "INTEGER32": 4, "REAL32": 4}


# Vendor objects of each device profile (0x2000-0x5FFF): read each, write
# back its default where it is writable (the personality's hooks).
def device_seed(profile_file):
    with open(profile_file) as f:
        rows = yaml.safe_load(f)["objects"]
    out = [rec(10, NMT, [0x01, 0x00])]
    for row in rows:
        index = row["index"]
        if not 0x2000 <= index < 0x6000 or len(out) >= 24:
            continue
        sub = row.get("sub", 0)
        sub = int(str(sub).split("..")[0], 0) if isinstance(sub, str) else sub
        out.append(sdo(0x40, index & 0xFF, index >> 8, sub))
        size = SIZES.get(row["type"])
        value = default_bytes(row, size) if size else None
        if value is not None and row["access"] in ("rw", "wo", "rww"):
            out.append(sdo(0x23 | ((4 - size) << 2), index & 0xFF, index >> 8, sub, *value))
    return b"".join(out + [rec(600, SYNC, []), rec(600, SYNC, [])])


here = os.path.dirname(os.path.abspath(__file__))
for name in ("dps", "p92c", "gems9000", "smc", "cmp"):
    seeds["device_" + name] = device_seed(os.path.join(here, "..", "profiles", name + ".yaml"))
out = os.path.join(here, "corpus")
os.makedirs(out, exist_ok=True)
for name, blob in seeds.items():
    assert len(blob) % 13 == 0, name
    with open(os.path.join(out, name + ".bin"), "wb") as f:
        f.write(blob)
print(f"wrote {len(seeds)} seeds to {out}")
