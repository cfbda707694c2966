#!/usr/bin/env python3
"""cansimd with one ADZ NAGANO SMC (profiles/smc.yaml) on vcan0 at its default
125 kbit/s, node-ID 0x20, against an independent master written here:
identity and string reads, NMT start -> TPDO1 on 0x1A0 every 100 ms (DLC 4,
REAL32 PV = field value counts by default), a scaling change (PV range
0..5 bar) seen in the next TPDO (the SMC's unit object is informational only),
then LSS (inquire node-ID, configure node-ID 0x21, store) + NMT Reset Node to
the old ID -> boot-up on 0x721 with the TPDO COB-ID unchanged (0x1A0)."""

import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x20


def test(ctx: it.Context) -> None:
    d = it.single_node_daemon(ctx, ctx.source("profiles/smc.yaml"), 125, "smc")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        it.expect(bus, it.is_bootup(NODE), 10, "boot-up of node 0x20")
        it.expect_none(bus, it.is_tpdo(NODE, 1), 1.0, "TPDO before NMT start (0x1F80 = 0)")

        sdo = it.SdoClient(bus, NODE, timeout=it.scaled(2.0))
        assert sdo.upload_u32(0x1000) == 0x80020194
        assert sdo.upload_u8(0x1018, 0) == 4
        assert sdo.upload_u32(0x1018, 1) != 0, "vendor-ID must be non-zero"
        assert sdo.upload_str(0x1008) == "SMC"
        assert sdo.upload_str(0x100A) == "v1826"
        assert sdo.upload_u32(0x1801, 1) == 0xC00002A0, "TPDO2 disabled"
        code = it.SdoClient.abort_code_of(lambda: sdo.download_u8(0x1800, 2, 0xFC))
        assert code == 0x06090030, f"transmission type 0xFC: {code!r}"
        it.log("identity, strings, TPDO settings ok")

        # Start: TPDO1 every 100 ms, REAL32 PV in FV counts (~2.5 bar of 0..5 -> ~10000).
        it.drain(bus)
        it.nmt(bus, it.NMT_START, NODE)
        pdos = it.collect(bus, 1.0 + it.scaled(0.2), it.is_tpdo(NODE, 1))
        assert len(pdos) >= 8, [it.fmt(m) for m in pdos]
        assert all(len(m.data) == 4 for m in pdos), [it.fmt(m) for m in pdos]
        mean = it.mean_gap(pdos)
        assert 0.08 < mean < 0.1 + 0.02 * it.SCALE, it.gaps(pdos)
        counts = struct.unpack("<f", bytes(pdos[-1].data))[0]
        assert 8000 < counts < 12000, f"PV {counts} counts"
        assert not it.collect(bus, 0.3, it.has_id(0x2A0)), "nothing on TPDO2"
        it.log(f"TPDO1 every ~{mean * 1000:.0f} ms, PV {counts:.1f} counts")

        # Scaling to 0..5 (bar): PV1 = 0, PV2 = 5.0, seen in the next TPDO.
        sdo.download_f32(0x6121, 1, 0.0)
        sdo.download_f32(0x6123, 1, 5.0)
        it.drain(bus)
        m = it.expect(bus, it.is_tpdo(NODE, 1), it.scaled(2.0), "TPDO after the scaling change")
        bar = struct.unpack("<f", bytes(m.data))[0]
        assert 2.0 < bar < 3.0, f"pressure {bar} bar"
        assert abs(sdo.upload_f32(0x6126, 1) - 5.0 / 20000) < 1e-9, "gain follows PV1/PV2"
        it.log(f"scaled: {bar:.4f} bar")

        # LSS (§8.3): configure node-ID 0x21, store, NMT Reset Node to the OLD ID.
        it.lss(bus, 0x04, [0x01])
        r = it.lss_reply(bus, 0x5E)
        assert r.data[1] == NODE, it.fmt(r)
        r = it.lss_reply(bus, 0x11, [0x21])
        assert bytes(r.data[:2]) == b"\x11\x00", it.fmt(r)
        r = it.lss_reply(bus, 0x17)
        assert bytes(r.data[:2]) == b"\x17\x00", it.fmt(r)
        assert sdo.upload_u32(0x1000) == 0x80020194, "old ID answers until the reset"
        it.drain(bus)
        it.nmt(bus, 0x81, NODE)
        it.expect(bus, it.is_bootup(0x21), it.scaled(2.0), "boot-up on 0x721")
        sdo21 = it.SdoClient(bus, 0x21, timeout=it.scaled(2.0))
        assert sdo21.upload_u32(0x1800, 1) == 0x400001A0, "TPDO COB-ID unchanged"
        it.nmt(bus, it.NMT_START, 0x21)
        it.expect(bus, it.has_id(0x1A0), it.scaled(2.0), "TPDO still on 0x1A0")
        it.log("LSS node-ID 0x21 + store + reset node: boot-up on 0x721, TPDO on 0x1A0")

        # Stored: after a restart the node boots on 0x721 again.
        assert d.stop() == 0
        it.drain(bus)
        again = it.restart_daemon(ctx, d)
        it.expect(bus, it.is_bootup(0x21), 10, "boot-up on 0x721 after restart")
        assert again.stop() == 0
        it.log("restart keeps node-ID 0x21")


it.main(test)
