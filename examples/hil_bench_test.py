"""A HIL bench: 20 simulated pressure sensors, this test is the master (examples/README.md)."""
import struct
import time

import can
import pytest

pytest_plugins = ["cansim.pytest_plugin"]


@pytest.fixture(scope="module")
def cansim_config():  # 20 generic CiA 404 transmitters, node-IDs 0x10..0x23
    return "nodes: [{profile: generic-404, interface: $INTERFACE, node_id: 0x10, count: 20, name: pt}]"


@pytest.fixture
def pt(cansim, cansim_bus):  # pt/7 started by the master; afterwards the fleet is back at power-on
    node, mark = cansim.node("pt/7"), cansim.mark()
    cansim_bus.send(can.Message(arbitration_id=0, data=[1, node.node_id], is_extended_id=False))  # NMT start
    node.wait_for("NmtStateChanged", new="operational", since=mark, timeout=5)
    yield node
    cansim.reset()


def received(bus, can_id, seconds):  # the frames with can_id the master receives from now on
    start, end = time.time(), time.monotonic() + seconds
    frames = iter(lambda: bus.recv(max(end - time.monotonic(), 0)), None)  # until a recv times out
    return [m for m in frames if m.arbitration_id == can_id and m.timestamp >= start]


def test_ramp_reaches_the_master(cansim_bus, pt):
    pt.pressure.set(2.0, "bar")
    pt.tpdo(1).wait_for(lambda pdo: abs(pdo["AI input PV 1"] - 2.0) < 0.01)  # the effect, not the next frame
    pt.pressure.set(8.0, "bar", ramp=2)  # TPDO1: REAL32 pressure in bar, status byte
    bar = [struct.unpack("<fB", m.data[:5])[0] for m in received(cansim_bus, 0x180 + pt.node_id, 3)]
    assert bar[0] < 6 and abs(bar[-1] - 8) < 0.05 and all(b > a - 0.05 for a, b in zip(bar, bar[1:]))


def test_broken_sensor_and_power_cycle(cansim, pt):
    tpdo1 = pt.tpdo(1)  # decoded by the node's live mapping, values in their units
    with pt.fault("open"):  # 0x6150 bit 0 in TPDO1 from the sensor's next sample on
        tpdo1.wait_for(lambda pdo: pdo["AI status 1"] & 1)
        assert all(tpdo1.next()["AI status 1"] & 1 for _ in range(5))
    with cansim.capture() as bus:  # what the master hears, with wall-clock timestamps
        pt.power_cycle(off=1)  # silent for 1 s, then the boot-up
        boot = bus.wait_for(can_id=0x700 + pt.node_id, where=lambda m: m.data == b"\0", timeout=3)
    assert pt.wait_for("BootUp") and boot.timestamp - bus.start_time >= 1.0
