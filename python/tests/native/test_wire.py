"""The wire in the client, on cansimd's kernel-free bus with python3-can's
socketcand client as the master: captures (the nodes' frames and the
master's, wall-clock timestamps, candump -L that can.LogReader reads),
events lined up with frames, TPDOs decoded by the live mapping through a
unit change and a remapping, and replays onto the bus (cansimctl replay's
pacing, filter, loop)."""

import os
import struct
import time

import can
import pytest

import cansim

PROFILES = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "..", "profiles"))

FLEET = f"""
interfaces: {{bench: {{bit_rate: 250}}}}
nodes:
  - {{profile: {PROFILES}/generic-404.yaml, interface: bench, node_id: 0x10, count: 3, name: pt}}
"""

KPA = 0x03220000  # CiA 303-2: kilo (0x03), pascal (0x22)


@pytest.fixture(scope="module")
def sim():
    with cansim.start(FLEET, transport="socketcand") as s:
        yield s


@pytest.fixture(scope="module")
def master(sim):
    with sim.open_bus("bench") as bus:
        yield bus


@pytest.fixture
def pt(sim):
    yield sim.node("pt/0")
    sim.reset()


def nmt_start(master, node_id):
    master.send(can.Message(arbitration_id=0, data=[1, node_id], is_extended_id=False))


# ---------------------------------------------------------------- captures

def test_a_capture_holds_the_nodes_frames_and_the_masters(sim, master, pt):
    with sim.capture() as wire:
        nmt_start(master, 0x10)
        tpdo = wire.wait_for(can_id=0x190)
        master.send(can.Message(arbitration_id=0x7AB, data=b"\x01\x02", is_extended_id=False))
        wire.wait_for(can_id=0x7AB)
    assert isinstance(tpdo, can.Message) and tpdo.channel == "bench" and not tpdo.is_extended_id
    frames = wire.frames
    nmt = [m for m in frames if m.arbitration_id == 0]
    assert [bytes(m.data) for m in nmt] == [b"\x01\x10"]  # the master's frame, as the bus carried it
    assert all(wire.start_time - 0.001 <= m.timestamp <= wire.stop_time for m in frames)
    assert frames == sorted(frames, key=lambda m: m.timestamp)
    count = len(wire)
    time.sleep(0.3)  # the node goes on sending: a stopped capture does not grow
    assert len(wire) == count


def test_wait_for_says_what_it_saw(sim, master):
    wire = sim.capture()
    master.send(can.Message(arbitration_id=0x7AA, data=b"\x0a", is_extended_id=False))
    wire.wait_for(can_id=0x7AA)
    with pytest.raises(cansim.Timeout) as e:
        wire.wait_for(can_id=0x6AB, timeout=0.3)
    assert "no frame 0x6AB within 0.3 s" in str(e.value) and " bench 7AA#0A" in str(e.value)


def test_a_saved_capture_is_candump_as_python_can_reads_it(sim, master, pt, tmp_path):
    with sim.capture() as wire:
        nmt_start(master, 0x10)
        master.send(can.Message(arbitration_id=0x1ABCDEF, data=b"\xff", is_extended_id=True))
        wire.wait_for(can_id=0x190)
        wire.wait_for(can_id=0x1ABCDEF)
    path = tmp_path / "bench.log"
    assert wire.save(path) == len(wire)
    logged = list(can.LogReader(str(path)))
    assert [(round(m.timestamp, 6), m.arbitration_id, m.is_extended_id, m.is_remote_frame, bytes(m.data), m.channel)
            for m in logged] == \
           [(round(m.timestamp, 6), m.arbitration_id, m.is_extended_id, m.is_remote_frame, bytes(m.data), m.channel)
            for m in wire.frames]
    lines = path.read_text().splitlines()
    assert any(line.endswith(" bench 01ABCDEF#FF") for line in lines)
    assert cansim.read_candump(path) == wire.raw()


def test_candump_lines_as_cansimctl_writes_them(tmp_path):
    path = tmp_path / "kinds.log"
    path.write_text("(1700000000.000001) can0 711#R2\n(1700000000.5) can0 711#R\n# a comment\n\n"
                    "(1700000001.000000) can0 12345678#\n(1700000002.000000) can0 20000080#0000000000000000\n"
                    "(1700000003.000000) can0 123##1AA\n")
    skipped = []
    frames = cansim.read_candump(path, skipped)
    assert [(f.can_id, f.extended, f.rtr, f.dlc, f.data) for f in frames] == \
        [(0x711, False, True, 2, b""), (0x711, False, True, 0, b""), (0x12345678, True, False, 0, b"")]
    assert len(skipped) == 2 and "an error frame" in skipped[0] and "a CAN FD frame" in skipped[1]
    out = tmp_path / "out.log"
    cansim.write_candump(out, frames)
    assert out.read_text().splitlines() == ["(1700000000.000001) can0 711#R2", "(1700000000.500000) can0 711#R",
                                            "(1700000001.000000) can0 12345678#"]
    assert [(m.arbitration_id, m.is_remote_frame, m.dlc) for m in can.LogReader(str(out))] == \
        [(0x711, True, 2), (0x711, True, 0), (0x12345678, False, 0)]
    (tmp_path / "bad.log").write_text("(1700000000.000001) can0 7111#01\n")
    with pytest.raises(ValueError) as e:
        cansim.read_candump(tmp_path / "bad.log")
    assert "bad.log:1: expected ID#DATA with an identifier of 3 or 8 hex digits" in str(e.value)


def test_events_and_frames_share_one_clock(sim, pt):
    with sim.capture() as wire:
        pt.power_cycle(off=0)
        boot = wire.wait_for(can_id=0x710, where=lambda m: bytes(m.data) == b"\0")
        event = pt.wait_for("BootUp")
    # simulated time + the epoch is wall-clock time, the frames' clock (a loaded host's round trip apart at most)
    assert event.wall_time == pytest.approx(sim.epoch + event.time, abs=1e-6)
    assert abs(boot.timestamp - event.wall_time) < 0.05, (boot.timestamp, event.wall_time)
    assert [e.name for e in pt.events(since=wire) if e.name == "BootUp"] == ["BootUp"]


# ---------------------------------------------------------------- TPDOs

def test_tpdo_values_in_their_units(sim, master, pt):
    mark = sim.mark()
    nmt_start(master, 0x10)
    pt.wait_for("NmtStateChanged", new="operational", since=mark, timeout=3)
    tpdo1 = pt.tpdo(1)
    pt.pressure.set(3.5, "bar")
    sample = tpdo1.wait_for(lambda s: abs(s["AI input PV 1"] - 3.5) < 0.01, timeout=3)
    values, frame = sample
    assert set(values) == {"AI input PV 1", "AI status 1"} and sample.units == {"AI input PV 1": "bar", "AI status 1": ""}
    assert frame.arbitration_id == 0x190 and struct.unpack_from("<fB", bytes(frame.data)) == \
        (pytest.approx(values["AI input PV 1"]), values["AI status 1"])
    tpdo2 = pt.tpdo(2)  # synchronous: one per SYNC; INTEGER16 views scaled by their decimals
    master.send(can.Message(arbitration_id=0x80, data=b"", is_extended_id=False))
    tpdo2 = tpdo2.next(timeout=3)
    assert tpdo2.units == {"AI input PV 1 (INTEGER16)": "bar", "AI input PV 2 (INTEGER16)": "degC"}
    assert tpdo2["AI input PV 1 (INTEGER16)"] == pytest.approx(3.5, abs=0.011)
    raw = struct.unpack_from("<h", bytes(tpdo2.frame.data))[0]
    assert tpdo2["AI input PV 1 (INTEGER16)"] == round(raw * 0.01, 2)


def test_tpdo_follows_a_unit_change_and_a_remapping(sim, master, pt):
    nmt_start(master, 0x10)
    pt.pressure.set(3.5, "bar")
    tpdo1 = pt.tpdo(1)
    tpdo1.wait_for(lambda s: abs(s["AI input PV 1"] - 3.5) < 0.01, timeout=3)
    pt.write(0x6131, 1, KPA)
    assert pt.wait_for("PdoMappingChanged")
    in_kpa = tpdo1.wait_for(lambda s: s.units["AI input PV 1"] == "kPa", timeout=3)
    assert in_kpa["AI input PV 1"] == pytest.approx(350, abs=1)  # the number is in its unit
    cob = pt.read(0x1800, 1)
    mark = sim.mark()
    for sub, value in ((1, cob | 0x80000000), (0, 0)):  # CiA 301: invalid, then the mapping cleared
        pt.write(0x1800 if sub else 0x1A00, sub, value)
    pt.write(0x1A00, 1, 0x61500108)  # 0x6150:01, 8 bits: the status byte alone
    pt.write(0x1A00, 0, 1)
    pt.write(0x1800, 1, cob)
    assert pt.wait_for("PdoMappingChanged", since=mark)
    status_only = tpdo1.wait_for(lambda s: "AI input PV 1" not in s.values, timeout=3)
    assert status_only.values == {"AI status 1": 0} and len(status_only.frame.data) == 1
    assert [e.entries[0].index for e in [tpdo1.mapping]] == [0x6150]


def test_tpdo_of_a_silent_node_times_out_naming_it(sim):
    with pytest.raises(cansim.Timeout) as e:
        sim.node("pt/2").tpdo(1).next(timeout=0.3)  # pre-operational: no PDOs
    assert "bench/pt/2: no TPDO1 (CAN-ID 0x192, valid) within 0.3 s" in str(e.value)
    with pytest.raises(cansim.Error):
        sim.node("pt/2").tpdo(9)


# ---------------------------------------------------------------- replay

def write_log(path, rows):
    """rows: (seconds, "ID#DATA") lines of a candump -L file on bus 'rec'."""
    path.write_text("".join(f"({1700000000 + t:.6f}) rec {frame}\n" for t, frame in rows))
    return path


def test_replay_plays_a_file_onto_the_bus(sim, master, tmp_path):
    log = write_log(tmp_path / "rec.log", [(0.00, "321#01"), (0.05, "322#02"), (0.10, "321#03"),
                                           (0.10, "00000123#04"), (0.15, "20000080#0000000000000000")])
    with sim.capture() as wire:
        replay = sim.replay(log, on="bench")
        assert replay.wait(timeout=5) == 4 and replay.skipped == 1  # the error frame is not replayed
        wire.wait_for(can_id=0x123)
    got = [(m.arbitration_id, bytes(m.data)) for m in wire.frames if m.arbitration_id in (0x321, 0x322, 0x123)]
    assert got == [(0x321, b"\x01"), (0x322, b"\x02"), (0x321, b"\x03"), (0x123, b"\x04")]
    heard = [m for m in wire.frames if m.arbitration_id == 0x322]
    assert heard[0].timestamp >= wire.start_time + 0.1  # 100 ms after the call, then the file's spacing


def test_replay_filters_and_loops(sim, tmp_path):
    log = write_log(tmp_path / "rec.log", [(0.0, "181#01"), (0.01, "182#02"), (0.02, "281#03")])
    with sim.capture() as wire:
        with sim.replay(log, on="bench", filter="181:7FF", loop=True, speed=2) as replay:
            wire.wait_for(can_id=0x181, where=lambda m: len([f for f in wire.frames if f.arbitration_id == 0x181]) >= 3,
                          timeout=5)
        assert replay.sent >= 3 and replay.filtered == 2
    assert {m.arbitration_id for m in wire.frames} & {0x182, 0x281} == set()


def test_replay_of_a_capture_and_bad_arguments(sim, master, tmp_path):
    with sim.capture(buses=["bench"]) as recorded:
        master.send(can.Message(arbitration_id=0x555, data=b"\x05", is_extended_id=False))
        recorded.wait_for(can_id=0x555)
    with sim.capture() as wire:
        sim.replay([m for m in recorded.frames if m.arbitration_id == 0x555], on="bench").wait(5)
        assert wire.wait_for(can_id=0x555).data == b"\x05"
    with pytest.raises(ValueError) as e:
        sim.replay(recorded, on="vcan0")
    assert "bench" in str(e.value)
    bad = tmp_path / "bad.log"
    bad.write_text("(1700000000.000000) rec 321#01\n(1700000000.1) rec 321#0\n")
    with pytest.raises(ValueError) as e:
        sim.replay(bad, on="bench")
    assert f"{bad}:2:" in str(e.value)
    with pytest.raises(ValueError):
        sim.replay(recorded, on="bench", filter="xyz")
