#!/usr/bin/python3
"""The running daemon's memory per node (no CAN interface needed).

usage: bench/daemon_memory.py [--cansimd PATH] [--nodes 2000,4096] [--profile generic-404]
                              [--padding KIB] [--idle SECONDS] [--bus-model auto|timed|ideal]
                              [--transport kernel|socketcand] [--no-shrink]

Starts cansimd off the bus (the fleet's interfaces do not exist, so its
nodes run without sending) and reads RssAnon from /proc/PID/status once
every node has booted:

  base      a 1-node fleet;
  N nodes   a fleet file of N nodes (127 per interface, vb0, vb1, ...), for
            each N of --nodes: (RssAnon(N) - RssAnon(base)) / (N - 1);
  grow      a 10-node fleet grown by AddNodes to the largest N (128 nodes a
            call), then shrunk by RemoveNode back to its 10 file nodes: its
            RssAnon at 10, at N and after the shrink, against a 10-node
            fleet's (the memory of removed nodes given back);
  --padding a profile padded with KIB of comments (a copy of --profile):
            per node the same as without, when nothing keeps its text.
  --idle    the 2,000-node fleet (pre-operational) idle for SECONDS: its
            CPU from the scheduler's clock, in % of one core, and its
            wake-ups a second (the loop thread's voluntary context switches).
            --bus-model sets its buses' model (default auto: timed, as for
            any interface that is not a real CAN controller); --transport
            socketcand: the buses are socketcand servers no client
            connects to.
"""

import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python"))
import cansim  # noqa: E402

PER_BUS = 127


def rss_anon_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("RssAnon:"):
                return int(line.split()[1])
    raise RuntimeError("no RssAnon in /proc/PID/status")


def cpu_seconds(pid: int) -> float:
    """Time on a CPU of all the process's threads, from the scheduler's own
    clock (/proc/PID/task/*/schedstat, ns): utime + stime of /proc/PID/stat
    are sampled at the tick (100 Hz), and a loop that wakes 2,000 times a
    second for microseconds is charged a whole tick or nothing."""
    total = 0
    for tid in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{tid}/schedstat", encoding="ascii") as f:
            total += int(f.read().split()[0])
    return total / 1e9


def entries(n: int, profile: str, prefix: str = "vb", first_bus: int = 0) -> list:
    out = []
    for i in range(0, n, PER_BUS):
        count = min(PER_BUS, n - i)
        bus = first_bus + i // PER_BUS
        out.append(f"{{profile: {profile}, interface: {prefix}{bus}, node_id: 1, count: {count}, name: n{bus}}}")
    return out


def fleet(n: int, profile: str, bus_model: str = "auto", transport: str = "kernel") -> str:
    text = "nodes:\n" + "".join(f"  - {e}\n" for e in entries(n, profile))
    settings = []
    if bus_model != "auto":
        settings.append(f"bus_model: {bus_model}")
    if transport == "socketcand":  # no client connects
        settings.append("transport: socketcand, listen: '127.0.0.1:0'")
    if not settings:
        return text
    buses = (n + PER_BUS - 1) // PER_BUS
    line = ", ".join(settings)
    return "interfaces:\n" + "".join(f"  vb{b}: {{{line}}}\n" for b in range(buses)) + text


def wake_ups(pid: int) -> int:
    """Voluntary context switches of the process's threads: each is a sleep
    the loop woke from."""
    total = 0
    for tid in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{tid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("voluntary_ctxt_switches:"):
                    total += int(line.split()[1])
    return total


def settle(pid: int) -> int:
    """RssAnon once it stopped moving (the allocator's lazy work done)."""
    last = rss_anon_kib(pid)
    for _ in range(20):
        time.sleep(0.25)
        now = rss_anon_kib(pid)
        if now == last:
            return now
        last = now
    return last


def started(binary: str, n: int, profile: str, bus_model: str = "auto", transport: str = "kernel"):
    return cansim.start(fleet(n, profile, bus_model, transport), binary=binary, timeout=120)


def measure_fleet(binary: str, n: int, profile: str) -> int:
    with started(binary, n, profile) as sim:
        return settle(sim.pid)


def grow_and_shrink(binary: str, top: int, profile: str) -> None:
    small = measure_fleet(binary, 10, profile)
    with started(binary, 10, profile) as sim:
        at10 = settle(sim.pid)
        t = time.perf_counter()
        added = []
        grown = 10
        bus = 1
        while grown < top:  # one entry of up to 127 nodes a call (AddNodes: at most 128)
            count = min(PER_BUS, top - grown)
            text = f"{{profile: {profile}, interface: vg{bus}, node_id: 1, count: {count}, name: g}}"
            sim.add(text)
            added += [f"vg{bus}/g/{k}" for k in range(count)]
            grown += count
            bus += 1
        grow_s = time.perf_counter() - t
        at_top = settle(sim.pid)
        t = time.perf_counter()
        for key in added:
            sim.remove(key)
        shrink_s = time.perf_counter() - t
        time.sleep(2.0)  # the daemon gives removed nodes' memory back a second after the last removal
        after = settle(sim.pid)
        print(f"grow 10 -> {top} -> 10: RssAnon {at10} -> {at_top} -> {after} KiB "
              f"(AddNodes {grow_s:.1f} s, {len(added)} RemoveNode {shrink_s:.1f} s); "
              f"a 10-node fleet: {small} KiB; after the shrink {100.0 * (after - small) / small:+.1f} %", flush=True)


def idle_cpu(binary: str, n: int, profile: str, seconds: float, bus_model: str, transport: str) -> None:
    with started(binary, n, profile, bus_model, transport) as sim:
        time.sleep(2.0)  # start-up work done
        t0, c0, w0 = time.monotonic(), cpu_seconds(sim.pid), wake_ups(sim.pid)
        time.sleep(seconds)
        t1, c1, w1 = time.monotonic(), cpu_seconds(sim.pid), wake_ups(sim.pid)
        where = "socketcand buses without a client" if transport == "socketcand" else f"{bus_model} buses"
        print(f"idle {n} nodes, pre-operational, {where}, {seconds:.0f} s: "
              f"{100.0 * (c1 - c0) / (t1 - t0):.2f} % of a core, {(w1 - w0) / (t1 - t0):.0f} wake-ups/s", flush=True)


def padded_profile(profile: str, kib: int, folder: str) -> str:
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with open(os.path.join(repo, "profiles", profile + ".yaml"), encoding="utf-8") as f:
        text = f.read()
    path = os.path.join(folder, f"{profile}-padded.yaml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
        line = "# " + "x" * 76 + "\n"
        f.write(line * (kib * 1024 // len(line)))
    return path


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cansimd", default=None)
    p.add_argument("--nodes", default="2000,4096")
    p.add_argument("--profile", default="generic-404")
    p.add_argument("--padding", type=int, default=0, help="KiB of comments in a padded copy of the profile")
    p.add_argument("--idle", type=float, default=0, help="seconds of idle CPU of a 2,000-node fleet")
    p.add_argument("--bus-model", choices=["auto", "timed", "ideal"], default="auto",
                   help="the idle fleet's bus model")
    p.add_argument("--transport", choices=["kernel", "socketcand"], default="kernel",
                   help="socketcand: the idle fleet's buses are socketcand servers without a client")
    p.add_argument("--no-shrink", action="store_true")
    a = p.parse_args()
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = a.cansimd or os.environ.get("CANSIMD") or os.path.join(repo, "build", "cansimd")
    os.chdir(repo)
    sizes = [int(s) for s in a.nodes.split(",") if s]
    base = measure_fleet(binary, 1, a.profile)
    print(f"cansimd {binary}, profile {a.profile}: 1 node RssAnon {base} KiB", flush=True)
    for n in sizes:
        rss = measure_fleet(binary, n, a.profile)
        print(f"{n:5d} nodes: RssAnon {rss} KiB, {(rss - base) / (n - 1):.1f} KiB per node above 1 node", flush=True)
    if a.padding:
        with tempfile.TemporaryDirectory() as folder:
            path = padded_profile(a.profile, a.padding, folder)
            n = sizes[0]
            pb = measure_fleet(binary, 1, path)
            rss = measure_fleet(binary, n, path)
            print(f"{n:5d} nodes of a profile padded with {a.padding} KiB of comments: RssAnon {rss} KiB, "
                  f"{(rss - pb) / (n - 1):.1f} KiB per node", flush=True)
    if not a.no_shrink and sizes:
        grow_and_shrink(binary, max(sizes), a.profile)
    if a.idle:
        idle_cpu(binary, 2000, a.profile, a.idle, a.bus_model, a.transport)
    return 0


if __name__ == "__main__":
    sys.exit(main())
