#!/usr/bin/env python3
"""cansimd with one generic-404 node on vcan0: boot-up, heartbeat period,
NMT start -> TPDO, SDO reads (expedited 0x1018, segmented string 0x1008),
abort for a missing object, NMT reset node -> boot-up again, SIGTERM -> exit 0
(and the node falls silent)."""

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x10


def test(ctx: it.Context) -> None:
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d = ctx.start_daemon("--profile", ctx.source("profiles/generic-404.yaml"), "--interface", "vcan0",
                             "--node-id", str(NODE), "--state-dir", "{state_dir}")
        boot = it.expect(bus, it.is_bootup(NODE), 10, "boot-up of node 0x10")
        it.log("boot-up seen")
        # The first heartbeat comes one period (1000 ms) after the boot-up, not
        # earlier (the node powers on when it is built, not when loading began).
        first = it.expect(bus, it.is_heartbeat(NODE), 2 + it.scaled(0.5), "first heartbeat")
        after = first.timestamp - boot.timestamp
        assert 0.9 < after < 1.1 + 0.1 * it.SCALE, f"first heartbeat {after:.3f} s after the boot-up"

        sdo = it.SdoClient(bus, NODE)
        assert sdo.upload_u32(0x1000) == 0x00020194
        assert sdo.upload_u32(0x1018, 1) == 0x00CA5D00, "vendor-ID"
        assert sdo.upload_u8(0x1018, 0) == 4
        name = sdo.upload_str(0x1008)  # 40 characters: segmented upload
        assert name == "cansimd generic-404 pressure transmitter", repr(name)
        code = it.SdoClient.abort_code_of(lambda: sdo.upload(0x2FFF, 0))
        assert code == 0x06020000, f"abort for a missing object: {code!r}"
        code = it.SdoClient.abort_code_of(lambda: sdo.upload(0x1018, 9))
        assert code == 0x06090011, f"abort for a missing sub-index: {code!r}"
        it.log("SDO reads and aborts ok")

        # Heartbeat: 200 ms, pre-operational.
        sdo.download_u16(0x1017, 0, 200)
        it.drain(bus)
        beats = it.collect(bus, it.scaled(2.0) + 1.0, it.is_heartbeat(NODE))
        assert len(beats) >= 4, f"{len(beats)} heartbeats"
        assert all(b.data[0] == it.STATE_PRE_OPERATIONAL for b in beats), [it.fmt(b) for b in beats]
        gaps = [b2.timestamp - b1.timestamp for b1, b2 in zip(beats, beats[1:])]
        mean = sum(gaps) / len(gaps)
        assert 0.1 < mean < 0.2 + 0.1 * it.SCALE, f"mean heartbeat gap {mean:.3f}s"
        it.log(f"heartbeat every {mean * 1000:.0f} ms")

        # NMT start: operational heartbeat and TPDO1 (event timer 100 ms).
        it.nmt(bus, it.NMT_START, NODE)
        it.expect(bus, it.is_heartbeat(NODE, it.STATE_OPERATIONAL), 5, "operational heartbeat")
        it.expect(bus, it.is_tpdo(NODE, 1), 5, "TPDO1 after NMT start")
        it.log("operational, TPDO1 seen")

        # Reset node: boot-up again, back in pre-operational with the default 1000 ms heartbeat.
        it.nmt(bus, it.NMT_RESET_NODE, NODE)
        it.expect(bus, it.is_bootup(NODE), 5, "boot-up after reset node")
        assert sdo.upload_u16(0x1017) == 1000, "reset node restores the default heartbeat time"
        it.expect_none(bus, it.is_tpdo(NODE, 1), 0.5, "TPDO1 in pre-operational")
        it.log("reset node ok")

        assert d.stop() == 0, "exit status after SIGTERM"
        it.drain(bus)
        it.expect_none(bus, lambda m: m.arbitration_id & 0x7F == NODE, 1.5, "frame after SIGTERM")
        it.log("SIGTERM: exit 0, node silent")


it.main(test)
