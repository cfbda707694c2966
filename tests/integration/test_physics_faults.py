#!/usr/bin/env python3
"""Physics and scheduled faults on a real CAN stack.

1. A Honeywell DPS whose pressure ramps from 10 to 90 psi over 40 s sends
   rising TPDO1 values (INTEGER32, psi x 10^digits); a sensor-open fault scheduled 8 s after
   start produces the manual's EMCY 0x2201 on vcan0, and its end the error
   reset 0x0000.
2. A generic-404 node with a power cycle scheduled 8 s after start: the
   boot-up comes again, the stored 0x1017 (saved with 0x1010) is kept, the
   unsaved scratch value 0x2100:01 is lost. Nothing is sent while it is off.

Times in a profile count from the daemon's start (simulated time 0)."""

# ctest-timeout: 240

import os
import re
import struct
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

DPS = 0x7F
GENERIC = 0x10


def profile_with(ctx: it.Context, name: str, physics: str, faults: str, out_dir: str) -> str:
    """profiles/<name>.yaml with its physics: and faults: sections replaced."""
    text = open(ctx.source("profiles", name + ".yaml")).read()
    text = re.sub(r"^physics:\n(?:[ #].*\n)*", physics.strip() + "\n", text, count=1, flags=re.M)
    text = re.sub(r"^faults:.*\n(?:[ #-].*\n)*", faults.strip() + "\n", text, count=1, flags=re.M)
    path = os.path.join(out_dir, name + "-it.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def ramp_and_sensor_fault(ctx: it.Context, bus) -> None:
    profile = profile_with(ctx, "dps", """
physics:
  pressure:
    - ramp: {from: 10 psi, to: 90 psi, start: 0 s, duration: 40 s}
  temperature:
    - constant: 25 degC
""", """
faults:
  - {kind: open, channel: pressure, at: 8 s, duration: 3 s}
""", ctx.tmp)
    started = time.monotonic()
    d = ctx.start_daemon("--profile", profile, "--interface", "vcan0", "--state-dir", "{state_dir}", name="dps")
    it.expect(bus, it.is_bootup(DPS), 10, "DPS boot-up")
    it.nmt(bus, 0x01, DPS)
    pdos = it.collect(bus, 1.5, it.is_tpdo(DPS))
    values = [struct.unpack("<i", bytes(m.data[:4]))[0] for m in pdos]
    it.log(f"{len(values)} PDOs: {values[0] if values else None} .. {values[-1] if values else None}")
    assert len(values) >= 5, f"expected TPDOs every 100 ms, got {len(values)}"
    assert all(b >= a for a, b in zip(values, values[1:])), f"PDO values must rise on the ramp: {values}"
    assert values[-1] > values[0], f"ramp of 2 psi/s not visible: {values}"
    elapsed = time.monotonic() - started
    assert elapsed < 8, f"the fault window starts 8 s after start; setup took {elapsed:.1f} s"
    emcy = it.expect(bus, it.is_emcy(DPS), 8 - elapsed + it.scaled(2), "EMCY of the open sensor")
    code, reg = it.emcy_fields(emcy)[:2]
    assert (code, reg) == (0x2201, 0x03), f"expected EMCY 0x2201 register 0x03, got {it.fmt(emcy)}"
    at = time.monotonic() - started
    assert at > 7.5, f"EMCY came {at:.1f} s after start, before the fault (8 s)"
    reset = it.expect(bus, it.is_emcy(DPS), it.scaled(3) + 3, "error reset when the sensor is back")
    assert it.emcy_fields(reset)[0] == 0x0000, f"expected the error reset EMCY, got {it.fmt(reset)}"
    assert d.stop() == 0


def power_cycle(ctx: it.Context, bus) -> None:
    profile = profile_with(ctx, "generic-404", """
physics:
  pressure:
    - constant: 5 bar
  temperature:
    - constant: 22 degC
""", """
faults:
  - {kind: power_cycle, at: 8 s, duration: 1 s}
""", ctx.tmp)
    started = time.monotonic()
    d = ctx.start_daemon("--profile", profile, "--interface", "vcan0", "--state-dir", "{state_dir}", name="generic")
    it.expect(bus, it.is_bootup(GENERIC), 10, "boot-up")
    sdo = it.SdoClient(bus, GENERIC)
    sdo.download_u16(0x1017, 0, 300)
    sdo.download(0x1010, 1, b"save")
    sdo.download_u32(0x2100, 1, 0xCAFE)  # volatile
    assert sdo.upload_u32(0x2100, 1) == 0xCAFE
    elapsed = time.monotonic() - started
    assert elapsed < 7, f"the power cycle comes 8 s after start; setup took {elapsed:.1f} s"
    it.drain(bus)
    # Heartbeats every 300 ms until the power goes, then silence, then the boot-up.
    frames = it.collect(bus, 8 - elapsed - 0.3, it.has_id(0x700 + GENERIC))
    assert frames, "heartbeats before the power cycle"
    boot = it.expect(bus, it.is_bootup(GENERIC), it.scaled(3) + 3, "boot-up after the power cycle")
    at = time.monotonic() - started
    assert at > 8.5, f"boot-up {at:.1f} s after start: the node was off for less than its 1 s"
    it.log(f"boot-up again {at:.1f} s after start: {it.fmt(boot)}")
    assert sdo.upload_u16(0x1017) == 300, "stored heartbeat time lost in the power cycle"
    assert sdo.upload_u32(0x2100, 1) == 0, "a volatile value survived the power cycle"
    beats = it.collect(bus, it.scaled(1.2) + 0.5, it.is_heartbeat(GENERIC))
    assert len(beats) >= 2, "heartbeats after the power cycle"
    assert all(m.data[0] == 0x7F for m in beats), "pre-operational after the boot-up"
    assert d.stop() == 0


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    with it.open_bus("vcan0") as bus:
        ramp_and_sensor_fault(ctx, bus)
        it.drain(bus)
        power_cycle(ctx, bus)


it.main(test)
