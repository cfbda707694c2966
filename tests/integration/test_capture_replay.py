#!/usr/bin/env python3
"""cansimctl capture and replay on a kernel interface (vcan0, timed by
cansimd): the capture holds what python-can received on vcan0 (read back by
can.LogReader) and canplayer plays it onto vcan1 frame for frame; replay puts
a file's frames on vcan0 through cansimd (the node answers a replayed SDO
request, other programs on vcan0 see the replayed frames) and on the timed
bus they arbitrate with each other and with the nodes' frames."""

import os
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import can  # noqa: E402

import cansim_it as it  # noqa: E402


def cansimctl(ctx: it.Context, d: it.Daemon, *args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([os.path.join(ctx.binary_dir, "cansimctl"), "--socket", os.path.join(d.state_dir, "control"),
                           *args], capture_output=True, text=True, timeout=it.scaled(30), **kw)


def capture_then_play(ctx: it.Context, d: it.Daemon) -> None:
    path = os.path.join(ctx.tmp, "vcan0.log")
    err = open(os.path.join(ctx.tmp, "capture.err"), "w+")
    proc = subprocess.Popen([os.path.join(ctx.binary_dir, "cansimctl"), "--socket",
                             os.path.join(d.state_dir, "control"), "capture", "vcan0", path],
                            stdout=subprocess.DEVNULL, stderr=err)
    reader = threading.Thread(target=lambda: None)
    reader.start()
    with it.open_bus("vcan0") as master:
        # The capture has begun once it wrote a frame (the node's heartbeat, every second).
        deadline = time.monotonic() + it.scaled(20)
        while not (os.path.exists(path) and os.path.getsize(path) > 0):
            assert time.monotonic() < deadline and proc.poll() is None, "cansimctl capture wrote nothing"
            time.sleep(0.1)
        it.drain(master)
        it.nmt(master, it.NMT_START, 0x10)
        got = it.collect(master, it.scaled(2), lambda m: m.arbitration_id in (0x190, 0x710))
    time.sleep(it.scaled(0.3))
    assert it.stop_process(proc, reader, err) == 0
    logged = list(can.LogReader(path))
    # candump -L has microseconds (SO_TIMESTAMP); python-can's socketcan bus
    # reads nanoseconds (SO_TIMESTAMPNS): the same frame within 1 µs.
    on_file = {}
    for m in logged:
        on_file.setdefault((m.arbitration_id, bytes(m.data)), []).append(m.timestamp)
    missing = [m for m in got
               if not any(abs(t - m.timestamp) < 1.5e-6 for t in on_file.get((m.arbitration_id, bytes(m.data)), []))]
    assert got and not missing, f"{len(missing)} of {len(got)} frames not in the capture: {missing[:3]} / {logged[:3]}"
    assert any(m.arbitration_id == 0 and bytes(m.data) == bytes([1, 0x10]) for m in logged), "the master's NMT"
    # canplayer reads it: played onto vcan1, the same frames in the same order.
    with it.open_bus("vcan1") as watch:
        r = subprocess.run(["canplayer", "-I", path, "vcan1=vcan0"], capture_output=True, text=True,
                           timeout=it.scaled(60))
        assert r.returncode == 0, r.stderr
        played = it.collect(watch, it.scaled(1))
    assert [(m.arbitration_id, bytes(m.data)) for m in played] == \
        [(m.arbitration_id, bytes(m.data)) for m in logged], (len(played), len(logged))


def replay_reaches_the_node(ctx: it.Context, d: it.Daemon) -> None:
    path = os.path.join(ctx.tmp, "sdo.log")
    with open(path, "w") as f:
        f.write("(50.000000) can7 610#4000100000000000\n")  # upload 0x1000 from node 0x10
    with it.open_bus("vcan0") as watch:
        r = cansimctl(ctx, d, "replay", path, "--on", "vcan0")
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == f"replayed 1 frame(s) of {path} onto vcan0", r.stdout
        it.expect(watch, lambda m: m.arbitration_id == 0x610 and m.data[0] == 0x40, 5, "the replayed request on vcan0")
        answer = it.expect(watch, it.has_id(0x590), 5, "the node's answer to the replayed request")
    assert bytes(answer.data)[:4] == bytes([0x43, 0x00, 0x10, 0x00]), it.fmt(answer)


def replay_arbitrates(ctx: it.Context, d: it.Daemon) -> None:
    """On vcan1 at 10 kbit/s an 8-byte frame takes about 13 ms: five frames
    replayed 1 ms after ten low-priority ones overtake at least the last."""
    path = os.path.join(ctx.tmp, "burst.log")
    with open(path, "w") as f:
        for i in range(10):
            f.write(f"(100.000000) x 700#{i:02X}00000000000000\n")
        for i in range(5):
            f.write(f"(100.001000) x 100#{i:02X}\n")
    with it.open_bus("vcan1") as watch:
        r = cansimctl(ctx, d, "replay", path, "--on", "vcan1")
        assert r.returncode == 0, r.stderr
        seen = [(m.arbitration_id, m.data[0]) for m in it.collect(watch, it.scaled(3))
                if m.arbitration_id in (0x100, 0x700)]
    assert sorted(seen) == sorted([(0x700, i) for i in range(10)] + [(0x100, i) for i in range(5)]), seen
    assert [i for c, i in seen if c == 0x700] == list(range(10)), seen
    last_high = max(k for k, (c, _) in enumerate(seen) if c == 0x100)
    assert any(c == 0x700 for c, _ in seen[last_high:]), f"no replayed frame lost arbitration: {seen}"


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.require_iface("vcan1")
    d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}",
                   "--control-socket", "{state_dir}/control", "--bus", "none")
    with open(os.path.join(d.state_dir, "fleet.yaml"), "w") as f:
        f.write("interfaces: {vcan0: {}, vcan1: {bit_rate: 10}}\n"
                "nodes: [{profile: " + ctx.source("profiles/generic-404.yaml") +
                ", interface: vcan0, node_id: 0x10, name: pt}]\n")
    with d:
        with it.open_bus("vcan0") as bus:
            it.expect(bus, it.is_heartbeat(0x10), 10, "the node's heartbeat")
        capture_then_play(ctx, d)
        replay_reaches_the_node(ctx, d)
        replay_arbitrates(ctx, d)
        d.assert_alive()


it.main(test)
