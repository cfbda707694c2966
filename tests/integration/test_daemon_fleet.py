#!/usr/bin/env python3
"""cansimd --config: two nodes on vcan0 and one on vcan1 each boot on their
own bus; SIGHUP adds a node without disturbing the others (no boot-up, no
heartbeat gap); a config error at reload keeps the fleet running;
SIGTERM -> exit 0."""

import os
import signal
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


it.main(test)
