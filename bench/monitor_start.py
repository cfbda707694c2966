#!/usr/bin/python3
"""How long `cansimctl monitor` takes to its first line at N nodes (no CAN
interface needed).

usage: bench/monitor_start.py [--nodes 1000] [--runs 5] [--all] [--frames N] [--cansimd PATH] CANSIMCTL...

Starts cansimd with every interface a kernel-free socketcand bus
(--socketcand; 127 generic-404 nodes per bus), a python-can client on vb0
sending a frame every 2 ms (so the first line comes as soon as monitor
decodes), then for each run and each CANSIMCTL given (interleaved: before and
after builds side by side) the wall time from starting `cansimctl monitor
vb0` (--all: `cansimctl monitor`, every bus) to its first decoded line on stdout: what it asks the daemon of every
node before it decodes a frame. Prints best and median of --runs.

--frames N: then, for each CANSIMCTL, `cansimctl --json monitor vb0` given N
TPDO1 frames of node n0/0 (CAN-ID 0x181) as fast as a python-can client
sends them: its CPU time (utime + stime) per frame decoded and printed, and
the frame rate one core of it would keep up with (a saturated 1 Mbit/s bus
carries at most about 8,700 frames/s of 8 bytes, 8,900 of 5).
"""

import argparse
import os
import statistics
import subprocess
import sys
import threading
import time

import can

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python"))
import cansim  # noqa: E402

PER_BUS = 127


def fleet(n: int) -> str:
    out = "nodes:\n"
    for i in range(0, n, PER_BUS):
        bus = i // PER_BUS
        out += (f"  - {{profile: generic-404, interface: vb{bus}, node_id: 1, count: {min(PER_BUS, n - i)}, "
                f"name: n{bus}}}\n")
    return out


def first_line_s(cansimctl: str, socket: str, buses: list) -> float:
    t = time.perf_counter()
    p = subprocess.Popen([cansimctl, "--socket", socket, "monitor"] + buses, stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL)
    try:
        line = p.stdout.readline()
        elapsed = time.perf_counter() - t
        if not line:
            raise RuntimeError(f"{cansimctl} monitor printed nothing")
        return elapsed
    finally:
        p.kill()
        p.wait()


def cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def decode_cost(cansimctl: str, socket: str, bus, frames: int) -> tuple:
    """(CPU s per frame, frames counted) of a JSON monitor given `frames` TPDO1 frames."""
    p = subprocess.Popen([cansimctl, "--socket", socket, "--json", "monitor", "vb0"], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True)
    try:
        while True:  # listening and decoding
            bus.send(can.Message(arbitration_id=0x181, data=b"\x00\x00\x60\x40\x00", is_extended_id=False))
            if '"id":385' in p.stdout.readline():
                break
        c0 = cpu_s(p.pid)
        for _ in range(frames):
            bus.send(can.Message(arbitration_id=0x181, data=b"\x00\x00\x60\x40\x00", is_extended_id=False))
        seen = 0
        while seen < frames:
            line = p.stdout.readline()
            if not line:
                break
            seen += '"id":385' in line or '"kind":"dropped"' in line
        return (cpu_s(p.pid) - c0) / max(seen, 1), seen
    finally:
        p.kill()
        p.wait()


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("cansimctl", nargs="+")
    p.add_argument("--nodes", type=int, default=1000)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--frames", type=int, default=0)
    p.add_argument("--all", action="store_true", help="monitor every bus of the fleet, not only vb0")
    p.add_argument("--cansimd", default=None)
    a = p.parse_args()
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = a.cansimd or os.path.join(repo, "build", "cansimd")
    os.chdir(repo)
    times = {c: [] for c in a.cansimctl}
    with cansim.start(fleet(a.nodes), binary=binary, timeout=120, transport="socketcand") as sim:
        stop = threading.Event()
        with sim.open_bus("vb0") as bus:
            def tick() -> None:
                while not stop.wait(0.002):
                    bus.send(can.Message(arbitration_id=0x7E0, data=b"\x01", is_extended_id=False))
            sender = threading.Thread(target=tick, daemon=True)
            sender.start()
            try:
                for _ in range(a.runs):
                    for c in a.cansimctl:
                        times[c].append(first_line_s(c, sim.control_socket, [] if a.all else ["vb0"]))
            finally:
                stop.set()
                sender.join()
            for c in a.cansimctl if a.frames else []:
                per_frame, seen = decode_cost(c, sim.control_socket, bus, a.frames)
                print(f"{c}: monitor --json decodes {seen} TPDO frames at {per_frame * 1e6:.1f} us CPU each "
                      f"(one core keeps up with {1 / per_frame:,.0f} frames/s)", flush=True)
    for c, ts in times.items():
        print(f"{c}: monitor{'' if a.all else ' vb0'}: its first line at {a.nodes} nodes: best {min(ts):.3f} s, median "
              f"{statistics.median(ts):.3f} s of {len(ts)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
