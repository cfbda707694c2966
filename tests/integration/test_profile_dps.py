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
    d = it.sdo_exchange(bus, node, struct.pack("<BHB", 0x40, index, sub), f"SDO answer 0x{index:04X}:{sub}")
    assert len(d) == 8, d.hex()
    assert d[0] != 0x80, f"abort 0x{struct.unpack_from('<I', d, 4)[0]:08X} on 0x{index:04X}:{sub}"
    assert d[0] == 0x60 or d[0] & 0xF3 == 0x43, d.hex()
    assert struct.unpack_from("<HB", d, 1) == (index, sub), d.hex()
    return d[4:8]


def sdo_write(bus, node: int, index: int, sub: int, data: bytes) -> None:
    d = it.sdo_exchange(bus, node, struct.pack("<BHB", 0x22, index, sub) + data.ljust(4, b"\0"),
                        f"SDO answer 0x{index:04X}:{sub}")
    assert d == struct.pack("<BHB", 0x60, index, sub) + b"\0" * 4, d.hex()


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
        msgs, values = it.tpdo_i32(bus, NODE, 2.0)
        assert len(msgs) >= 10, f"{len(msgs)} PDOs in 2 s"
        mean = it.mean_gap(msgs)
        assert 0.09 < mean < 0.11 + 0.02 * it.SCALE, f"PDO period {mean:.3f} s"
        assert all(40000 < v < 60000 for v in values), f"psi x 1000: {values}"
        it.log(f"PDO: {len(msgs)} frames, mean period {mean * 1000:.1f} ms, psi x 1000 {values[:3]}")

        # unit change to bar (manual Table 19): the next PDO carries bar x 1000
        sdo_write(bus, NODE, 0x6131, 1, bytes([0x00, 0x00, 0x4E, 0x00]))
        it.drain(bus)
        _, values = it.tpdo_i32(bus, NODE, 0.5)
        assert values and all(2700 < v < 4200 for v in values), f"bar x 1000: {values}"
        sdo_write(bus, NODE, 0x6131, 1, bytes([0x00, 0x00, 0xAB, 0x00]))

        # LSS: inquire, configure node-ID, store, reset -> boot-up on the new ID
        it.nmt(bus, 0x80, NODE)
        it.drain(bus)
        it.lss(bus, 0x04, [0x01])
        assert struct.unpack_from("<I", bytes(it.lss_reply(bus, 0x5A).data), 1)[0] == 0x00000362
        assert struct.unpack_from("<I", bytes(it.lss_reply(bus, 0x5D).data), 1)[0] == serial
        assert bytes(it.lss_reply(bus, 0x5E).data)[1] == NODE
        assert bytes(it.lss_reply(bus, 0x11, [NEW_NODE]).data)[1] == 0, "configure node-ID"
        assert bytes(it.lss_reply(bus, 0x17).data)[1] == 0, "store configuration"
        it.lss(bus, 0x04, [0x00])
        it.nmt(bus, 0x81, NODE)
        it.expect(bus, it.is_bootup(NEW_NODE), it.scaled(2), "boot-up on the new node-ID")
        assert struct.unpack("<I", sdo_read(bus, NEW_NODE, 0x1018, 1))[0] == 0x00000362
        it.nmt(bus, 0x01, NEW_NODE)
        it.expect(bus, it.has_id(0x180 + NEW_NODE), it.scaled(1), "PDO on 0x1A2")
        assert d.stop() == 0

        # the LSS-stored node-ID survives a restart
        it.drain(bus)
        again = it.restart_daemon(ctx, d)
        it.expect(bus, it.is_bootup(NEW_NODE), 10, "boot-up on the stored node-ID after restart")
        assert again.stop() == 0


it.main(test)
