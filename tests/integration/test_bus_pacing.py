#!/usr/bin/env python3
"""The wire never goes faster than physics, on a real kernel: 30 generic-404
nodes on a 125 kbit/s vcan0 answer each SYNC with their TPDO1 (5 bytes),
first paced by cansimd's loop, then by the kernel (scripts/cansim-pace: a
prio qdisc with ETF under its first band; the VM's vcan has echo=1).

Each burst arrives in CAN-ID order; the spacing of consecutive frames is
measured against the later frame's exact length on the wire (stuff bits and
intermission included). Where the kernel paces, its receive timestamps on
vcan0 are the launch times cansimd asked for (SO_TXTIME's time travels with
the frame through the echo), not when the frames left: the frames are also
forwarded by can-gw to vcan1, which clears the timestamp, and vcan1's kernel
timestamps are the real release times. The loop pacer's frames carry no
launch time: vcan0's timestamps are real.

Targets: median spacing >= 0.95 x and minimum >= 0.8 x the frame
time. Asserted here is what does not depend on how loaded the host is: the
loop pacer's median and its bursts never shorter than physics (a late
wake-up slips the bus; the slip is reported), the kernel pacer's launch
times exactly the model's and its frames released one by one. The figures
(docs/benchmarks.md) are printed: under TCG both pacers follow the guest's
timers, the kernel's soft hrtimers run late in bunches on a loaded host."""
# ctest-timeout: 300

import json
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

KBIT = 125
BIT_S = 1.0 / (KBIT * 1000)
NODES = range(0x10, 0x10 + 30)
SYNCS = 12
SYNC_GAP_S = 0.25  # a burst of 30 TPDOs takes 24 ms at 125 kbit/s


def sync_profile(ctx: it.Context) -> str:
    """generic-404 with TPDO1 synchronous (type 1) and no event timer."""
    with open(ctx.source("profiles/generic-404.yaml")) as f:
        text = f.read()
    for old, new in (("name: TPDO1 transmission type, type: UNSIGNED8, access: rw, default: 255",
                      "name: TPDO1 transmission type, type: UNSIGNED8, access: rw, default: 1"),
                     ("name: TPDO1 event timer, type: UNSIGNED16, access: rw, default: 100",
                      "name: TPDO1 event timer, type: UNSIGNED16, access: rw, default: 0"),
                     ("name: generic-404\n", "name: generic-404-sync\n")):
        assert old in text, old
        text = text.replace(old, new)
    path = os.path.join(ctx.tmp, "generic-404-sync.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def bursts(msgs):
    """One SYNC's answers: a burst ends where the CAN-IDs start again."""
    out, cur = [], []
    for m in msgs:
        if cur and m.arbitration_id <= cur[-1].arbitration_id:
            out.append(cur)
            cur = []
        cur.append(m)
    return out + ([cur] if cur else [])


def spacing(groups):
    """Spacing / frame time of consecutive frames, every burst; the bursts' lengths."""
    ratios, lengths = [], []
    for g in groups:
        frame_s = [it.wire_bits(m.arbitration_id, bytes(m.data)) * BIT_S for m in g]
        ratios += [(g[k].timestamp - g[k - 1].timestamp) / frame_s[k] for k in range(1, len(g))]
        if len(g) == len(NODES):
            lengths.append((g[-1].timestamp - g[0].timestamp, sum(frame_s[1:])))
    return ratios, lengths


def run(ctx: it.Context, fleet: str, ctl: str, label: str):
    sock = os.path.join(ctx.tmp, f"control-{label}")
    tpdo = lambda m: 0x180 + NODES[0] <= m.arbitration_id < 0x180 + NODES[-1] + 1  # noqa: E731
    with it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
        d = ctx.start_daemon("--config", fleet, "--state-dir", "{state_dir}", "--control-socket", sock,
                             "--bus", "none")
        it.expect(bus0, it.is_heartbeat(NODES[-1]), it.scaled(3), "the last node's boot-up")
        it.nmt(bus0, 0x01)
        it.drain(bus0)
        it.drain(bus1)
        on0, on1 = [], []
        for _ in range(SYNCS):
            it.send(bus0, 0x080)
            on0 += it.collect(bus0, SYNC_GAP_S)
            on1 += it.collect(bus1, 0.01)
        on0 = [m for m in on0 + it.collect(bus0, 0.3) if tpdo(m)]
        on1 = [m for m in on1 + it.collect(bus1, 0.3) if tpdo(m)]
        d.assert_alive()
        st = json.loads(subprocess.run([ctl, "--socket", sock, "--json", "stats"], capture_output=True, text=True,
                                       check=True, timeout=it.scaled(10)).stdout)
        log = d.log_text()
        assert d.stop() == 0
    return on0, on1, st[0], log


def report(label: str, ratios, lengths) -> str:
    r = sorted(ratios)
    burst = statistics.median(x for x, _ in lengths) if lengths else 0
    computed = statistics.median(c for _, c in lengths) if lengths else 0
    return (f"{label}: spacing / frame time over {len(r)} pairs: min {r[0]:.2f}, p10 {r[len(r) // 10]:.2f}, "
            f"median {statistics.median(r):.3f}, max {r[-1]:.2f}; burst {burst * 1e3:.1f} ms (computed "
            f"{computed * 1e3:.1f}, {len(lengths)} whole bursts)")


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.require_iface("vcan1")
    if not it.IN_VM:
        it.skip("needs the test VM (tc, can-gw and a vcan with echo=1 there)")
    ctl = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    fleet = os.path.join(ctx.tmp, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write(f"interfaces:\n  vcan0: {{bit_rate: {KBIT}}}\nnodes:\n"
                f"  - {{profile: {sync_profile(ctx)}, interface: vcan0, node_id: {NODES[0]}, count: {len(NODES)}, "
                f"bit_rate: {KBIT}, name: g}}\n")
    subprocess.run(["cangw", "-F"], check=True)
    subprocess.run(["cangw", "-A", "-s", "vcan0", "-d", "vcan1", "-e"], check=True)
    pace = ctx.source("scripts/cansim-pace")
    try:
        subprocess.run([pace, "--off", "vcan0"], check=True)
        on0, _, st, log = run(ctx, fleet, ctl, "loop")
        assert "timed bus paced by the loop" in log, log
        assert len(on0) == SYNCS * len(NODES), f"{len(on0)} TPDOs on vcan0"
        ratios, lengths = spacing(bursts(on0)[1:])
        it.log(report("loop pacer (vcan0 kernel timestamps)", ratios, lengths) +
               f"; slip p99 {st['slip_p99_us']} us, max {st['slip_max_us']} us")
        # Each frame is written when the loop wakes at its end; a late
        # wake-up slips the bus: never faster than physics, except by the
        # jitter of the write after the wake-up (up to a few 100 µs in TCG).
        assert statistics.median(ratios) >= 0.95, report("loop pacer", ratios, lengths)
        assert all(burst >= computed - 0.001 for burst, computed in lengths), lengths
        assert st["slip_max_us"] >= st["slip_p99_us"] > 0, st

        subprocess.run([pace, "--delta", "50000", "vcan0"], check=True)
        for attempt in (1, 2):
            on0, on1, st, log = run(ctx, fleet, ctl, f"kernel{attempt}")
            assert "timed bus paced by the kernel" in log, log
            assert len(on0) == SYNCS * len(NODES), f"{len(on0)} TPDOs on vcan0"
            launch, lengths = spacing(bursts(on0)[1:])
            ratios, lengths1 = spacing(bursts(on1)[1:])
            it.log(report("kernel pacer, launch times (vcan0 timestamps)", launch, lengths))
            it.log(report("kernel pacer, released (vcan1 via can-gw)", ratios, lengths1) +
                   f"; slip p99 {st['slip_p99_us']} us, max {st['slip_max_us']} us; {len(on1)} forwarded")
            # The schedule handed to the kernel is the model's, frame for frame.
            assert min(launch) >= 0.999, report("launch times", launch, lengths)
            # Frames lost between vcan0 and this test's vcan1 socket: the host
            # held the VM back (a loaded host), and what vcan1 shows is the
            # starved guest, not the qdisc. Measured again once.
            starved = len(on1) < len(on0)
            if not starved:
                break
            it.log(f"kernel pacer: {len(on1)} of {len(on0)} TPDOs reached vcan1, the VM was starved")
        if starved:
            it.log("kernel pacer: the release spacing is not judged (the VM was starved twice); the launch times are")
        else:
            # The kernel releases them one by one (without echo=1, or without
            # the qdisc, a burst would leave at once: median near 0). How close
            # to its time each one leaves is the guest's soft hrtimer's matter.
            assert statistics.median(ratios) >= 0.5, report("kernel pacer", ratios, lengths1)
    finally:
        subprocess.run([pace, "--off", "vcan0"], check=False)
        subprocess.run(["cangw", "-F"], check=False)


it.main(test)
