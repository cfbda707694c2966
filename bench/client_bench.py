#!/usr/bin/python3
"""The Python client's figures against a real cansimd on this host (no CAN
interface needed): call round trips and the listing of a big fleet.

usage: bench/client_bench.py [--cansimd PATH] [--nodes N] [--calls N]

Starts cansimd with N generic-404 nodes (125 per interface, vcan0..), then
prints the median and p99 of: a property read (node.nmt_state), a
measurement read (pressure.reading()), an action (pressure.set), an action
and the event it causes (nmt + wait_for NmtStateChanged), a node's
state(); and nodes() / states() of the whole fleet (best and median of 5).
"""

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python"))
import cansim  # noqa: E402


def fleet(n: int) -> str:
    lines = ["nodes:"]
    for i in range(0, n, 125):
        count = min(125, n - i)
        lines.append(f"  - {{profile: generic-404, interface: vcan{i // 125}, node_id: 1, count: {count}, "
                     f"name: pt{i // 125}}}")
    return "\n".join(lines) + "\n"


def timed(fn, calls: int) -> list:
    out = []
    for _ in range(calls):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def report(what: str, samples: list, unit: str = "ms") -> None:
    k = 1e3 if unit == "ms" else 1.0
    s = sorted(samples)
    p99 = s[min(len(s) - 1, int(len(s) * 0.99))]
    print(f"{what:<44} median {statistics.median(s) * k:8.3f} {unit}   p99 {p99 * k:8.3f} {unit}   "
          f"({len(s)} calls)", flush=True)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cansimd", default=None)
    p.add_argument("--nodes", type=int, default=1000)
    p.add_argument("--calls", type=int, default=1000)
    a = p.parse_args()
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = a.cansimd or os.environ.get("CANSIMD") or os.path.join(repo, "build", "cansimd")
    os.chdir(repo)
    t = time.perf_counter()
    with cansim.start(fleet(a.nodes), binary=binary, timeout=60) as sim:
        print(f"cansim.start: {a.nodes} nodes booted in {time.perf_counter() - t:.2f} s", flush=True)
        node = sim.node("pt0/5")
        report("property read (node.nmt_state)", timed(lambda: node.nmt_state, a.calls))
        report("reading (node.pressure.reading())", timed(node.pressure.reading, a.calls))
        report("action (node.pressure.set(2.0, 'bar'))", timed(lambda: node.pressure.set(2.0, "bar"), a.calls))
        report("node.state() (GetAll)", timed(node.state, a.calls // 4))

        def act_and_wait():
            node.nmt("start")
            node.wait_for("NmtStateChanged", new="operational")
            node.nmt("pre-operational")
            node.wait_for("NmtStateChanged", new="pre-operational")
        report("2 x (nmt + wait_for its event)", timed(act_and_wait, a.calls // 4))
        listing = timed(sim.nodes, 5)
        report(f"sim.nodes() of {a.nodes} nodes", listing)
        report(f"sim.states() of {a.nodes} nodes", timed(sim.states, 5))
    return 0


if __name__ == "__main__":
    sys.exit(main())
