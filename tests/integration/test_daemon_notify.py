#!/usr/bin/env python3
"""cansimd and systemd's notify protocol (Type=notify, WatchdogSec=), checked
against a stand-in NOTIFY_SOCKET (it.NotifySocket) with WATCHDOG_USEC=2 s:
READY=1 after the boot-up frames are on vcan0/vcan1; STATUS= names the nodes
and interfaces; WATCHDOG=1 keeps coming at less than half the watchdog
interval; SIGHUP (a node added to the config) gives RELOADING=1 with
MONOTONIC_USEC, then READY=1 and a STATUS= with the new node count; SIGTERM
gives STOPPING=1 and exit status 0."""

import os
import re
import signal
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

WATCHDOG_USEC = 2_000_000
HALF = WATCHDOG_USEC / 2 / 1e6

BASE = """
interfaces:
  vcan0: {{bit_rate: 250}}
  vcan1: {{bit_rate: 250}}
nodes:
  - {{profile: {profile}, interface: vcan0, node_id: 0x41, count: 2, name: a}}
  - {{profile: {profile}, interface: vcan1, node_id: 0x51, name: b}}
"""
EXTRA = "  - {{profile: {profile}, interface: vcan0, node_id: 0x45, name: c}}\n"


def status_counts(m: it.NotifySocket.Notification) -> tuple:
    """(nodes, interfaces up, interfaces configured) from a STATUS= line."""
    s = m.get("STATUS", "")
    nodes = re.search(r"(\d+) node\(s\)", s)
    ifs = re.search(r"(\d+)/(\d+) interface\(s\) up", s)
    assert nodes and ifs, f"STATUS= without node and interface counts: {s!r}"
    return int(nodes.group(1)), int(ifs.group(1)), int(ifs.group(2))


def is_(key: str, value: str = "1"):
    return lambda m: m.get(key) == value


def test(ctx: it.Context) -> None:
    profile = ctx.source("profiles/generic-404.yaml")
    with it.NotifySocket(watchdog_usec=WATCHDOG_USEC) as ns, \
            it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
        d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}", env=ns.env())
        cfg = os.path.join(d.state_dir, "fleet.yaml")
        with open(cfg, "w") as f:
            f.write(BASE.format(profile=profile))
        it.drain(bus0)
        it.drain(bus1)
        d.start()

        # READY=1, after the boot-up frames (python-can timestamps are the
        # kernel's receive time; the notification's is taken on arrival).
        ready = ns.expect(is_("READY"), 15, "READY=1")
        boot0 = it.expect(bus0, it.is_bootup(0x41), 5, "boot-up of node 0x41 on vcan0")
        boot1 = it.expect(bus1, it.is_bootup(0x51), 5, "boot-up of node 0x51 on vcan1")
        last_boot = max(boot0.timestamp, boot1.timestamp)
        assert last_boot <= ready.time, \
            f"READY=1 arrived {last_boot - ready.time:.3f}s before the boot-up frames were on the bus"
        it.log(f"READY=1 {1000 * (ready.time - last_boot):.1f} ms after the last boot-up frame")

        # STATUS= before READY=1: 3 nodes, 2/2 interfaces up.
        i_ready = ns.index_of(ready)
        statuses = [m for m in ns.snapshot()[:i_ready] if "STATUS" in m.fields]
        assert statuses, f"no STATUS= before READY=1: {ns.snapshot()[:i_ready + 1]}"
        assert status_counts(statuses[-1]) == (3, 2, 2), statuses[-1].get("STATUS")
        assert not [m for m in ns.snapshot()[:i_ready] if "RELOADING" in m.fields or "STOPPING" in m.fields]
        it.log(f"STATUS={statuses[-1].get('STATUS')}")

        # WATCHDOG=1, repeatedly, each less than half the interval after the last.
        watch_for = 4 * HALF + it.scaled(1.0)
        time.sleep(watch_for)
        pings = [m.mono for m in ns.snapshot() if m.get("WATCHDOG") == "1"]
        assert len(pings) >= 4, f"{len(pings)} WATCHDOG=1 in {watch_for:.1f}s (WATCHDOG_USEC={WATCHDOG_USEC})"
        gaps = [b - a for a, b in zip(pings, pings[1:])]
        assert max(gaps) < HALF, \
            f"WATCHDOG=1 gaps {', '.join(f'{g:.3f}' for g in gaps)}s: not all below half the interval ({HALF:.3f}s)"
        assert not [m for m in ns.snapshot() if m.get("WATCHDOG") not in (None, "1")], "WATCHDOG= other than 1"
        it.log(f"{len(pings)} WATCHDOG=1, gaps {min(gaps):.3f}..{max(gaps):.3f}s (< {HALF:.3f}s)")

        # SIGHUP with one node more: RELOADING=1 (+ MONOTONIC_USEC), then READY=1, STATUS= 4 nodes.
        with open(cfg, "a") as f:
            f.write(EXTRA.format(profile=profile))
        it.drain(bus0)
        mark = len(ns.snapshot())
        d.send_signal(signal.SIGHUP)
        reloading = ns.expect(is_("RELOADING"), 10, "RELOADING=1 after SIGHUP", start=mark)
        mono = reloading.get("MONOTONIC_USEC")
        assert mono and mono.isdigit() and int(mono) > 0, f"RELOADING=1 without MONOTONIC_USEC: {reloading!r}"
        i_rel = ns.index_of(reloading)
        ready2 = ns.expect(is_("READY"), 10, "READY=1 after RELOADING=1", start=i_rel + 1)
        i_ready2 = ns.index_of(ready2)
        between = ns.snapshot()[i_rel + 1:i_ready2]
        assert not [m for m in between if "READY" in m.fields], between
        st = [m for m in between if "STATUS" in m.fields]
        assert st and status_counts(st[-1]) == (4, 2, 2), f"STATUS= between RELOADING=1 and READY=1: {between}"
        it.expect(bus0, it.is_bootup(0x45), 5, "boot-up of the added node 0x45")
        it.log(f"SIGHUP: RELOADING=1 MONOTONIC_USEC={mono}, READY=1, STATUS={st[-1].get('STATUS')}")
        d.assert_alive()

        # SIGTERM: STOPPING=1 and exit 0.
        mark = len(ns.snapshot())
        rc = d.stop()
        assert rc == 0, f"exit status {rc} after SIGTERM"
        stopping = ns.wait_for(is_("STOPPING"), 2.0, start=mark)
        assert stopping is not None, f"no STOPPING=1 after SIGTERM: {ns.snapshot()[mark:]}"
        assert not [m for m in ns.snapshot()[ns.index_of(stopping) + 1:] if "READY" in m.fields]
        it.log("SIGTERM: STOPPING=1, exit 0")


it.main(test)
