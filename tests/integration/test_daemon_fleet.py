#!/usr/bin/env python3
"""cansimd --config: two nodes on vcan0 and one on vcan1 each boot on their
own bus; SIGHUP adds a node without disturbing the others (no boot-up, no
heartbeat gap); a config error at reload keeps the fleet running;
SIGTERM -> exit 0.

Device descriptions (test_eds): a fleet with one node from the EDS that
`cansimd --export-eds` wrote of generic-404 and one from the YAML profile;
every object of the EDS is SDO-read from both and compared ($NODEID values
relative to each node's ID; the CiA 404 measured values, whose physics
differ, by size only); started, the EDS node sends its TPDO1 as its 0x1800
says. `cansimctl dcf` of the EDS node, after an SDO write,
then runs as a node of its own on vcan1: its node-ID and the written value
come from the DCF."""

import os
import re
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

BASE = """
interfaces:
  vcan0: {{bit_rate: 250}}
  vcan1: {{bit_rate: 250}}
nodes:
  - {{profile: {profile}, interface: vcan0, node_id: 0x21, count: 2, name: a}}
  - {{profile: {profile}, interface: vcan1, node_id: 0x31, name: b}}
"""
EXTRA = "  - {{profile: {profile}, interface: vcan0, node_id: 0x25, name: c}}\n"


def test(ctx: it.Context) -> None:
    profile = ctx.source("profiles/generic-404.yaml")
    d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}")
    cfg = os.path.join(d.state_dir, "fleet.yaml")
    with open(cfg, "w") as f:
        f.write(BASE.format(profile=profile))
    with it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
        it.drain(bus0)
        it.drain(bus1)
        d.start()
        seen0 = set()
        deadline = time.monotonic() + it.scaled(10)
        while seen0 != {0x21, 0x22} and time.monotonic() < deadline:
            m = it.wait_for(bus0, lambda m: 0x701 <= m.arbitration_id <= 0x77F and bytes(m.data) == b"\0", 1)
            if m:
                seen0.add(m.arbitration_id - 0x700)
        assert seen0 == {0x21, 0x22}, f"boot-ups on vcan0: {sorted(seen0)}"
        it.expect(bus1, it.is_bootup(0x31), 10, "boot-up of node 0x31 on vcan1")
        for n in (0x21, 0x22):
            it.expect_none(bus1, it.is_heartbeat(n), 0.1, f"node 0x{n:02X} on vcan1")
        it.log("two nodes on vcan0, one on vcan1")

        # Faster heartbeats so a glitch would show.
        for n in (0x21, 0x22):
            it.SdoClient(bus0, n).download_u16(0x1017, 0, 100)

        with open(cfg, "a") as f:
            f.write(EXTRA.format(profile=profile))
        it.drain(bus0)
        d.send_signal(signal.SIGHUP)
        frames = []
        deadline = time.monotonic() + it.scaled(5)
        got_new = False
        while time.monotonic() < deadline and not got_new:
            m = bus0.recv(timeout=0.5)
            if m is None:
                continue
            frames.append(m)
            got_new = it.is_bootup(0x25)(m)
        assert got_new, "boot-up of the added node 0x25"
        frames += it.collect(bus0, 1.5)
        for n in (0x21, 0x22):
            boots = [m for m in frames if it.is_bootup(n)(m)]
            assert not boots, f"node 0x{n:02X} rebooted at reload"
            beats = [m.timestamp for m in frames if it.is_heartbeat(n)(m)]
            assert len(beats) >= 3, f"node 0x{n:02X}: {len(beats)} heartbeats around the reload"
            gap = max(b - a for a, b in zip(beats, beats[1:]))
            assert gap < 0.1 + 0.3 * it.SCALE, f"node 0x{n:02X}: {gap:.3f}s heartbeat gap at reload"
        assert it.SdoClient(bus0, 0x21).upload_u16(0x1017) == 100, "running node kept its RAM values"
        it.log("SIGHUP added node 0x25, the others kept running")

        # A broken config at reload: logged, the fleet keeps running.
        with open(cfg, "a") as f:
            f.write("  - {profile: nope, interface: vcan0}\n")
        d.send_signal(signal.SIGHUP)
        time.sleep(it.scaled(0.5))
        d.assert_alive()
        it.drain(bus0)
        it.expect(bus0, it.is_heartbeat(0x25), 5, "heartbeat of node 0x25 after a failed reload")
        assert "reload failed" in d.log_text(), d.log_text()
        assert d.stop() == 0


EDS_FLEET = """
interfaces:
  vcan0: {{bit_rate: 250}}
nodes:
  - {{profile: {eds}, interface: vcan0, node_id: 0x40, name: eds}}
  - {{profile: {yaml}, interface: vcan0, node_id: 0x41, name: yaml}}
  - {{profile: {vendor}, interface: vcan0, node_id: 0x42, name: vendor}}
  - {{profile: {editor}, interface: vcan0, node_id: 0x43, name: editor}}
"""
# Measured by the CiA 404 chain: the two nodes' physics differ.
MEASURED = {0x6100, 0x7100, 0x9100, 0x6130, 0x7130, 0x9130, 0x6150}


def eds_entries(path: str) -> list:
    """(index, sub, access, node-ID relative) of every entry of an EDS the exporter wrote."""
    out, section = [], None
    with open(path) as f:
        for line in f:
            line = line.strip()
            m = re.fullmatch(r"\[([0-9A-F]{4})(?:sub([0-9A-F]+))?\]", line)
            if m:
                section = {"index": int(m.group(1), 16), "sub": int(m.group(2) or "0", 16)}
                out.append(section)
            elif section is not None and "=" in line:
                k, v = line.split("=", 1)
                section[k] = v
            elif line.startswith("["):
                section = None
    # An object with sub-objects has no DataType of its own.
    return [(e["index"], e["sub"], e["AccessType"], "$NODEID" in e.get("DefaultValue", ""))
            for e in out if "DataType" in e]


def upload(sdo: it.SdoClient, index: int, sub: int):
    try:
        return sdo.upload(index, sub)
    except it.SdoAbort as a:
        return a.code


def test_eds(ctx: it.Context) -> None:
    eds = os.path.join(ctx.tmp, "generic-404.eds")
    subprocess.run([ctx.require_cansimd(), "--export-eds", ctx.source("profiles/generic-404.yaml"), "--output", eds],
                   check=True, timeout=it.scaled(10))
    ctl = os.path.join(os.path.dirname(ctx.cansimd), "cansimctl")
    cfg = os.path.join(ctx.tmp, "eds-fleet.yaml")
    with open(cfg, "w") as f:
        f.write(EDS_FLEET.format(eds=eds, yaml=ctx.source("profiles/generic-404.yaml"),
                                 vendor=ctx.source("tests/data/eds/vendor-transmitter.eds"),
                                 editor=ctx.source("tests/data/eds/editor-gripper.dcf")))
    sock = os.path.join(ctx.tmp, "control")
    d = ctx.daemon("--config", cfg, "--state-dir", "{state_dir}", "--bus", "none", "--control-socket", sock,
                   name="eds-fleet")
    with it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
        it.drain(bus0)
        d.start()
        it.expect(bus0, it.is_bootup(0x40), 10, "boot-up of the EDS node 0x40")
        a, b = it.SdoClient(bus0, 0x40), it.SdoClient(bus0, 0x41)
        entries = eds_entries(eds)
        for index, sub, access, plus_id in entries:
            x, y = upload(a, index, sub), upload(b, index, sub)
            where = f"0x{index:04X}:{sub} ({access})"
            if index in MEASURED and isinstance(x, bytes):
                assert isinstance(y, bytes) and len(x) == len(y), f"{where}: EDS node {x!r}, YAML node {y!r}"
            elif plus_id and isinstance(x, bytes):
                vx, vy = int.from_bytes(x, "little"), int.from_bytes(y, "little")
                assert vx - 0x40 == vy - 0x41, f"{where}: EDS node 0x{vx:X}, YAML node 0x{vy:X}"
            else:
                assert x == y, f"{where}: EDS node {x!r}, YAML node {y!r}"
        it.log(f"EDS and YAML nodes answer the same {len(entries)} objects")
        # Foreign files (tests/data/eds): the SDO server at 600h + node-ID
        # whatever the file wrote (0x601), values an empty ParameterValue
        # left to DefaultValue, and each repair logged once at start.
        v, e = it.SdoClient(bus0, 0x42), it.SdoClient(bus0, 0x43)
        assert v.upload(0x1200, 1) == (0x642).to_bytes(4, "little")
        assert v.upload_u16(0x1017) == 500 and v.upload(0x1000, 0) == (0x00020194).to_bytes(4, "little")
        assert e.upload_u16(0x1017) == 1000 and e.upload(0x1008, 0) == b"GX-2 gripper"
        assert e.upload(0x1018, 4) == (0x0012D687).to_bytes(4, "little")
        assert "vendor-transmitter.eds:106: [1200sub1] DefaultValue: expected $NODEID+0x600" in d.log_text(), d.log_text()
        assert "editor-gripper.dcf:387: [DeviceComissioning] Baudrate" in d.log_text()
        it.log("foreign EDS / DCF nodes answer the files' values; their warnings are in the log")
        it.nmt(bus0, 0x01, 0x40)
        it.expect(bus0, it.is_tpdo(0x40, 1), 5, "TPDO1 of the EDS node (event timer 100 ms from its 0x1800)")

        a.download_u16(0x1017, 0, 300)
        if not os.access(ctl, os.X_OK):
            it.log(f"cansimctl not built ({ctl}): no DCF round trip")
            assert d.stop() == 0
            return
        dcf = os.path.join(ctx.tmp, "eds-node.dcf")
        subprocess.run([ctl, "--socket", sock, "dcf", "eds", "--output", dcf], check=True, timeout=it.scaled(20))
        with open(dcf) as f:
            text = f.read()
        assert "[DeviceComissioning]\nNodeID=0x40\n" in text and "ParameterValue=0x12C" in text, text[:2000]
        assert d.stop() == 0

        it.drain(bus1)
        d2 = ctx.start_daemon("--profile", dcf, "--interface", "vcan1", "--state-dir", "{state_dir}",
                              "--bus", "none", "--control-socket", "none", name="dcf-node")
        it.expect(bus1, it.is_bootup(0x40), 10, "boot-up of the DCF node 0x40 on vcan1")
        assert it.SdoClient(bus1, 0x40).upload_u16(0x1017) == 300, "0x1017 from the DCF's ParameterValue"
        it.log("cansimctl dcf: the DCF runs as a node with the node-ID and values it recorded")
        assert d2.stop() == 0


def test_all(ctx: it.Context) -> None:
    test(ctx)
    test_eds(ctx)


it.main(test_all)
