#!/usr/bin/env python3
"""Network faults as an independent master sees them: the npm `canopen`
stack (tests/master/master_check.js, CANSIM_MASTER_ONLY=faults) against one
generic-404 node on a 125 kbit/s vcan0 (a timed bus), each fault armed with
`cansimctl fault`:

  sdo_abort          the chosen object answers the chosen abort code (0x08000022), another object its value;
  sdo_silent         no answer on the wire: the master's own SDO timeout;
  error_frames       CAN_ERR_FLAG frames of the controller (error-passive) and protocol (stuff) classes, as
                     the master's socket receives them with CAN_RAW_ERR_FILTER;
  node_id_collision  a second boot-up at the node's ID, two different answers (serial numbers) to one
                     upload, the collision's error frames (protocol class) before them.

Behaviour and order only (the VM's timing is coarse): the frame-by-frame
timing of every fault kind is tests/unit/network_faults_test.cpp's."""
# ctest-timeout: 120

import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE_ID = 0x10


def test(ctx: it.Context) -> None:
    node = shutil.which("node")
    master_dir = ctx.source("tests", "master")
    if not node or not os.path.isdir(os.path.join(master_dir, "node_modules", "canopen")):
        raise AssertionError("node or tests/master/node_modules is missing: scripts/install-deps")
    it.require_iface("vcan0")
    cansimctl = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}",
                   "--control-socket", "{state_dir}/control", "--bus", "none")
    with open(os.path.join(d.state_dir, "fleet.yaml"), "w") as f:
        f.write("interfaces:\n  vcan0: {bit_rate: 125, bus_model: timed}\nnodes:\n"
                f"  - {{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan0, "
                f"node_id: {NODE_ID}, name: faulty, bit_rate: 125}}\n")
    sock = os.path.join(d.state_dir, "control")
    plan = {"channel": "vcan0", "master_id": 0x7E, "scale": it.SCALE, "sdo_timeout_ms": 1000,
            "cansimctl": cansimctl, "control_socket": sock, "lss": {"new_ids": []},
            "nodes": [{"id": NODE_ID, "name": "faulty", "profile": "generic-404", "hb_ms": 1000}]}
    plan_path = os.path.join(ctx.tmp, "plan.json")
    with open(plan_path, "w") as f:
        json.dump(plan, f)
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        it.expect(bus, it.is_bootup(NODE_ID), it.scaled(10), "the node's boot-up")
    it.wait_for_path(sock, 5)
    p = subprocess.run([node, os.path.join(master_dir, "master_check.js"), plan_path],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=master_dir,
                       env={**os.environ, "CANSIM_MASTER_ONLY": "faults"}, timeout=min(it.scaled(40), 100))
    for line in p.stdout.splitlines():
        print(line, flush=True)
    checks = [ln for ln in p.stdout.splitlines() if ln.startswith("CHECK ")]
    fails = [ln for ln in checks if " FAIL " in ln]
    assert "SUMMARY" in p.stdout, "the master did not finish (no SUMMARY line)"
    assert len(checks) == 5, f"5 checks expected, {len(checks)} ran"
    assert p.returncode == 0 and not fails, "\n".join(fails)
    d.assert_alive()


it.main(test)
