#!/usr/bin/env python3
"""Record and replay on socketcand buses, natively: cansimctl capture writes
candump -L that python-can's can.LogReader reads back frame for frame (what
a python-can client saw on the same bus); cansimctl replay plays a file onto
a bus through cansimd, its frames arbitrating with others on a slow timed bus;
--filter and --speed; cansimctl monitor decodes a socketcand bus."""
# ctest-timeout: 180

import os
import signal
import subprocess
import threading
import time

import can

import cansim_it as it
import cansim_socketcand as sc

FLEET = """\
interfaces:
  bench: {transport: socketcand, listen: "127.0.0.1:0"}
  slow: {transport: socketcand, listen: "127.0.0.1:0", bit_rate: 10}
nodes:
  - {profile: generic-404, interface: bench, node_id: 0x10, count: 2, name: pt}
"""


def ctl_path(d: sc.SocketcandDaemon) -> str:
    return os.environ.get("CANSIMCTL") or os.path.join(d.ctx.binary_dir, "cansimctl")


def background(d: sc.SocketcandDaemon, *args: str):
    """cansimctl ARGS in the background; returns (process, thread reading its stdout, lines, stderr file)."""
    err = open(os.path.join(d.ctx.tmp, f"ctl-{args[0]}-{time.monotonic_ns()}.err"), "w+")
    proc = subprocess.Popen([ctl_path(d), "--socket", d.control_socket, *args], stdout=subprocess.PIPE,
                            stderr=err, text=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    return proc, reader, lines, err


def wait_for_clients(d: sc.SocketcandDaemon, bus: str, n: int) -> None:
    deadline = time.monotonic() + it.scaled(10)
    while True:
        out = d.cansimctl("--json", "stats").stdout
        for row in __import__("json").loads(out):
            if row["interface"] == bus and row.get("clients", 0) >= n:
                return
        assert time.monotonic() < deadline, f"{bus}: fewer than {n} clients: {out}"
        time.sleep(0.1)


def check_capture(d: sc.SocketcandDaemon) -> None:
    path = os.path.join(d.ctx.tmp, "bench.log")
    proc, reader, _, err = background(d, "capture", "bench", path)
    with d.bus("bench") as master:
        wait_for_clients(d, "bench", 2)
        it.send(master, 0x7FF, [])  # ends the rawmode hold
        it.nmt(master, it.NMT_START)
        got = it.collect(master, 2.0, lambda m: m.arbitration_id in (0x190, 0x191, 0x710, 0x711))
    time.sleep(0.3)
    assert it.stop_process(proc, reader, err) == 0
    logged = list(can.LogReader(path))
    # What the master received is in the file, with the same data and times.
    on_file = {(round(m.timestamp, 6), m.arbitration_id, bytes(m.data)) for m in logged}
    missing = [m for m in got if (round(m.timestamp, 6), m.arbitration_id, bytes(m.data)) not in on_file]
    assert got and not missing, f"{len(missing)} of {len(got)} frames not in the capture: {missing[:3]}"
    nmt = [m for m in logged if m.arbitration_id == 0x000]
    assert nmt and bytes(nmt[0].data) == bytes([it.NMT_START, 0]), nmt
    assert all(m.channel == "bench" and not m.is_extended_id for m in logged)


def check_replay_arbitrates(d: sc.SocketcandDaemon) -> None:
    """Ten low-priority frames at one instant, then five high-priority ones
    1 ms later: on a 10 kbit/s bus (an 8-byte frame is about 13 ms) the five
    overtake all but the first of the ten."""
    path = os.path.join(d.ctx.tmp, "burst.log")
    with open(path, "w") as f:
        for i in range(10):
            f.write(f"(100.000000) vcan0 700#{i:02X}{i:02X}{i:02X}{i:02X}{i:02X}{i:02X}{i:02X}{i:02X}\n")
        for i in range(5):
            f.write(f"(100.001000) vcan0 100#{i:02X}\n")
        f.write("(100.002000) vcan0 20000004#0004000000000000\n")  # an error frame: skipped
    with d.bus("slow") as watch:
        it.send(watch, 0x7FF, [])
        time.sleep(0.2)
        it.drain(watch)
        r = d.cansimctl("replay", path, "--on", "slow")
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == f"replayed 15 frame(s) of {path} onto slow, 1 error or CAN FD frame(s) not replayed", r.stdout
        seen = [(m.arbitration_id, m.data[0]) for m in it.collect(watch, 2.0) if m.arbitration_id in (0x100, 0x700)]
    assert seen == [(0x700, 0)] + [(0x100, i) for i in range(5)] + [(0x700, i) for i in range(1, 10)], seen


def check_replay_filter_and_speed(d: sc.SocketcandDaemon) -> None:
    """Every other frame of the file, twice as fast: 400 ms apart in the
    file, 200 ms on the bus. The median gap: a loaded host may hold the
    daemon's loop back for a while, merging two frames and stretching the
    next gap (seen: [0.0, 0.378])."""
    path = os.path.join(d.ctx.tmp, "paced.log")
    with open(path, "w") as f:
        for i in range(10):
            f.write(f"({200 + i * 0.2:.6f}) vcan0 {0x181 + (i % 2):03X}#{i:02X}\n")
    with d.bus("bench") as watch:
        it.send(watch, 0x7FF, [])
        time.sleep(0.2)
        it.drain(watch)
        t0 = time.monotonic()
        r = d.cansimctl("replay", path, "--on", "bench", "--filter", "181:7FF", "--speed", "2")
        took = time.monotonic() - t0
        assert r.returncode == 0, r.stderr
        assert "replayed 5 frame(s)" in r.stdout and "5 filtered out" in r.stdout, r.stdout
        seen = [m for m in it.collect(watch, 0.5) if m.arbitration_id in (0x181, 0x182)]
    assert [m.data[0] for m in seen] == [0, 2, 4, 6, 8], seen
    gaps = sorted(it.gaps(seen))
    assert 0.15 < (gaps[1] + gaps[2]) / 2 < 0.3, gaps  # at --speed 1: 0.4
    assert took >= 0.8, took  # the command ends when its last frame had its time


def check_monitor(d: sc.SocketcandDaemon) -> None:
    proc, reader, lines, err = background(d, "monitor", "bench")
    deadline = time.monotonic() + it.scaled(10)
    while not any("pt/0 TPDO1" in l for l in lines):
        assert time.monotonic() < deadline, f"no decoded TPDO1 of pt/0: {lines[:5]}"
        time.sleep(0.1)
    assert it.stop_process(proc, reader, err) == 0
    line = next(l for l in lines if "pt/0 TPDO1" in l)
    assert " bench 190 pt/0 TPDO1 " in line and "bar" in line, line


def test(ctx: it.Context) -> None:
    with sc.SocketcandDaemon(ctx, FLEET) as d:
        check_capture(d)
        check_replay_arbitrates(d)
        check_replay_filter_and_speed(d)
        check_monitor(d)
        d.daemon.assert_alive()


it.main(test)
