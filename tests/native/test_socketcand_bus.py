#!/usr/bin/env python3
"""cansimd's socketcand bus with python3-can 4.1's socketcand client as the
master, natively (no kernel CAN): the address reported (READY=1 after the
address file, Fleet1.SocketcandBuses, cansimctl stats), NMT, SDO upload and
download, PDOs and heartbeats, two clients seeing each other's frames (never
their own), arbitration between clients on a slow timed bus, a client that
does not read dropped while the others go on, bad messages answered, a reload adding a bus and refusing to move one."""
# ctest-timeout: 180

import os
import re
import signal
import struct
import time

import cansim_it as it
import cansim_socketcand as sc

FLEET = """\
interfaces:
  bench: {transport: socketcand, listen: "127.0.0.1:0"}
  slow: {transport: socketcand, listen: "127.0.0.1:0", bit_rate: 10}
  flood: {transport: socketcand, listen: "127.0.0.1:0", bus_model: ideal}
nodes:
  - {profile: generic-404, interface: bench, node_id: 0x10, count: 2, name: pt}
"""


def check_reported_address(d: sc.SocketcandDaemon) -> None:
    assert set(d.addresses) == {"bench", "slow", "flood"}, d.addresses
    host, port = d.addresses["bench"]
    assert host == "127.0.0.1" and port != 0, d.addresses
    log = d.daemon.log_text()
    assert f"bench: socketcand on 127.0.0.1:{port}, 250 kbit/s, timed bus" in log, log
    stats = d.cansimctl("--json", "stats")
    assert stats.returncode == 0, stats.stderr
    assert f'"listen_port":{port}' in stats.stdout.replace(" ", ""), stats.stdout
    text = d.cansimctl("stats").stdout
    assert f"127.0.0.1:{port}" in text, text


def check_master(d: sc.SocketcandDaemon) -> None:
    with d.bus("bench") as master, d.bus("bench") as other:
        it.nmt(master, it.NMT_START)
        # Each node's heartbeat says operational, its TPDO1 flows.
        for node in (0x10, 0x11):
            it.expect(master, it.is_heartbeat(node, it.STATE_OPERATIONAL), 5, f"operational heartbeat of {node:#x}")
            it.expect(master, it.is_tpdo(node, 1), 5, f"TPDO1 of {node:#x}")
        sdo = it.SdoClient(master, 0x10)
        assert sdo.upload_u32(0x1000, 0) == 0x00020194
        sdo.download_u16(0x1017, 0, 200)
        assert sdo.upload_u16(0x1017, 0) == 200
        beats = it.collect(master, 2.1, it.is_heartbeat(0x10))
        assert 8 <= len(beats) <= 13, [b.timestamp for b in beats]
        gaps = it.gaps(beats)
        assert 0.1 < sum(gaps) / len(gaps) < 0.35, gaps  # 200 ms apart
        # The other client sees the master's frames; neither hears its own.
        it.drain(master)
        it.drain(other)
        it.send(other, 0x7F1, [0xAA])
        got = it.expect(master, it.has_id(0x7F1), 5, "the other client's frame")
        assert bytes(got.data) == b"\xaa"
        assert it.wait_for(other, it.has_id(0x7F1), 0.5) is None, "a client heard its own frame"
        it.send(master, 0x610, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])
        it.expect(other, it.has_id(0x610), 5, "the master's SDO request")
        it.expect(other, it.has_id(0x590), 5, "the node's SDO answer")


def check_arbitration(d: sc.SocketcandDaemon) -> None:
    """On a 10 kbit/s bus an 8-byte frame takes about 13 ms: frames another
    client sends while ten low-priority ones wait overtake them."""
    with d.bus("slow") as low, d.bus("slow") as high, d.bus("slow") as watch:
        for b in (low, high, watch):
            it.send(b, 0x7FF, [])  # ends the rawmode hold of each
        time.sleep(0.2)
        it.drain(watch)
        for i in range(10):
            it.send(low, 0x700, [i] * 8)
        for i in range(5):
            it.send(high, 0x100, [i] * 8)
        seen = [m for m in it.collect(watch, it.scaled(3) + 1.5) if m.arbitration_id in (0x100, 0x700)]
        order = [(m.arbitration_id, m.data[0]) for m in seen]
        assert len(order) == 15, order
        assert [i for (cid, i) in order if cid == 0x700] == list(range(10)), order
        last_high = max(k for k, (cid, _) in enumerate(order) if cid == 0x100)
        lost = [k for k, (cid, _) in enumerate(order) if cid == 0x700 and k > last_high]
        assert lost, f"no 0x700 frame lost arbitration to 0x100: {order}"
        it.log(f"arbitration on slow: {order}")


def check_slow_client_dropped(d: sc.SocketcandDaemon) -> None:
    with d.raw("flood", rcvbuf=4096) as sleeper, d.bus("flood") as sender, d.bus("flood") as reader:
        sleeper.handshake("flood")
        sleeper.send("< echo >")
        it.send(reader, 0x7FF, [])
        for i in range(40000):
            it.send(sender, 0x181, struct.pack("<I", i))
            if i % 500 == 0:
                it.drain(reader)
            if i % 2000 == 0 and "dropped: reads too slowly" in d.daemon.log_text():
                break
        deadline = time.monotonic() + it.scaled(10)
        while "dropped: reads too slowly" not in d.daemon.log_text():
            assert time.monotonic() < deadline, "the client that does not read was not dropped"
            time.sleep(0.1)
        it.drain(reader)
        it.send(sender, 0x182, [0x42])
        it.expect(reader, it.has_id(0x182), 5, "frames after the slow client was dropped")
    assert "flood: socketcand client 127.0.0.1:" in d.daemon.log_text()


def check_bad_messages(d: sc.SocketcandDaemon) -> None:
    with d.raw("bench") as c:
        assert c.read_until("< hi >") == "< hi >"
        c.send("< open vcan0 >")
        assert c.read_until(">") == "< error could not open bus: this port serves bench >"
        assert c.read_until("nothing") == "<EOF>"
    with d.raw("bench") as c:
        c.handshake("bench")
        c.send("< send 123 9 >< send 605 2 1 >< bogus >")
        answers = re.findall(r"<[^<>]*>", c.read_until("bogus >"))
        assert answers[-3:] == ["< error send: expected a DLC of 0 to 8 >", "< error send: 1 data byte(s) for DLC 2 >",
                                "< error unknown command bogus >"], answers
        c.send("< echo >")
        assert c.read_until("< echo >").endswith("\n< echo >")


def check_reload(d: sc.SocketcandDaemon) -> None:
    """A reload adds a socketcand bus (listening, in the address file before
    READY=1); it never moves a running one (refused, the fleet unchanged)."""
    fleet = os.path.join(d.daemon.state_dir, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write(FLEET.replace('  flood:', '  more: {transport: socketcand, listen: "127.0.0.1:0"}\n  flood:'))
    start = len(d.notify.snapshot())
    d.daemon.send_signal(signal.SIGHUP)
    d.notify.expect(lambda m: m.get("READY") == "1", 20, "READY=1 after the reload", start)
    with open(d.address_file) as f:
        names = [line.split()[0] for line in f]
    assert names == ["bench", "slow", "flood", "more"], names
    with open(fleet, "w") as f:
        f.write(FLEET.replace('bench: {transport: socketcand, listen: "127.0.0.1:0"}', "bench: {}"))
    d.daemon.send_signal(signal.SIGHUP)
    deadline = time.monotonic() + it.scaled(10)
    while "interfaces.bench: its transport and listen address stay as cansimd started them" not in d.daemon.log_text():
        assert time.monotonic() < deadline, "the transport change was not refused"
        time.sleep(0.1)
    with d.bus("bench") as master:  # still served
        it.expect(master, it.has_id(0x710), 5, "a heartbeat after the refused reload")


def check_port_in_use(ctx: it.Context, d: sc.SocketcandDaemon) -> None:
    """A bus that cannot listen at start is fatal: no READY=1 for a bus nobody can reach."""
    host, port = d.addresses["bench"]
    second = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}", "--control-socket",
                        "{state_dir}/control", "--bus", "none", name="second")
    with open(os.path.join(second.state_dir, "fleet.yaml"), "w") as f:
        f.write(f'interfaces: {{bench: {{transport: socketcand, listen: "{host}:{port}"}}}}\nnodes: []\n')
    second.start()
    assert second.wait(10) == 1, "a second cansimd on a port in use did not exit 1"
    assert f"bench: cannot listen on {host}:{port}: Address already in use" in second.log_text(), second.log_text()


def test(ctx: it.Context) -> None:
    with sc.SocketcandDaemon(ctx, FLEET) as d:
        check_reported_address(d)
        check_master(d)
        check_arbitration(d)
        check_slow_client_dropped(d)
        check_bad_messages(d)
        check_reload(d)
        check_port_in_use(ctx, d)
        d.daemon.assert_alive()


it.main(test)
