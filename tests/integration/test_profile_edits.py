#!/usr/bin/env python3
"""Edited profiles on the real kernel, a sample of what
tests/unit/profile_edits_test.cpp runs for every object of every profile:
a profile without an object its personality needs is refused by
`cansimd --check` naming the object; profiles without objects their
personality can do without run: boot-up, NMT start, SDO reads, PDOs, and a
fault armed with cansimctl gives its EMCY, while the daemon stays up."""

import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

P92C, DPS = 0x01, 0x7F


def edited(ctx: it.Context, name: str, drop: tuple) -> str:
    """profiles/<name>.yaml without the `objects:` lines of the indices in `drop`."""
    with open(ctx.source("profiles", name + ".yaml")) as f:
        lines = [l for l in f if not any(f"index: {i}," in l for i in drop)]
    path = os.path.join(ctx.tmp, f"{name}-edited.yaml")
    with open(path, "w") as f:
        f.writelines(lines)
    return path


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    cansimd = ctx.require_cansimd()
    ctl = os.path.join(os.path.dirname(cansimd), "cansimctl")

    smc = edited(ctx, "smc", ("0x3125",))
    p = subprocess.run([cansimd, "--check", "--profile", smc], capture_output=True, text=True, timeout=60)
    assert p.returncode == 1, f"--check of smc without 0x3125: exit {p.returncode}: {p.stderr!r}"
    assert "smc-edited.yaml:" in p.stderr and "0x3125:01" in p.stderr and "adz-smc" in p.stderr, p.stderr
    it.log("smc without 0x3125 refused: " + p.stderr.strip())

    p92c = edited(ctx, "p92c", ("0x3000", "0x3001", "0x4E00"))
    dps = edited(ctx, "dps", ("0x200E", "0x2004", "0x2005"))
    fleet = os.path.join(ctx.tmp, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write("interfaces: {vcan0: {bit_rate: 250}}\nnodes:\n"
                f"  - {{profile: {p92c}, interface: vcan0, bit_rate: 250, name: p92c}}\n"
                f"  - {{profile: {dps}, interface: vcan0, bit_rate: 250, name: dps}}\n")
    p = subprocess.run([cansimd, "--check", "--config", fleet], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, f"--check of the edited fleet: exit {p.returncode}: {p.stderr!r}"

    sock = os.path.join(ctx.tmp, "control")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d = ctx.start_daemon("--config", fleet, "--control-socket", sock, "--bus", "none",
                             "--state-dir", "{state_dir}")
        for node in (P92C, DPS):
            it.expect(bus, it.is_bootup(node), 15, f"boot-up of node {node:#x}")
        for node in (P92C, DPS):
            # Written by hand: the DPS answers expedited uploads with 0x60 (its manual's quirk).
            r = it.sdo_exchange(bus, node, [0x40, 0x18, 0x10, 0x01], f"vendor-ID of {node:#x}")
            assert r[0] in (0x43, 0x60) and r[1:4] == bytes([0x18, 0x10, 0x01]), f"{node:#x}: {r.hex()}"
            assert int.from_bytes(r[4:8], "little") != 0, f"{node:#x}: vendor-ID 0"
        it.nmt(bus, it.NMT_START, 0)
        it.expect(bus, it.is_tpdo(P92C, 1), 5, "p92c TPDO1")
        it.send(bus, 0x080)  # the DPS's type-0 TPDO goes on SYNC after a change
        it.log("both nodes operational")
        if os.access(ctl, os.X_OK):
            it.drain(bus)
            r = subprocess.run([ctl, "--socket", sock, "fault", "p92c", "open", "--for", "2s"],
                               capture_output=True, text=True, timeout=it.scaled(20))
            assert r.returncode == 0, f"cansimctl fault: {r.returncode} {r.stderr!r}"
            it.expect(bus, it.is_emcy(P92C), 5, "p92c sensor-fault EMCY")
            it.log("fault -> EMCY")
        d.assert_alive()
        assert d.stop() == 0, "exit status"


if __name__ == "__main__":
    it.main(test)
