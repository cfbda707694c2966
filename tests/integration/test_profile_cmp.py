#!/usr/bin/env python3
"""Trafag CMP profile (profiles/cmp.yaml) on vcan0 against an independent
master: boot-up on 0x701, identity and string reads, the manual's example
SDOs, NMT start -> TPDO1 (mapping mode 5, INTEGER32 bar x 1000) every 100 ms,
unit change to kPa seen in the next PDO, LSS switch selective with revision 0
(the manual's simplification), inquire / configure node-ID / store / reset
-> boot-up on the new node-ID, SDO and PDO there."""

import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x01
NEW_NODE = 0x21
VENDOR, PRODUCT = 0x00CA5D00, 0x00008270  # placeholder identity of profiles/cmp.yaml


def lss_u32(bus, cs: int, value: int) -> None:
    it.lss(bus, cs, struct.pack("<I", value))


def test(ctx: it.Context) -> None:
    args = ("--profile", ctx.source("profiles/cmp.yaml"), "--interface", "vcan0", "--state-dir", "{state_dir}")
    d = ctx.start_daemon(*args)
    with it.open_bus("vcan0") as bus:
        it.expect(bus, it.is_bootup(NODE), 10, "boot-up of node 1")
        it.expect_none(bus, it.has_id(0x181), 1.0, "PDO before NMT start (Auto-Start off)")
        sdo = it.SdoClient(bus, NODE)

        # identity and strings
        assert sdo.upload_u32(0x1000) == 0x00020194
        assert sdo.upload_u32(0x1018, 1) == VENDOR
        assert sdo.upload_u32(0x1018, 2) == PRODUCT
        serial = sdo.upload_u32(0x1018, 4)
        revision = sdo.upload_u32(0x1018, 3)
        assert sdo.upload_str(0x1008).startswith("CMP"), sdo.upload_str(0x1008)
        assert sdo.upload_str(0x100A)
        assert sdo.upload_u16(0x2001) == 20  # kbit/s
        assert sdo.upload_u8(0x2100, 1) == 5

        # manual examples: read P as FLOAT, T as INT_16, read-only write abort
        d_p = it.sdo_exchange(bus, NODE, bytes([0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0]))
        assert d_p[:4] == bytes([0x43, 0x30, 0x61, 0x01]), d_p.hex()
        p_bar = struct.unpack_from("<f", d_p, 4)[0]
        assert 4.0 < p_bar < 6.0, p_bar
        d_t = it.sdo_exchange(bus, NODE, bytes([0x40, 0x30, 0x71, 0x02, 0, 0, 0, 0]))
        assert d_t[:4] == bytes([0x4B, 0x30, 0x71, 0x02]) and d_t[6:] == b"\0\0", d_t.hex()
        assert 200 < struct.unpack_from("<h", d_t, 4)[0] < 300
        d_ro = it.sdo_exchange(bus, NODE, bytes([0x22, 0x00, 0x10, 0x00, 0x78, 0x56, 0x34, 0x12]))
        assert d_ro == bytes([0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06]), d_ro.hex()

        # NMT start: TPDO1 every 100 ms, INTEGER32 bar x 1000 around 5 bar
        it.nmt(bus, 0x01, NODE)
        it.expect(bus, it.has_id(0x181), it.scaled(1), "first PDO")
        msgs, values = it.tpdo_i32(bus, NODE, 2.0)
        assert len(msgs) >= 10, f"{len(msgs)} PDOs in 2 s"
        mean = it.mean_gap(msgs)
        assert 0.09 < mean < 0.11 + 0.02 * it.SCALE, f"PDO period {mean:.3f} s"
        assert all(4000 < v < 6000 for v in values), f"bar x 1000: {values}"
        it.log(f"PDO: {len(msgs)} frames, mean period {mean * 1000:.1f} ms, bar x 1000 {values[:3]}")

        # unit change to kPa (manual example bytes): the next PDO carries kPa x 1000
        d_u = it.sdo_exchange(bus, NODE, bytes([0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x03]))
        assert d_u == bytes([0x60, 0x31, 0x61, 0x01, 0, 0, 0, 0]), d_u.hex()
        it.drain(bus)
        _, values = it.tpdo_i32(bus, NODE, 0.5)
        assert values and all(400000 < v < 600000 for v in values), f"kPa x 1000: {values}"
        sdo.download_u32(0x6131, 1, 0x004E0000)

        # LSS: selective switch ignoring the revision, inquire, configure, store, reset
        it.nmt(bus, 0x80, NODE)
        it.drain(bus)
        lss_u32(bus, 0x40, VENDOR)
        lss_u32(bus, 0x41, PRODUCT)
        lss_u32(bus, 0x42, 0x00000000)  # "revision number could be ignored with 0000'0000h"
        lss_u32(bus, 0x43, serial)
        it.lss_expect(bus, 0x44, it.scaled(2))
        assert struct.unpack_from("<I", bytes(it.lss_reply(bus, 0x5C).data), 1)[0] == revision
        assert bytes(it.lss_reply(bus, 0x5E).data)[1] == NODE
        assert bytes(it.lss_reply(bus, 0x11, [NEW_NODE]).data)[1] == 0, "configure node-ID"
        assert bytes(it.lss_reply(bus, 0x17).data)[1] == 0, "store configuration"
        it.lss(bus, 0x04, [0x00])
        it.nmt(bus, 0x81, NODE)
        it.expect(bus, it.is_bootup(NEW_NODE), it.scaled(2), "boot-up on the new node-ID")
        assert it.SdoClient(bus, NEW_NODE).upload_u32(0x1018, 1) == VENDOR
        it.nmt(bus, 0x01, NEW_NODE)
        it.expect(bus, it.has_id(0x180 + NEW_NODE), it.scaled(1), "PDO on 0x1A1")
        assert d.stop() == 0


it.main(test)
