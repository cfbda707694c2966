#!/usr/bin/env python3
"""A bench reproduces a run's network faults bit for bit from the fleet seed
(docs/faults.md): three daemons in turn, seeds 7, 7 and 8, each with the same
seeded faults on one node's heartbeat (frame_corrupt: random bits of byte 0,
probability 0.5; frame_drop: probability 0.3), power-cycled after more or
fewer heartbeats. Each power-on starts the node's seeded streams afresh,
however many frames went before it, so the master records the same first
heartbeats after the cycle. Heartbeats in pre-operational all carry 0x7F, so
each frame's byte 0 is exactly what the faults made of it; which frames were
dropped shows in their order against the other node's heartbeats, which are
not faulted. Seed 7 twice gives the same frames, seed 8 others."""
# ctest-timeout: 180

import os
import re
import time
from typing import List, Tuple

import cansim_it as it
import cansim_socketcand as sc

FAULTED, WITNESS = 0x10, 0x11
FRAMES = 40  # heartbeats of the faulted node compared per run

FLEET = """\
seed: {seed}
interfaces:
  bench: {{transport: socketcand, listen: "127.0.0.1:0", bus_model: ideal}}
nodes:
  - profile: hb.yaml
    interface: bench
    node_id: 0x10
    name: faulted
    faults:
      - {{kind: frame_corrupt, service: heartbeat, bytes: [0], probability: 0.5}}
      - {{kind: frame_drop, service: heartbeat, probability: 0.3}}
  - {{profile: hb.yaml, interface: bench, node_id: 0x11, name: witness}}
"""


def heartbeat_profile(ctx: it.Context) -> str:
    """generic-404 with a 20 ms producer heartbeat (0x1017) and no TPDOs'
    traffic to wait behind: the runs need many heartbeats fast."""
    with open(ctx.source("profiles/generic-404.yaml")) as f:
        text = f.read()
    text, n = re.subn(r"(index: 0x1017, name: Producer heartbeat time, .*default: )1000", r"\g<1>20", text)
    assert n == 1, "generic-404.yaml: its 0x1017 line changed; update this test"
    return text


Frame = Tuple[int, bytes]
OFF_S = 0.3  # the power cycle's off time


def run(ctx: it.Context, seed: int, before_s: float = 0.0) -> List[Frame]:
    """The first heartbeats after a power cycle of both nodes: (node-ID, data),
    in the order the master received them, until FRAMES of the faulted node.
    The cycle comes `before_s` later than it might: more heartbeats before
    it, so more of the faults' draws."""
    d = sc.SocketcandDaemon(ctx, FLEET.format(seed=seed))
    with open(os.path.join(d.daemon.state_dir, "hb.yaml"), "w") as f:
        f.write(heartbeat_profile(ctx))
    with d:
        with d.bus("bench") as master:
            it.send(master, 0x7FF, [])  # ends the rawmode hold
            time.sleep(0.2)
            while master.recv(0) is not None:
                pass
            time.sleep(before_s)
            r = d.cansimctl("power-cycle", "bench/*", "--off", str(OFF_S))
            assert r.returncode == 0, r.stderr
            got: List[Tuple[float, Frame]] = []
            deadline = time.monotonic() + it.scaled(30)
            while since_boot_up(got, FAULTED) < FRAMES:
                assert time.monotonic() < deadline, f"seed {seed}: only {got}"
                m = master.recv(0.5)
                if m is not None and m.arbitration_id in (0x700 + FAULTED, 0x700 + WITNESS):
                    got.append((m.timestamp, (m.arbitration_id - 0x700, bytes(m.data))))
        d.daemon.assert_alive()
    for node in (FAULTED, WITNESS):
        boot = boot_up(got, node)
        got = [g for i, g in enumerate(got) if g[1][0] != node or i >= boot]
    return [f for _, f in got]


def since_boot_up(got: List[Tuple[float, Frame]], node: int) -> int:
    """How many of the node's frames `got` has from its boot-up on (0: no
    boot-up yet)."""
    try:
        boot = boot_up(got, node)
    except AssertionError:
        return 0
    return sum(1 for _, (n, _) in got[boot:] if n == node)


def boot_up(got: List[Tuple[float, Frame]], node: int) -> int:
    """Where the node's boot-up after the power cycle is in `got`: its first
    frame when the master heard none from before the cycle, else its first
    frame after the off time's silence (by the daemon's timestamps, so a
    slow master does not matter). A corrupted heartbeat may carry 0x00 too,
    so byte 0 alone cannot tell it."""
    mine = [(i, t, f) for i, (t, f) in enumerate(got) if f[0] == node]
    assert mine, f"node {node:#x}: no frame"
    start = mine[0][0]
    for (_, t0, _), (i, t1, _) in zip(mine, mine[1:]):
        if t1 - t0 >= OFF_S * 0.8:
            start = i
    boot = got[start][1]
    assert boot == (node, b"\x00"), f"node {node:#x}: {boot} after the silence, not a boot-up"
    return start


def faulted_stream(frames: List[Frame]) -> List[str]:
    """The faulted node's heartbeats as they came, and where the witness's
    beats show that some were dropped: 'hh' a heartbeat's byte, '-' for each
    witness beat with none of the faulted node's since the last."""
    out: List[str] = []
    since = 0
    for node, data in frames:
        if node == WITNESS:
            since += 1
            if since > 1:
                out.append("-")
            continue
        since = 0
        out.append(data.hex())
    return out[: FRAMES + 20]


def test(ctx: it.Context) -> None:
    # Seed 7 twice, the second cycle after about 7 heartbeats more.
    a, b, other = run(ctx, 7), run(ctx, 7, before_s=0.14), run(ctx, 8)
    fa, fb, fo = ([d for n, d in r if n == FAULTED][:FRAMES] for r in (a, b, other))
    assert fa[0] == b"\x00" and len(fa) == FRAMES, fa
    corrupted = sum(1 for d in fa[1:] if d != b"\x7f")
    assert 8 <= corrupted <= 32, f"{corrupted} of {FRAMES - 1} heartbeats corrupted (p = 0.5): {fa}"
    assert fa == fb, f"seed 7 twice, different heartbeats:\n{fa}\n{fb}"
    assert fa != fo, f"seeds 7 and 8, the same heartbeats: {fa}"
    # The drops: the witness beats on at the same period, so a dropped
    # heartbeat of the faulted node is a witness beat without one of its own.
    drops_a = faulted_stream(a).count("-")
    assert drops_a >= 3, f"no heartbeat dropped at p = 0.3: {faulted_stream(a)}"
    it.log(f"seed 7: {corrupted} of {FRAMES - 1} heartbeats corrupted, {drops_a} gaps; identical twice; seed 8 differs")


it.main(test)
