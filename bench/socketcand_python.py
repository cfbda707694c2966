#!/usr/bin/env python3
"""What a python-can master gets through cansimd's socketcand bus (Debian
12's python3-can 4.1, its socketcand interface): SDO upload round trips from
one node, one at a time (median and p99 of send() to the answer received),
and how many frames per second one python-can client receives while another
sends as fast as python-can does, on an ideal bus.

    python3 bench/socketcand_python.py [--cansimd build/cansimd] [--trips 2000] [--frames 20000]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import can

HERE = os.path.dirname(os.path.abspath(__file__))


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimd", default=os.path.join(HERE, "..", "build", "cansimd"))
    p.add_argument("--trips", type=int, default=2000)
    p.add_argument("--frames", type=int, default=20000)
    a = p.parse_args()
    with tempfile.TemporaryDirectory() as d:
        os.symlink(os.path.join(HERE, "..", "profiles"), os.path.join(d, "profiles"))
        with open(os.path.join(d, "fleet.yaml"), "w") as f:
            f.write('interfaces: {bench: {transport: socketcand, listen: "127.0.0.1:0", bus_model: ideal}}\n'
                    "nodes: [{profile: generic-404, interface: bench, node_id: 1, name: pt}]\n")
        addr = os.path.join(d, "addresses")
        daemon = subprocess.Popen([a.cansimd, "--config", os.path.join(d, "fleet.yaml"), "--state-dir",
                                   os.path.join(d, "state"), "--control-socket", os.path.join(d, "control"),
                                   "--bus", "none", "--log-level", "warn", "--address-file", addr])
        try:
            for _ in range(200):
                if os.path.exists(addr):
                    break
                time.sleep(0.05)
            _, host, port = open(addr).read().split()
            run(host, int(port), a.trips, a.frames)
        finally:
            daemon.terminate()
            daemon.wait()
    return 0


def run(host: str, port: int, trips: int, frames: int) -> None:
    master = can.Bus(interface="socketcand", host=host, port=port, channel="bench")
    request = can.Message(arbitration_id=0x601, data=[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0], is_extended_id=False)
    rtt = []
    for _ in range(trips):
        t0 = time.perf_counter()
        master.send(request)
        while True:
            m = master.recv(1.0)
            if m is None:
                raise SystemExit("no SDO answer within 1 s")
            if m.arbitration_id == 0x581:
                break
        rtt.append(time.perf_counter() - t0)
    rtt.sort()
    print(f"python-can SDO upload round trip, {trips} trips: median {statistics.median(rtt) * 1e6:.0f} us, "
          f"p99 {rtt[len(rtt) * 99 // 100] * 1e6:.0f} us, {trips / sum(rtt):.0f} round trips/s")
    sender = can.Bus(interface="socketcand", host=host, port=port, channel="bench")
    got = [0]
    done = threading.Event()

    def receive() -> None:
        while not done.is_set():
            m = master.recv(0.2)
            if m is not None and m.arbitration_id == 0x7F0:
                got[0] += 1
                if got[0] == frames:
                    done.set()

    reader = threading.Thread(target=receive)
    reader.start()
    t0 = time.perf_counter()
    for i in range(frames):
        sender.send(can.Message(arbitration_id=0x7F0, data=i.to_bytes(4, "little"), is_extended_id=False))
    sent = time.perf_counter() - t0
    done.wait(60)
    took = time.perf_counter() - t0
    done.set()
    reader.join()
    print(f"python-can streaming: one client sent {frames} frames in {sent:.2f} s ({frames / sent:.0f}/s), "
          f"another received {got[0]} of them in {took:.2f} s ({got[0] / took:.0f}/s)")
    sender.shutdown()
    master.shutdown()


if __name__ == "__main__":
    sys.exit(main())
