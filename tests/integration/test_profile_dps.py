#!/usr/bin/env python3
"""Honeywell DPS profile (profiles/dps.yaml) on vcan0 against a hand-written
master: boot-up on 0x77F, identity and string reads (the manual's 0x60 read
responses, Table 19), NMT start -> TPDO1 0x1FF every 100 ms with INTEGER32
psi x 1000, unit change to bar seen in the next PDO, LSS inquire / configure
node-ID / store / reset -> boot-up on the new node-ID, SDO there."""

import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x7F
NEW_NODE = 0x22


def sdo_read(bus, node: int, index: int, sub: int) -> bytes:
    """Expedited upload; the DPS answers with 0x60 (manual Table 19) where
    CiA 301 has 0x43..0x4F: accept both, return the 4 data bytes."""
    it.drain(bus)
    it.send(bus, 0x600 + node, struct.pack("<BHB", 0x40, index, sub).ljust(8, b"\0"))
    m = it.expect(bus, it.has_id(0x580 + node), it.scaled(2), f"SDO answer 0x{index:04X}:{sub}")
    d = bytes(m.data)
    assert len(d) == 8, it.fmt(m)
    assert d[0] != 0x80, f"abort 0x{struct.unpack_from('<I', d, 4)[0]:08X} on 0x{index:04X}:{sub}"
    assert d[0] == 0x60 or d[0] & 0xF3 == 0x43, it.fmt(m)
    assert struct.unpack_from("<HB", d, 1) == (index, sub), it.fmt(m)
    return d[4:8]


def sdo_write(bus, node: int, index: int, sub: int, data: bytes) -> None:
    it.drain(bus)
    it.send(bus, 0x600 + node, struct.pack("<BHB", 0x22, index, sub) + data.ljust(4, b"\0"))
    m = it.expect(bus, it.has_id(0x580 + node), it.scaled(2), f"SDO answer 0x{index:04X}:{sub}")
    assert bytes(m.data) == struct.pack("<BHB", 0x60, index, sub) + b"\0" * 4, it.fmt(m)


def pdo_values(bus, node: int, seconds: float):
    msgs = it.collect(bus, seconds, it.has_id(0x180 + node))
    for m in msgs:
        assert m.dlc == 4, it.fmt(m)
    return msgs, [struct.unpack("<i", bytes(m.data))[0] for m in msgs]


def test(ctx: it.Context) -> None:
    args = ("--profile", ctx.source("profiles/dps.yaml"), "--interface", "vcan0", "--state-dir", "{state_dir}")
    d = ctx.start_daemon(*args)
    with it.open_bus("vcan0") as bus:
        it.expect(bus, it.is_bootup(NODE), 10, "boot-up of node 0x7F")

        # identity and strings
        assert struct.unpack("<I", sdo_read(bus, NODE, 0x1018, 1))[0] == 0x00000362
        assert struct.unpack("<I", sdo_read(bus, NODE, 0x1018, 2))[0] == 0x00443150
        assert struct.unpack("<I", sdo_read(bus, NODE, 0x1018, 3))[0] == 0x00010000
        serial = struct.unpack("<I", sdo_read(bus, NODE, 0x1018, 4))[0]
        assert struct.unpack("<I", sdo_read(bus, NODE, 0x200E, 0))[0] == serial
        assert sdo_read(bus, NODE, 0x1008, 0).rstrip(b"\0") == b"DPS"
        assert sdo_read(bus, NODE, 0x6132, 1)[0] == 3
        assert struct.unpack("<I", sdo_read(bus, NODE, 0x6131, 1))[0] == 0x00AB0000

        # NMT start: TPDO1 every 100 ms, INTEGER32 psi x 1000 around 50 psi
        it.nmt(bus, 0x01, NODE)
        it.expect(bus, it.has_id(0x1FF), it.scaled(1), "first PDO")
        msgs, values = pdo_values(bus, NODE, 2.0)
        assert len(msgs) >= 10, f"{len(msgs)} PDOs in 2 s"
        gaps = [b.timestamp - a.timestamp for a, b in zip(msgs, msgs[1:])]
        mean = sum(gaps) / len(gaps)
        assert 0.09 < mean < 0.11 + 0.02 * it.SCALE, f"PDO period {mean:.3f} s"
        assert all(40000 < v < 60000 for v in values), f"psi x 1000: {values}"
        it.log(f"PDO: {len(msgs)} frames, mean period {mean * 1000:.1f} ms, psi x 1000 {values[:3]}")

        # unit change to bar (manual Table 19): the next PDO carries bar x 1000
        sdo_write(bus, NODE, 0x6131, 1, bytes([0x00, 0x00, 0x4E, 0x00]))
        it.drain(bus)
        _, values = pdo_values(bus, NODE, 0.5)
        assert values and all(2700 < v < 4200 for v in values), f"bar x 1000: {values}"
        sdo_write(bus, NODE, 0x6131, 1, bytes([0x00, 0x00, 0xAB, 0x00]))

        # LSS: inquire, configure node-ID, store, reset -> boot-up on the new ID
        it.nmt(bus, 0x80, NODE)
        it.drain(bus)
        it.lss(bus, 0x04, [0x01])
        it.lss(bus, 0x5A)
        assert struct.unpack_from("<I", bytes(it.lss_expect(bus, 0x5A, it.scaled(2)).data), 1)[0] == 0x00000362
        it.lss(bus, 0x5D)
        assert struct.unpack_from("<I", bytes(it.lss_expect(bus, 0x5D, it.scaled(2)).data), 1)[0] == serial
        it.lss(bus, 0x5E)
        assert bytes(it.lss_expect(bus, 0x5E, it.scaled(2)).data)[1] == NODE
        it.lss(bus, 0x11, [NEW_NODE])
        assert bytes(it.lss_expect(bus, 0x11, it.scaled(2)).data)[1] == 0, "configure node-ID"
        it.lss(bus, 0x17)
        assert bytes(it.lss_expect(bus, 0x17, it.scaled(2)).data)[1] == 0, "store configuration"
        it.lss(bus, 0x04, [0x00])
        it.nmt(bus, 0x81, NODE)
        it.expect(bus, it.is_bootup(NEW_NODE), it.scaled(2), "boot-up on the new node-ID")
        assert struct.unpack("<I", sdo_read(bus, NEW_NODE, 0x1018, 1))[0] == 0x00000362
        it.nmt(bus, 0x01, NEW_NODE)
        it.expect(bus, it.has_id(0x180 + NEW_NODE), it.scaled(1), "PDO on 0x1A2")
        assert d.stop() == 0

        # the LSS-stored node-ID survives a restart
        again = it.Daemon(ctx.require_cansimd(), args, name="again", state_dir=d.state_dir)
        ctx.daemons.append(again)
        it.drain(bus)
        again.start()
        it.expect(bus, it.is_bootup(NEW_NODE), 10, "boot-up on the stored node-ID after restart")
        assert again.stop() == 0


it.main(test)
