#!/usr/bin/python3
"""How fast a test gets a fresh fleet on its own kernel-free bus: what the
pytest plugin's cansim_fleet() does per call, timed natively (no CAN needed).

usage: bench/fleet_start_bench.py [--cansimd PATH] [--runs N]

For fleets of 1, 20 and 100 generic-404 nodes (and one of each shipped
device), N times: cansim.start(fleet, transport="socketcand") until every
node has booted, then the plugin's listener on the bus (sim.capture(), as
for the failure evidence) and a python-can master (sim.open_bus()); then
close. Prints median, p90 and max of the start (ready to use) and of the
close, interleaving the fleet sizes run by run.
"""

import argparse
import os
import statistics
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))
import cansim  # noqa: E402

FLEETS = {
    "1 generic-404": "nodes: [{profile: generic-404, interface: bench, node_id: 0x10, name: pt}]",
    "20 generic-404": "nodes: [{profile: generic-404, interface: bench, node_id: 0x10, count: 20, name: pt}]",
    "100 generic-404": "nodes: [{profile: generic-404, interface: bench, node_id: 1, count: 100, name: pt}]",
    "5 devices (dps p92c gems9000 smc cmp)": "interfaces: {bench: {bit_rate: 250}}\nnodes:\n" + "".join(
        f"  - {{profile: {p}, interface: bench, bit_rate: 250, node_id: {0x20 + i}, name: {p}}}\n"
        for i, p in enumerate(("dps", "p92c", "gems9000", "smc", "cmp"))),
}


def one(binary: str, text: str) -> tuple:
    t0 = time.perf_counter()
    sim = cansim.start(text, binary=binary, transport="socketcand")
    sim.capture()
    master = sim.open_bus()
    t1 = time.perf_counter()
    master.shutdown()
    sim.close()
    return t1 - t0, time.perf_counter() - t1


def row(what: str, samples: list) -> str:
    s = sorted(samples)
    p90 = s[min(len(s) - 1, int(len(s) * 0.9))]
    return f"median {statistics.median(s) * 1e3:6.1f} ms  p90 {p90 * 1e3:6.1f} ms  max {s[-1] * 1e3:6.1f} ms"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cansimd", default=None)
    p.add_argument("--runs", type=int, default=20)
    a = p.parse_args()
    binary = a.cansimd or os.environ.get("CANSIMD") or os.path.join(REPO, "build", "cansimd")
    os.chdir(REPO)  # profile names resolve from ./profiles
    starts = {k: [] for k in FLEETS}
    closes = {k: [] for k in FLEETS}
    one(binary, FLEETS["1 generic-404"])  # warm the page cache
    for _ in range(a.runs):
        for name, text in FLEETS.items():
            s, c = one(binary, text)
            starts[name].append(s)
            closes[name].append(c)
    print(f"fresh fleet on its own socketcand bus, {a.runs} runs each (start = booted + listener + master):")
    for name in FLEETS:
        print(f"  {name:<38} start {row(name, starts[name])}   close {row(name, closes[name])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
