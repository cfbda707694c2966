#!/usr/bin/env python3
"""cansimd with one Gems Series 9000 (profiles/gems9000.yaml) on vcan0 at its
default 250 kbit/s, node-ID 1, against an independent master written here:
identity and string reads (expedited only, answers 0x42), NMT start -> one
DLC-8 PDO per SYNC (INT16 pressure, INT16 temperature), none without SYNC,
unit changes (degF, psi via 0x2032) seen in the next PDO, then LSS in NMT
stopped (inquire is not a DSP 305 v1.0 service: no answer; configure node-ID
0x0A, store, back to operation mode) -> reset communication -> boot-up on
0x70A, and after a daemon restart the node boots on 0x70A again (stored)."""

import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

def upload_raw(bus, node, index, sub):
    """Expedited upload by hand: the whole 8-byte answer."""
    return it.sdo_exchange(bus, node, struct.pack("<BHB", 0x40, index, sub), f"SDO answer 0x{index:04X}:{sub}")


def value(bus, node, index, sub, fmt):
    r = upload_raw(bus, node, index, sub)
    assert r[0] == 0x42 and r[1:4] == struct.pack("<HB", index, sub), r.hex()
    return struct.unpack_from(fmt, r, 4)[0]


def sync_pdos(bus, node, n):
    out = []
    for _ in range(n):
        it.drain(bus)
        it.send(bus, 0x080)
        out.append(it.expect(bus, it.has_id(0x180 + node), it.scaled(1.0), "PDO after SYNC"))
    return out


def test(ctx: it.Context) -> None:
    d = it.single_node_daemon(ctx, ctx.source("profiles/gems9000.yaml"), 250, "gems")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        boot = it.expect(bus, it.is_bootup(1), 10, "boot-up of node 1")
        assert len(boot.data) == 1, it.fmt(boot)

        # Identity and strings: every upload is answered 0x42 (size not indicated).
        assert upload_raw(bus, 1, 0x1000, 0) == bytes([0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00])
        assert value(bus, 1, 0x1018, 0, "<B") == 4
        assert value(bus, 1, 0x1018, 4, "<I") != 0, "serial number"
        assert upload_raw(bus, 1, 0x2800, 1)[4:8] == b"2801", "last calibration ddmm"
        assert upload_raw(bus, 1, 0x2801, 2)[4:8] == b"2003", "next calibration yyyy"
        assert upload_raw(bus, 1, 0x2000, 0)[4:8] == b"GEMS"
        r = upload_raw(bus, 1, 0x1008, 0)
        assert r[0] == 0x80 and struct.unpack_from("<I", r, 4)[0] == 0x06020000, r.hex()
        r = upload_raw(bus, 1, 0x5130, 1)  # 8-byte string: expedited only
        assert r[0] == 0x80 and struct.unpack_from("<I", r, 4)[0] == 0x08000000, r.hex()
        assert value(bus, 1, 0x6132, 1, "<B") == 3 and value(bus, 1, 0x6132, 2, "<B") == 1
        it.log("identity, strings, aborts ok")

        # Start: type 1 = one PDO per SYNC, nothing without SYNC.
        it.nmt(bus, it.NMT_START, 0)
        it.expect_none(bus, it.has_id(0x181), 1.0, "PDO without SYNC")
        pdos = sync_pdos(bus, 1, 5)
        assert all(len(m.data) == 8 and bytes(m.data[4:]) == b"\0\0\0\0" for m in pdos), [it.fmt(m) for m in pdos]
        p, t = struct.unpack_from("<hh", bytes(pdos[-1].data))
        assert 2000 < p < 3000, f"pressure {p} x 0.001 bar"  # the profile's process: ~2.5 bar
        assert 150 < t < 300, f"temperature {t} x 0.1 degC"
        it.log(f"PDO: {p / 1000:.3f} bar, {t / 10:.1f} degC")

        # Temperature in degF (non-SI code, Fig. 34), pressure in psi via 0x2032.
        sdo = it.SdoClient(bus, 1, timeout=it.scaled(2.0))
        sdo.download_u32(0x6131, 2, 0x00A00000)
        t_f = struct.unpack_from("<h", bytes(sync_pdos(bus, 1, 1)[0].data), 2)[0]
        assert abs(t_f - (t * 1.8 + 320)) < 60, f"{t_f} x 0.1 degF after {t} x 0.1 degC"
        sdo.download_u32(0x2032, 0, 0x3D8D3466)
        sdo.download_u32(0x6131, 1, 0x00A00000)
        assert value(bus, 1, 0x6132, 1, "<B") == 2
        p_psi = struct.unpack_from("<h", bytes(sync_pdos(bus, 1, 1)[0].data), 0)[0]
        assert abs(p_psi - p / 1000 / 0.0689476 * 100) < 300, f"{p_psi} x 0.01 psi after {p} x 0.001 bar"
        it.log(f"units: {t_f / 10:.1f} degF, {p_psi / 100:.2f} psi")

        # LSS: ignored outside STOPPED (Table 4).
        it.lss(bus, 0x04, [0x01])
        it.lss(bus, 0x11, [0x0A])
        it.expect_none(bus, it.has_id(it.LSS_RX), it.scaled(0.5), "LSS answer while operational")
        it.nmt(bus, it.NMT_STOP, 1)
        it.lss(bus, 0x04, [0x01])
        it.lss(bus, 0x5E)
        it.expect_none(bus, it.has_id(it.LSS_RX), it.scaled(0.5), "LSS inquire (not a DSP 305 v1.0 service)")
        r = it.lss_reply(bus, 0x13, [0x04, 0x00])  # the manual's layout: index in byte 1
        assert bytes(r.data) == bytes([0x13, 0, 0, 0, 0, 0, 0, 0]), it.fmt(r)
        r = it.lss_reply(bus, 0x13, [0x00, 0x03])  # CiA 305 layout, back to 250 k
        assert bytes(r.data[:2]) == b"\x13\x00", it.fmt(r)
        r = it.lss_reply(bus, 0x11, [0x80])
        assert bytes(r.data[:2]) == b"\x11\x01", it.fmt(r)
        r = it.lss_reply(bus, 0x11, [0x0A])
        assert bytes(r.data) == bytes([0x11, 0, 0, 0, 0, 0, 0, 0]), it.fmt(r)
        r = it.lss_reply(bus, 0x17)
        assert bytes(r.data) == bytes([0x17, 0, 0, 0, 0, 0, 0, 0]), it.fmt(r)
        it.lss(bus, 0x04, [0x00])
        it.drain(bus)
        it.nmt(bus, 0x82, 1)
        m = it.expect(bus, lambda x: x.arbitration_id in (0x701, 0x70A), it.scaled(2.0), "boot-up after reset comm")
        assert m.arbitration_id == 0x70A and bytes(m.data) == b"\x00", it.fmt(m)
        assert value(bus, 0x0A, 0x1000, 0, "<I") == 0x00020194
        it.log("LSS: node-ID 0x0A active after reset communication")

    assert d.stop() == 0
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        m = it.expect(bus, lambda x: x.arbitration_id in (0x701, 0x70A), 10, "boot-up after restart")
        assert m.arbitration_id == 0x70A, it.fmt(m)
        it.log("stored node-ID 0x0A survives a daemon restart")
    assert d.stop() == 0


it.main(test)
