#!/usr/bin/env python3
# ctest-timeout: 600
"""cansimd with one Danfoss DST P92C (profiles/p92c.yaml) on vcan0 at its
default 125 kbit/s, node-ID 1, against an independent master written here:
identity and string reads, NMT start -> immediate TPDO then one per 1000 ms
(DLC 5: int32 pressure + status), a unit change (Pa -> bar, 2 digits) seen in
the next TPDO, then LSS (NMT stopped; inquire vendor / node-ID, configure
node-ID 5, store, switch to waiting) -> boot-up on 0x705, and after a daemon
restart the node boots on 0x705 again (stored)."""

import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

def test(ctx: it.Context) -> None:
    d = it.single_node_daemon(ctx, ctx.source("profiles/p92c.yaml"), 125, "p92c")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        it.expect(bus, it.is_bootup(1), 10, "boot-up of node 1")
        it.expect_none(bus, it.is_tpdo(1, 1), 1.0, "TPDO before NMT start (0x1F80 = 4)")

        sdo = it.SdoClient(bus, 1, timeout=it.scaled(2.0))
        assert sdo.upload_u32(0x1000) == 0x00020194
        assert sdo.upload_u32(0x1018, 1) == 0x23D, "Danfoss vendor-ID"
        assert sdo.upload_str(0x1008) == "DST P92C CANopen"
        assert sdo.upload_str(0x4E00, 4) == "11.223344.5566"
        assert sdo.upload_u8(0x4F00) == 4 and sdo.upload_u8(0x4F01) == 1
        assert sdo.upload_u8(0x1800, 2) == 0xFF and sdo.upload_u16(0x1800, 5) == 1000
        code = it.SdoClient.abort_code_of(lambda: sdo.download_u8(0x1800, 2, 0xFE))
        assert code == 0x06090030, f"transmission type 0xFE: {code!r}"
        it.log("identity, strings, TPDO settings ok")

        # Start: answered with a PDO at once, then cyclic at the event timer.
        it.drain(bus)
        it.nmt(bus, it.NMT_START, 1)
        pdos = it.collect(bus, 2.5 + it.scaled(0.3), it.is_tpdo(1, 1))
        assert len(pdos) >= 3, [it.fmt(m) for m in pdos]
        assert all(len(m.data) == 5 for m in pdos), [it.fmt(m) for m in pdos]
        gaps = it.gaps(pdos[1:])
        assert all(0.8 < g < 1.0 + 0.1 * it.SCALE for g in gaps), gaps
        pa = struct.unpack("<i", bytes(pdos[-1].data[:4]))[0]
        assert 50e5 < pa < 150e5, f"pressure {pa} Pa"  # the profile's process: ~100 bar
        it.log(f"TPDO every ~{sum(gaps) / len(gaps) * 1000:.0f} ms, {pa} Pa")

        # Unit change: bar with 2 decimal digits, visible in the next TPDO.
        sdo.download_u32(0x6131, 1, 0x004E0000)
        sdo.download_u8(0x6132, 1, 2)
        it.drain(bus)
        m = it.expect(bus, it.is_tpdo(1, 1), it.scaled(2.0), "TPDO after the unit change")
        centibar = struct.unpack("<i", bytes(m.data[:4]))[0]
        assert 5000 < centibar < 15000, f"pressure {centibar} x 0.01 bar"
        assert abs(sdo.upload_f32(0x6149, 1) - 250.0) < 1e-3, "span end follows the unit"
        it.log(f"bar/2 digits: {centibar / 100:.2f} bar")

        # LSS (§4.2): only in NMT stopped.
        it.nmt(bus, it.NMT_STOP, 0)
        it.lss(bus, 0x04, [0x01])
        r = it.lss_reply(bus, 0x5A)
        assert bytes(r.data) == bytes([0x5A, 0x3D, 0x02, 0, 0, 0, 0, 0]), it.fmt(r)
        r = it.lss_reply(bus, 0x11, [0x05])
        assert bytes(r.data[:3]) == b"\x11\x00\x00", it.fmt(r)
        r = it.lss_reply(bus, 0x5E)
        assert r.data[1] == 1, "inquire node-ID returns the stored one"
        r = it.lss_reply(bus, 0x17)
        assert bytes(r.data[:3]) == b"\x17\x00\x00", it.fmt(r)
        it.drain(bus)
        it.lss(bus, 0x04, [0x00])
        it.expect(bus, it.is_bootup(5), it.scaled(2.0), "boot-up on the new node-ID")
        sdo5 = it.SdoClient(bus, 5, timeout=it.scaled(2.0))
        assert sdo5.upload_u8(0x4F01) == 5
        assert sdo5.upload_u32(0x1014) == 0x85
        it.log("LSS configure node-ID 5 + store + waiting: boot-up on 0x705")

        # Stored: the node comes back on 0x705 after a restart.
        assert d.stop() == 0
        it.drain(bus)
        again = it.restart_daemon(ctx, d)
        it.expect(bus, it.is_bootup(5), 10, "boot-up on 0x705 after restart")
        it.nmt(bus, it.NMT_START, 5)
        it.expect(bus, it.is_tpdo(5, 1), it.scaled(2.0), "TPDO on 0x185")
        assert again.stop() == 0
        it.log("restart keeps node-ID 5")


it.main(test)
