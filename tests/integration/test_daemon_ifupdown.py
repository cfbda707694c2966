#!/usr/bin/env python3
"""An interface that goes down and up: cansimd keeps running, logs it, and
its nodes resume on the bus. A node started while its interface is missing
appears once the interface exists (skipped when we cannot add links)."""

import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x12


def ip(*args: str) -> int:
    return subprocess.run(["ip", "link", *args], capture_output=True).returncode


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    d = ctx.start_daemon("--profile", ctx.source("profiles/generic-404.yaml"), "--interface", "vcan0",
                         "--node-id", str(NODE), "--state-dir", "{state_dir}")
    try:
        with it.open_bus("vcan0") as bus:
            it.expect(bus, it.is_heartbeat(NODE), 10, "heartbeat before the interface goes down")
        assert ip("set", "vcan0", "down") == 0, "ip link set vcan0 down"
        time.sleep(it.scaled(1.5))
        d.assert_alive()
    finally:
        ip("set", "vcan0", "up")
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        it.expect(bus, it.is_heartbeat(NODE), 10, "heartbeat after the interface came back")
        sdo = it.SdoClient(bus, NODE)
        assert sdo.upload_u32(0x1000) == 0x00020194
    log = d.log_text()
    assert "vcan0" in log and "retrying" in log, log
    assert "back" in log, log
    it.log("node resumed after down/up")

    # An interface that does not exist yet.
    if ip("add", "vcan9", "type", "vcan") != 0:
        assert d.stop() == 0
        return
    ip("delete", "vcan9")
    d9 = ctx.start_daemon("--profile", ctx.source("profiles/generic-404.yaml"), "--interface", "vcan9",
                          "--node-id", "5", "--state-dir", "{state_dir}", name="cansimd-vcan9")
    try:
        time.sleep(it.scaled(1.0))
        d9.assert_alive()
        assert ip("add", "vcan9", "type", "vcan") == 0 and ip("set", "vcan9", "up") == 0
        with it.open_bus("vcan9") as bus:
            it.expect(bus, it.is_heartbeat(5), 10, "heartbeat on vcan9 once it exists")
        assert d9.stop() == 0
    finally:
        ip("delete", "vcan9")
    assert d.stop() == 0


it.main(test)
