#!/usr/bin/env python3
"""The Python client (python/cansim) on a real kernel CAN stack: each call's
effect on the wire, seen by an independent reader (python3-can on vcan0),
and the events the client waits for matched against the frames.

One cansimd (cansim.start, a generic CiA 404 sensor at 0x10, a Honeywell
DPS at 0x7F): boot-ups on the bus before start() returns; nmt -> heartbeat
states; set / ramp / hold / override -> the TPDO1 values; fault open -> the
status bit and the DPS's EMCY 0x2201 with the EmcySent event's fields;
write 0x1017 -> the heartbeat period; read -> what an SDO upload answers;
a master's SDO write -> ObjectWritten; power_cycle -> silence, then the
boot-up; add / remove -> a new node's boot-up, a removed node's silence;
a refused call -> cansim.Refused naming the daemon's error, no frame."""

# ctest-timeout: 240

import os
import struct
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

SENSOR, DPS = 0x10, 0x7F


def pressure(m):
    """The generic node's TPDO1: REAL32 pressure (bar), status byte."""
    return struct.unpack_from("<fB", bytes(m.data))


def after(t, pred):
    """pred, for frames the kernel stamped at or after wall-clock time t."""
    return lambda m: m.timestamp >= t and pred(m)


def showing(effect):
    """The sensor's TPDO1 whose (pressure, status) shows effect(pressure, status)."""
    return lambda m: it.is_tpdo(SENSOR)(m) and bool(effect(*pressure(m)))


def test(ctx: it.Context) -> None:
    sys.path.insert(0, ctx.source("python"))
    import cansim

    cansimd = ctx.require_cansimd()
    profiles = ctx.source("profiles")
    fleet = (f"nodes:\n"
             f"  - {{profile: {profiles}/generic-404.yaml, interface: vcan0, node_id: {SENSOR}, name: pt}}\n"
             f"  - {{profile: {profiles}/dps.yaml, interface: vcan0, bit_rate: 250, name: dps}}\n")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        t0 = time.time()
        with cansim.start(fleet, binary=cansimd, timeout=it.scaled(10)) as sim:
            returned = time.time()
            boots = {m.arbitration_id - 0x700: m.timestamp for m in it.collect(bus, 0.3)
                     if 0x700 < m.arbitration_id < 0x780 and m.data == b"\0"}
            assert set(boots) == {SENSOR, DPS} and max(boots.values()) <= returned, \
                f"boot-ups {boots}, start() returned at {returned}"
            it.log("start: both boot-ups on the bus before start() returned")
            pt, dps = sim.node("pt"), sim.node("dps")

            for command, state in (("start", 0x05), ("stop", 0x04), ("pre-operational", 0x7F), ("start", 0x05)):
                t = time.time()
                pt.nmt(command)
                it.expect(bus, after(t, it.is_heartbeat(SENSOR, state)), it.scaled(2.5), f"heartbeat 0x{state:02X}")
                assert pt.nmt_state == {0x05: "operational", 0x04: "stopped", 0x7F: "pre-operational"}[state]
            it.log("nmt: start / stop / pre-operational -> heartbeat states 05 / 04 / 7F")

            # Each effect is awaited with a bound: the first TPDO after an action
            # may have been sampled before it (the sensor's pace, the frame in flight).
            t = time.time()
            pt.pressure.set(2.0, "bar")
            m = it.expect(bus, after(t, showing(lambda v, s: abs(v - 2.0) < 0.05)), it.scaled(1), "TPDO1 of 2 bar after set")
            pt.pressure.set(6.0, "bar", ramp=1.0)
            t = time.time()
            ramp = [pressure(m)[0] for m in it.collect(bus, it.scaled(1) + 0.5, after(t, it.is_tpdo(SENSOR)))]
            assert ramp and ramp[0] < 5 and abs(ramp[-1] - 6.0) < 0.05, f"ramp 2 -> 6 bar: {ramp}"
            assert all(b > a - 0.05 for a, b in zip(ramp, ramp[1:])), f"the ramp must rise: {ramp}"
            pt.pressure.set(3.0, "bar", ramp=100)
            time.sleep(0.2)
            pt.pressure.hold()
            t = time.time()
            held = [pressure(m)[0] for m in it.collect(bus, 0.5, after(t, it.is_tpdo(SENSOR)))]
            assert held and max(held) - min(held) < 0.02, f"hold: {held}"
            t = time.time()
            pt.pressure.override(12.5, "bar")
            m = it.expect(bus, after(t, showing(lambda v, s: abs(v - 12.5) < 1e-3)), it.scaled(1),
                          "TPDO1 of exactly 12.5 bar after override")
            pt.pressure.clear_override()
            it.log(f"set / ramp / hold / override -> TPDO1 2.0 / {ramp[0]:.2f}..{ramp[-1]:.2f} / "
                   f"{held[0]:.3f} / 12.5 bar")

            t = time.time()
            with pt.fault("open"):
                m = it.expect(bus, after(t, showing(lambda v, s: s & 1)), it.scaled(1),
                              "TPDO1 with status bit 0 (the open sensor)")
            with dps.fault("open", channel="pressure") as fault:
                ev = dps.wait_for("EmcySent", timeout=it.scaled(2))
                m = it.expect(bus, it.is_emcy(DPS), it.scaled(2), "the DPS's EMCY")
                code, register = struct.unpack_from("<HB", bytes(m.data))
                assert (code, register) == (ev["code"], ev["register"]) == (0x2201, ev["register"]), \
                    f"EMCY {bytes(m.data).hex()} / event {ev}"
                assert bytes(m.data[3:]) == ev["vendor"] and dps.last_emcy.code == 0x2201
                assert dps.wait_for("FaultStarted").fields["id"] == fault.id
            m = it.expect(bus, lambda m: it.is_emcy(DPS)(m) and bytes(m.data[:2]) == b"\0\0", it.scaled(2),
                          "the DPS's error reset (EMCY 0x0000)")
            assert dps.wait_for("EmcySent", code=0)
            it.log("fault open -> status bit 0 in TPDO1, EMCY 0x2201 (= EmcySent), error reset on cancel")

            pt.write(0x1017, 0, 200)
            t = time.time()
            beats = it.collect(bus, it.scaled(1), after(t, it.is_heartbeat(SENSOR)))
            gaps = [b.timestamp - a.timestamp for a, b in zip(beats, beats[1:])]
            # the median: one late wake-up of the guest makes one gap long and the next short
            assert len(beats) >= 4 and 0.15 < sorted(gaps)[len(gaps) // 2] < 0.25, f"heartbeat gaps {gaps}"
            sdo = it.SdoClient(bus, SENSOR, timeout=it.scaled(1))
            assert sdo.upload_u16(0x1017) == pt.read(0x1017) == 200
            assert sdo.upload_u32(0x1018, 4) == pt.read(0x1018, 4)
            mark = sim.mark()
            sdo.download_u16(0x1017, 0, 1000)
            written = pt.wait_for("ObjectWritten", since=mark, index=0x1017, timeout=it.scaled(2))
            assert (written["sub"], written["value"], written["via"]) == (0, 1000, "sdo"), written
            it.log(f"write 0x1017 = 200 -> heartbeat every {sorted(gaps)[len(gaps) // 2] * 1000:.0f} ms; read = SDO upload; "
                   "SDO download -> ObjectWritten")

            t = time.time()
            pt.power_cycle(off=1.0)
            returned = time.time()  # what the node sent before the power-off is stamped before this
            first = it.expect(bus, after(returned, lambda m: m.arbitration_id & 0x7F == SENSOR and m.arbitration_id > 0x80),
                              it.scaled(3), "the first frame after the power cycle")
            assert it.is_bootup(SENSOR)(first) and first.timestamp - t >= 1.0, \
                f"first frame {it.fmt(first)} {first.timestamp - t:.3f} s after power-off"
            boot = pt.wait_for("BootUp", timeout=it.scaled(2))
            assert boot["node_id"] == SENSOR
            it.log(f"power_cycle(1 s) -> silent, boot-up after {first.timestamp - t:.2f} s (BootUp event)")

            t = time.time()
            (extra,) = sim.add(f"{{profile: {profiles}/generic-404.yaml, interface: vcan0, node_id: 0x30, name: extra}}")
            it.expect(bus, after(t, it.is_bootup(0x30)), it.scaled(2), "the added node's boot-up")
            assert extra.wait_for("BootUp")["node_id"] == 0x30
            sim.remove(extra)
            t = time.time()
            it.expect_none(bus, after(t, lambda m: m.arbitration_id & 0x7F == 0x30), 1.5, "frames of the removed node")
            it.log("add -> boot-up of 0x30; remove -> silence")

            t = time.time()
            try:
                pt.pressure.set(1.0, "furlong")
                raise AssertionError("a bad unit must be refused")
            except cansim.Refused as e:
                assert e.name == "io.cansim.Error.UnknownUnit", e
            try:
                sim.node("vcan0/0x55")
                raise AssertionError("an unknown node must be refused")
            except cansim.NoSuchNode:
                pass
            it.log("bad unit -> cansim.Refused(io.cansim.Error.UnknownUnit); unknown node -> cansim.NoSuchNode")
        it.log(f"cansimd stopped cleanly; {time.time() - t0:.1f} s in all")


it.main(test)
