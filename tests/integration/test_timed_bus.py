#!/usr/bin/env python3
"""The timed bus model on a real kernel's vcan, seen with kernel timestamps:
16 generic-404 nodes on a 10 kbit/s vcan0 boot at one instant and beat at
one instant every second; each burst arrives in CAN-ID order, one frame at a
time, each after at least its own length on the wire (ISO 11898-1, stuff bits
and intermission included), the whole burst never shorter than computed (a
late wake-up slips the bus instead). The same nodes on vcan1 with
`bus_model: ideal` arrive all at once. TCG's clock is coarse: the wire is
checked with a tolerance for the jitter of the write after the loop's
wake-up; the model through `cansimctl stats`: the last frame of a burst
waited for the 15 before it and the bus's slips."""
# ctest-timeout: 120

import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

KBIT = 10
BIT_S = 1.0 / (KBIT * 1000)
NODES = range(0x10, 0x20)


def bursts(msgs, gap_s: float):
    out, cur = [], []
    for m in msgs:
        if cur and m.timestamp - cur[-1].timestamp > gap_s:
            out.append(cur)
            cur = []
        cur.append(m)
    return out + ([cur] if cur else [])


def check_timed(burst, tol_s: float) -> str:
    ids = [m.arbitration_id for m in burst]
    assert ids == sorted(ids) and len(ids) == len(NODES), f"burst order {[hex(i) for i in ids]}"
    # Never faster than physics: each frame at least its own length after
    # the one before (up to the jitter of the write after the loop's
    # wake-up). A late wake-up slips the bus: the burst may take longer.
    frame_s = [it.wire_bits(m.arbitration_id, bytes(m.data)) * BIT_S for m in burst]
    ratios = []
    for k in range(1, len(burst)):
        spacing = burst[k].timestamp - burst[k - 1].timestamp
        ratios.append(spacing / frame_s[k])
        assert spacing >= frame_s[k] - tol_s, \
            f"{it.fmt(burst[k])} {spacing * 1e3:.2f} ms after {it.fmt(burst[k - 1])}, its frame takes " \
            f"{frame_s[k] * 1e3:.2f} ms"
    computed = sum(frame_s[1:])
    length = burst[-1].timestamp - burst[0].timestamp
    assert length >= computed - tol_s, f"burst {length * 1e3:.1f} ms, computed {computed * 1e3:.1f} ms"
    return f"{len(burst)} frames in {length * 1e3:.1f} ms (computed {computed * 1e3:.1f}), spacing / frame time " \
           f"min {min(ratios):.2f}, median {sorted(ratios)[len(ratios) // 2]:.2f}"


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.require_iface("vcan1")
    fleet = os.path.join(ctx.tmp, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write(f"interfaces:\n  vcan0: {{bit_rate: {KBIT}}}\n  vcan1: {{bit_rate: {KBIT}, bus_model: ideal}}\n"
                "nodes:\n")
        for bus in ("vcan0", "vcan1"):
            f.write(f"  - {{profile: {ctx.source('profiles/generic-404.yaml')}, interface: {bus}, node_id: {NODES[0]}, count: {len(NODES)}, "
                    f"bit_rate: {KBIT}, name: g}}\n")
    # Each frame is written when its EOF ends, by one timer wake-up of the
    # loop, and the next follows from then: the spacing may fall short of
    # the frame time only by the jitter of the write after the wake-up (the
    # guest descheduled in between: up to a few ms on a loaded host). At the
    # VM's default scale, 1.5 ms: a quarter of a frame.
    tol = 0.0003 * it.SCALE
    ctl = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    sock = os.path.join(ctx.tmp, "control")
    with it.open_bus("vcan0") as timed, it.open_bus("vcan1") as ideal:
        it.drain(timed)
        it.drain(ideal)
        d = ctx.start_daemon("--config", fleet, "--state-dir", "{state_dir}", "--control-socket", sock, "--bus", "none")
        # Boot-ups at one instant, then heartbeats every second (generic-404: 1000 ms).
        ours = lambda m: 0x700 + NODES[0] <= m.arbitration_id < 0x700 + 0x20  # noqa: E731
        msgs = []
        while len(msgs) < 3 * len(NODES):
            m = it.wait_for(timed, ours, 3 + it.scaled(1))
            assert m is not None, f"{len(msgs)} boot-ups and heartbeats on vcan0"
            msgs.append(m)
        plain = it.collect(ideal, 0.2, ours)
        d.assert_alive()
        groups = bursts(msgs, 0.3)
        assert len(groups) >= 3, f"{len(groups)} bursts: {[len(g) for g in groups]}"
        # The boot-ups: in CAN-ID order. Their spacing is not asserted: the
        # daemon's start-up work delays its first loop passes, and what ended
        # meanwhile leaves at once (the schedule stays absolute).
        boot = [m.arbitration_id for m in groups[0]]
        assert boot == sorted(boot) and len(boot) == len(NODES), f"boot-ups {[hex(i) for i in boot]}"
        it.log("vcan0 boot-ups: " + " ".join(f"{m.arbitration_id:x}@{(m.timestamp - groups[0][0].timestamp) * 1e3:.1f}"
                                             for m in groups[0]))
        for g in groups[1:3]:
            it.log(f"vcan0 heartbeats: {check_timed(g, tol)}")
        # vcan1, ideal: each burst leaves in one pass of the loop (sendmmsg).
        g = bursts(plain, 0.3)[0]
        one_frame = it.wire_bits(0x710, b"\x7f") * BIT_S
        assert len(g) == len(NODES) and g[-1].timestamp - g[0].timestamp < one_frame, \
            f"ideal burst {len(g)} frames in {(g[-1].timestamp - g[0].timestamp) * 1e3:.2f} ms"
        it.log(f"vcan1 (ideal): {len(g)} frames in {(g[-1].timestamp - g[0].timestamp) * 1e3:.2f} ms")
        # The model, exactly: each burst's frames were queued at one instant;
        # the last of the boot-ups and of the heartbeats waited for the 15
        # frames before it (queueing delays of the last 10 s).
        waits = [sum(it.wire_bits(0x700 + n, bytes([state])) for n in NODES[:-1]) * 100 for state in (0x00, 0x7F)]
        out = subprocess.run([ctl, "--socket", sock, "--json", "stats"], capture_output=True, text=True, check=True,
                             timeout=it.scaled(10)).stdout
        st = {b["interface"]: b for b in json.loads(out)}
        assert st["vcan0"]["bus_model"] == "timed" and st["vcan1"]["bus_model"] == "ideal", st
        # Exactly the frames before it, plus the slips of the bus meanwhile.
        slip = st["vcan0"]["slip_max_us"]
        assert max(waits) <= st["vcan0"]["queue_delay_max_us"] <= max(waits) + len(NODES) * slip, (st["vcan0"], waits)
        assert st["vcan1"]["queue_delay_max_us"] == 0 and st["vcan0"]["queue_dropped"] == 0, st
        it.log(f"vcan0 queueing delay max {st['vcan0']['queue_delay_max_us']} us: the 15 frames before the last "
               f"({max(waits)} us) and the slips (max {slip} us); "
               f"carried {st['vcan0']['carried_load_10s'] * 100:.1f} % over 10 s")
        assert d.stop() == 0


if __name__ == "__main__":
    it.main(test)
