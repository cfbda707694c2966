#!/usr/bin/env python3
"""`cansimctl monitor` never loses frames silently: what the kernel drops on
its CAN socket (SO_RXQ_OVFL) it says, and every frame is either printed or
counted.

A cansimd with one generic-404 on vcan1 (so vcan0 carries only this test's
frames); `cansimctl --json monitor vcan0` prints a first frame, is stopped
(SIGSTOP) while python-can writes FLOOD frames of CAN-ID 0x5F0 onto vcan0
(far beyond its socket's receive queue), continued, and a last frame 0x5F1
marks the end. Then: at least one record of kind "dropped" came before the
first frame read after the drops, its counts add up ("dropped_total" is the
sum of "dropped"), and the 0x5F0 frames printed plus those counted dropped
are exactly the frames sent.
"""

# ctest-timeout: 120

import json
import os
import signal
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

FLOOD = 20000
FLOOD_ID, MARK_ID, FIRST_ID = 0x5F0, 0x5F1, 0x5EF


def send_all(bus, can_id: int, count: int) -> int:
    """Sends `count` frames, waiting out a full transmit queue (ENOBUFS)."""
    sent = 0
    while sent < count:
        try:
            bus.send(it.frame(can_id, sent.to_bytes(4, "little")))
            sent += 1
        except Exception:  # noqa: BLE001  python-can's CanOperationError on ENOBUFS
            time.sleep(0.001)
    return sent


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.require_iface("vcan1")
    ctl_bin = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    if not os.access(ctl_bin, os.X_OK):
        it.skip(f"cansimctl not built ({ctl_bin})")
    fleet = os.path.join(ctx.tmp, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write(f"nodes:\n  - {{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan1, "
                f"node_id: 0x10, name: g}}\n")
    sock = os.path.join(ctx.tmp, "control")
    d = ctx.start_daemon("--config", fleet, "--state-dir", "{state_dir}", "--control-socket", sock, "--bus", "none")
    it.wait_for_path(sock, 10)
    err = open(os.path.join(ctx.tmp, "monitor.err"), "w")
    monitor = subprocess.Popen([ctl_bin, "--socket", sock, "--json", "monitor", "vcan0"], stdin=subprocess.DEVNULL,
                               stdout=subprocess.PIPE, stderr=err, text=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(line.rstrip("\n") for line in monitor.stdout), daemon=True)
    reader.start()

    def wait_for_id(can_id: int, timeout: float) -> None:
        deadline = time.monotonic() + it.scaled(timeout)
        while time.monotonic() < deadline and monitor.poll() is None:
            if any(json.loads(line).get("id") == can_id for line in list(lines)):
                return
            time.sleep(0.05)
        raise AssertionError(f"monitor printed no frame 0x{can_id:X}: {len(lines)} lines")

    with it.open_bus("vcan0") as bus:
        deadline = time.monotonic() + it.scaled(10)
        while not lines and time.monotonic() < deadline:  # listening once it printed a frame
            it.send(bus, FIRST_ID)
            time.sleep(0.2)
        wait_for_id(FIRST_ID, 5)
        monitor.send_signal(signal.SIGSTOP)
        try:
            sent = send_all(bus, FLOOD_ID, FLOOD)
        finally:
            monitor.send_signal(signal.SIGCONT)
        it.send(bus, MARK_ID)
        wait_for_id(MARK_ID, 30)
    monitor.send_signal(signal.SIGINT)
    assert it.stop_process(monitor, reader, err) == 0
    assert d.stop() == 0

    records = [json.loads(line) for line in lines]
    printed = sum(1 for r in records if r.get("id") == FLOOD_ID)
    drops = [r for r in records if r["kind"] == "dropped"]
    it.log(f"{sent} frames sent while monitor was stopped: {printed} printed, "
           f"{sum(r['dropped'] for r in drops)} counted dropped in {len(drops)} record(s)")
    assert drops, f"no record of dropped frames; {printed} of {sent} printed"
    for r in drops:
        assert set(r) == {"time", "wall_time", "interface", "node", "kind", "dropped", "dropped_total"}, r
        assert r["interface"] == "vcan0" and r["node"] is None and r["dropped"] > 0, r
    running = 0
    for r in drops:
        running += r["dropped"]
        assert r["dropped_total"] == running, drops
    first_drop = records.index(drops[0])
    assert first_drop + 1 < len(records) and records[first_drop + 1]["kind"] != "dropped", records[first_drop:]
    assert printed + running == sent, f"{printed} printed + {running} dropped != {sent} sent"


if __name__ == "__main__":
    it.main(test)
