#!/usr/bin/env python3
"""Smoke test of the real-kernel test environment (does not need cansimd):
vcan0 and vcan1 exist and are vcan devices, a frame sent with can-utils'
cansend reaches python-can, a frame sent with python-can reaches candump, and
the two buses are separate."""

import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402


def link_kind(name: str) -> str:
    out = subprocess.run(["ip", "-json", "-details", "link", "show", name],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)[0].get("linkinfo", {}).get("info_kind", "?")


def test(ctx: it.Context) -> None:
    for name in ("vcan0", "vcan1"):
        it.require_iface(name)
        assert link_kind(name) == "vcan", f"{name} is a {link_kind(name)} device, not vcan"
        with open(f"/sys/class/net/{name}/operstate") as f:
            state = f.read().strip()
        assert state in ("up", "unknown"), f"{name} is not up (operstate {state})"
    it.log("vcan0 and vcan1 exist and are up")

    with it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
        it.drain(bus0)
        it.drain(bus1)

        # can-utils -> python-can
        subprocess.run(["cansend", "vcan0", "123#DEADBEEF"], check=True)
        m = it.expect(bus0, it.has_id(0x123), 5, "frame 123#DEADBEEF on vcan0")
        assert bytes(m.data) == bytes.fromhex("DEADBEEF"), it.fmt(m)
        it.log(f"python-can received {it.fmt(m)} sent by cansend")

        # python-can -> candump (started first; resend until it has seen one)
        dump = subprocess.Popen(["candump", "-n", "1", "-T", str(int(it.scaled(5000))), "vcan0,456:7FF"],
                                stdout=subprocess.PIPE, text=True)
        try:
            for _ in range(int(it.scaled(50))):
                it.send(bus0, 0x456, b"\x01\x02\x03")
                try:
                    dump.wait(0.1)
                    break
                except subprocess.TimeoutExpired:
                    pass
            out, _ = dump.communicate(timeout=it.scaled(5))
        finally:
            if dump.poll() is None:
                dump.kill()
        assert "456" in out and "01 02 03" in out, f"candump saw: {out!r}"
        it.log(f"candump received: {out.strip()}")

        # vcan1 is a separate bus
        it.drain(bus0)
        with it.open_bus("vcan1") as sender1:
            it.send(sender1, 0x321, b"\xAA")
        m = it.expect(bus1, it.has_id(0x321), 5, "frame 321#AA on vcan1")
        it.expect_none(bus0, it.has_id(0x321), 0.5, "vcan1 frame on vcan0")
        it.log("vcan1 carries its own traffic")


if __name__ == "__main__":
    it.main(test)
