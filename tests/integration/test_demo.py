#!/usr/bin/env python3
"""scripts/demo, a newcomer's first command, on real SocketCAN: `scripts/demo
--run-only --seconds 4` with this build's cansimd and cansimctl
(CANSIM_DEMO_BUILD_DIR) and the shipped fleet (config/cansimd.yaml: nodes on
vcan0 and vcan1). What it prints must be true:

  - "resets and starts all nodes": NMT reaches both buses, so the monitor
    shows TPDOs of vcan1's generic-b (0x20), not only of vcan0's nodes;
  - the SMC's pressure reads as its counts with what they mean in bar
    ("Process value (REAL32) = 10 007 counts (2.5017 bar)"), never counts
    labelled bar;
  - the end reads as an end: cansimd stops on SIGTERM with status 0 and the
    monitor says "cansimd has stopped; done.", not that the connection
    failed.
"""

# ctest-timeout: 120

import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.require_iface("vcan1")
    build = os.path.dirname(ctx.require_cansimd())
    if not os.access(os.path.join(build, "cansimctl"), os.X_OK):
        it.skip(f"cansimctl not built ({build})")
    env = dict(os.environ, CANSIM_DEMO_BUILD_DIR=build, TMPDIR=ctx.tmp)
    p = subprocess.run([ctx.source("scripts", "demo"), "--run-only", "--seconds", "4"], cwd=ctx.source(), env=env,
                       capture_output=True, text=True, timeout=it.scaled(60), stdin=subprocess.DEVNULL)
    out = p.stdout + p.stderr
    it.log("demo (last lines):\n" + "\n".join(out.splitlines()[-12:]))
    assert p.returncode == 0, f"scripts/demo exited {p.returncode}:\n{out[-3000:]}"
    assert "cansimd exited with status 0 after SIGTERM" in p.stderr, p.stderr[-2000:]

    lines = p.stdout.splitlines()
    vcan1 = [line for line in lines if re.search(r" vcan1 1A0 generic-b TPDO1 ", line)]
    assert vcan1, "no TPDO of vcan1's generic-b: the demo's NMT start did not reach vcan1\n" + \
        "\n".join(line for line in lines if " vcan1 " in line)[-2000:]
    smc = [line for line in lines if " smc TPDO1 " in line]
    assert smc, "no TPDO1 of the SMC in the demo's monitor"
    assert all(re.search(r"= [0-9 .]+ counts \([0-9.]+ bar\)", line) for line in smc), smc[-3:]
    it.log(f"vcan1: {vcan1[-1]}; SMC: {smc[-1]}")

    assert "closed the connection" not in out, out[-2000:]
    assert "cansimctl monitor: cansimd has stopped; done." in out, out[-2000:]


it.main(test)
