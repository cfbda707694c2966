#!/usr/bin/env python3
"""Stored parameters survive a daemon restart: 0x1017 = 300 ms, 0x1010:02
"save" (communication parameters), SIGTERM, start again with the same state
directory -> 0x1017 reads 300 and heartbeats come every 300 ms. An unsaved
change does not survive."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

NODE = 0x14
SAVE = b"save"


def test(ctx: it.Context) -> None:
    args = ("--profile", ctx.source("profiles/generic-404.yaml"), "--interface", "vcan0", "--node-id", str(NODE),
            "--state-dir", "{state_dir}")
    first = ctx.start_daemon(*args, name="first")
    with it.open_bus("vcan0") as bus:
        it.expect(bus, it.is_bootup(NODE), 10, "boot-up")
        sdo = it.SdoClient(bus, NODE)
        sdo.download_u16(0x1017, 0, 300)
        sdo.download(0x1010, 2, SAVE)
        sdo.download_u32(0x1006, 0, 0)  # touch something else, unsaved
        sdo.download_u16(0x100C, 0, 123)  # guard time: changed after the save, lost
        assert first.stop() == 0
        files = [f for f in os.listdir(first.state_dir) if f.endswith(".params")]
        assert files, f"no parameter file in {os.listdir(first.state_dir)}"
        it.log(f"stored: {files}")

        second = it.Daemon(ctx.require_cansimd(), args, name="second", state_dir=first.state_dir)
        ctx.daemons.append(second)
        it.drain(bus)
        second.start()
        it.expect(bus, it.is_bootup(NODE), 10, "boot-up after restart")
        assert sdo.upload_u16(0x1017) == 300, "0x1017 after restart"
        assert sdo.upload_u16(0x100C) == 0, "unsaved 0x100C must not survive"
        it.drain(bus)
        beats = it.collect(bus, it.scaled(1.5) + 1.0, it.is_heartbeat(NODE))
        gaps = [b - a for a, b in zip([m.timestamp for m in beats], [m.timestamp for m in beats[1:]])]
        assert gaps and 0.2 < sum(gaps) / len(gaps) < 0.3 + 0.1 * it.SCALE, f"heartbeat gaps {gaps}"
        assert second.stop() == 0


it.main(test)
