"""The cansim client against a real cansimd on this host.

The control API works without the CAN interfaces (the nodes run, their
frames count as not sent), so every call's effect is checked through the
public API here; what reaches the wire is checked in the VM
(tests/integration/test_python_client.py).

    CANSIMD=build/cansimd python3 -m pytest -q python/tests
"""

import math
import os
import signal
import time

import pytest

import cansim

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
PROFILES = os.path.join(REPO, "profiles")

FLEET = f"""
interfaces:
  vcan0: {{bit_rate: 250}}
nodes:
  - {{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, count: 12, name: pt}}
  - {{profile: {PROFILES}/dps.yaml, interface: $INTERFACE, bit_rate: 250, name: dps}}
  - {{profile: {PROFILES}/smc.yaml, interface: $INTERFACE, bit_rate: 250, name: smc}}
"""


def eventually(check, timeout=2.0):
    """check() becomes true within timeout (what follows the sensor's sampling)."""
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "not within the time"
        time.sleep(0.01)
    return True


def us(seconds):
    """Simulated seconds as the daemon's whole microseconds."""
    return round(seconds * 1e6)


@pytest.fixture(scope="module")
def sim():
    with cansim.start(FLEET, interface="vcan0") as s:
        yield s


@pytest.fixture
def pt(sim):
    node = sim.node("pt/3")
    yield node
    for f in node.faults():
        f.cancel()
    node.pressure.clear_override()
    node.pressure.restore_model()


# ---------------------------------------------------------------- start, nodes

def test_start_returns_with_every_node_booted(sim):
    states = sim.states()
    assert len(states) == 14
    # the SMC boots 150 ms after power-on (boot_up_delay_ms): still waited for
    assert {s.nmt_state for s in states} == {"pre-operational"}, [(s.key, s.nmt_state) for s in states]
    assert os.path.isfile(sim.log)


def test_nodes_in_natural_order(sim):
    keys = [n.key for n in sim.nodes()]
    # pt/2 before pt/10
    assert keys == ["vcan0/dps/0"] + [f"vcan0/pt/{i}" for i in range(12)] + ["vcan0/smc/0"]
    assert len(sim) == 14


def test_node_by_key_name_and_id(sim):
    by_key = sim.node("vcan0/dps/0")
    assert sim.node("dps") == by_key
    assert sim.node("vcan0/0x7F") == by_key
    assert sim["dps"] == by_key
    assert (by_key.key, by_key.name, by_key.interface, by_key.node_id) == ("vcan0/dps/0", "dps", "vcan0", 0x7F)
    assert (by_key.profile, by_key.personality) == ("dps", "honeywell-dps")
    assert sim.node("pt/11").node_id == 0x10 + 11


def test_node_by_integer_node_id(sim):
    assert sim.node(0x7F) == sim.node("dps")
    assert sim.node(0x13).key == "vcan0/pt/3"
    with pytest.raises(cansim.NoSuchNode) as e:
        sim.node(0x55)
    assert "0x55" in str(e.value) and "0x10" in str(e.value)  # the fleet's node-IDs, for the reader
    (twin,) = sim.add("{profile: generic-404, interface: vcan1, node_id: 0x13, name: twin}")
    try:
        with pytest.raises(cansim.NoSuchNode) as e:
            sim.node(0x13)
        assert "vcan0/pt/3" in str(e.value) and "vcan1/twin/0" in str(e.value)
        assert sim.node("vcan1/0x13") == twin
    finally:
        sim.remove(twin)


def test_unknown_node_is_no_such_node(sim):
    with pytest.raises(cansim.NoSuchNode) as e:
        sim.node("nothing-here")
    assert e.value.name == "io.cansim.Error.UnknownNode"
    assert "nothing-here" in str(e.value)
    with pytest.raises(cansim.NoSuchNode):
        sim.node("pt")  # a count: group's name alone is ambiguous


def test_node_state_in_one_call(sim):
    s = sim.node("pt/0").state()
    assert isinstance(s, cansim.NodeState)
    assert s.key == "vcan0/pt/0" and s.node_id == 0x10 and s.powered
    assert s.pressure.unit == "bar" and s.temperature.unit == "degC"
    assert s.last_emcy is None or s.last_emcy.code >= 0


def test_simulated_time_advances(sim):
    t0 = sim.time
    time.sleep(0.05)
    assert sim.time > t0 + 0.04


# ---------------------------------------------------------------- channels

def test_set_steps_the_true_value(pt):
    pt.pressure.set(3.25, "bar")
    r = pt.pressure.reading()
    assert r.true_value == pytest.approx(3.25)
    assert (r.unit, r.status) == ("bar", 0)
    assert pt.pressure.wait_for(3.25, tolerance=0.05).value == pytest.approx(3.25, abs=0.05)


def test_a_device_in_counts_reads_in_true_units(sim):
    # The SMC reports field counts by default (0..20000 over 0..5 bar; its
    # 0x6131 is informational): the reading says what they mean, in bar.
    smc = sim.node("smc")
    smc.pressure.set(4, "bar")
    r = smc.pressure.wait_for(4, tolerance=0.01)
    assert r.unit == "bar" and r.value == pytest.approx(4, abs=0.01)
    assert r.counts == pytest.approx(16000, abs=40)
    assert smc.state().pressure.counts == pytest.approx(16000, abs=40)
    assert sim.node("pt/0").pressure.reading().counts is None  # a CiA 404 PV is in its unit


def test_set_converts_units_and_defaults_to_the_channel_unit(pt):
    pt.pressure.set(250, "kPa")
    assert pt.pressure.true_value == pytest.approx(2.5)
    pt.pressure.set(4.5)  # the channel's unit: bar
    assert pt.pressure.true_value == pytest.approx(4.5)
    pt.temperature.set(300, "K")
    assert pt.temperature.true_value == pytest.approx(26.85)


def test_ramp_then_hold(pt):
    pt.pressure.set(1.0, "bar")
    pt.pressure.set(101.0, "bar", ramp=100)  # 1 bar/s
    a = pt.pressure.true_value
    time.sleep(0.1)
    b = pt.pressure.true_value
    assert 1.0 <= a < b < 10.0
    pt.pressure.hold()
    c = pt.pressure.true_value
    time.sleep(0.05)
    assert pt.pressure.true_value == pytest.approx(c)


def test_override_reports_a_value_the_process_does_not_have(pt):
    pt.pressure.set(2.0, "bar")
    pt.pressure.override(12.0, "bar")
    r = pt.pressure.reading()
    assert (r.value, r.true_value) == (pytest.approx(12.0), pytest.approx(2.0))
    assert pt.state().overrides == [("pressure", 12.0, "bar")]
    pt.pressure.clear_override()
    pt.pressure.wait_for(2.0, tolerance=0.05)
    with pytest.raises(cansim.Timeout) as e:
        pt.pressure.wait_for(9.0, timeout=0.05)
    assert "not 9 ± 0.01" in str(e.value)


def test_model_and_restore_model(pt):
    pt.pressure.model("- constant: 7 bar\n- sine: {amplitude: 0.5 bar, period: 10 s}")
    values = [pt.pressure.true_value for _ in range(3)]
    assert all(6.4 < v < 7.6 for v in values)
    pt.pressure.restore_model()
    with pytest.raises(cansim.Refused) as e:
        pt.pressure.model("- constant: [not a value")
    assert e.value.name == "io.cansim.Error.InvalidArgument"


def test_bad_values_are_refused_with_the_daemon_error(pt):
    with pytest.raises(cansim.Refused) as e:
        pt.pressure.set(1.0, "furlongs")
    assert e.value.name == "io.cansim.Error.UnknownUnit"
    assert "furlongs" in e.value.message
    with pytest.raises(cansim.Refused) as e:
        pt.pressure.set(float("inf"), "bar")
    assert e.value.name.startswith("io.cansim.Error.")
    with pytest.raises(cansim.Refused) as e:
        pt.pressure.set(2.0, "bar", ramp=-1)
    assert e.value.name == "io.cansim.Error.OutOfRange"


def test_node_without_a_temperature_channel(sim):
    dps = sim.node("dps")
    assert dps.state().temperature is None
    with pytest.raises(cansim.Refused) as e:
        dps.temperature.set(20, "degC")
    assert e.value.name == "io.cansim.Error.UnknownChannel"


# ---------------------------------------------------------------- faults

def test_fault_is_a_context_manager(pt):
    with pt.fault("open") as f:
        assert isinstance(f, cansim.Fault) and f.kind == "open" and f.id >= 0
        assert f.active
        started = pt.wait_for("FaultStarted", id=f.id)
        assert started.fields == {"id": f.id, "kind": "open"}
        assert eventually(lambda: pt.pressure.status & 0x01)  # 0x6150 bit 0: invalid, from the next sample
        assert [g.id for g in pt.faults()] == [f.id]
    assert pt.wait_for("FaultEnded", id=f.id).node == pt.key
    assert not f.active and not f.armed and pt.faults() == []
    f.cancel()  # already over: no error


def test_fault_with_duration_and_parameters(pt):
    pt.pressure.set(2.0, "bar")
    f = pt.fault("stuck", duration=1.0, value="3 bar", channel="pressure")
    assert pt.wait_for("FaultStarted", id=f.id).time is not None
    pt.pressure.wait_for(3.0, tolerance=0.05)
    ended = pt.wait_for("FaultEnded", id=f.id, timeout=5)
    started = pt.wait_for("FaultStarted", id=f.id)
    assert 1_000_000 <= us(ended.time - started.time) < 1_250_000  # never early; late by a busy host's wake-up


def test_fault_at_a_simulated_time(pt, sim):
    at = sim.time + 1.0  # far enough ahead for a loaded host
    f = pt.fault("open", at=at, duration=0.1)
    assert not f.active
    started = pt.wait_for("FaultStarted", id=f.id, timeout=5)
    assert 0 <= us(started.time - at) < 250_000


def test_unknown_fault_kind_is_refused(pt):
    with pytest.raises(cansim.Refused) as e:
        pt.fault("gremlins")
    assert e.value.name == "io.cansim.Error.UnknownFault"
    with pytest.raises(cansim.Refused) as e:
        pt.fault("open", duration="two seconds")
    assert e.value.name == "io.cansim.Error.InvalidArgument"


def test_network_faults_take_their_keys_as_python_names(pt):
    # class_ is error_frames' class; delay and jitter are seconds; a key of
    # another kind is refused by the daemon, naming it.
    with pt.fault("error_frames", duration=0.5, class_="passive", period=0.1) as e, \
            pt.fault("frame_delay", service="heartbeat", delay=0.03, jitter=0.01) as d:
        assert {f.id: f.kind for f in pt.faults()} == {e.id: "error_frames", d.id: "frame_delay"}
        assert pt.wait_for("FaultEnded", id=e.id, timeout=5).node == pt.key
    with pytest.raises(cansim.Refused) as r:
        pt.fault("frame_drop", service="tpdo1", dlc=3)
    assert r.value.name == "io.cansim.Error.InvalidArgument" and "dlc" in str(r.value)
    with pytest.raises(cansim.Refused):
        pt.fault("error_frames", class_="meteor")


def test_vendor_emcy_and_last_emcy(sim):
    dps = sim.node("dps")
    count = dps.emcy_count
    with dps.fault("open", channel="pressure"):
        emcy = dps.wait_for("EmcySent", code=0x2201)
        assert emcy.fields["register"] & 0x01
        assert isinstance(emcy.fields["vendor"], bytes) and len(emcy.fields["vendor"]) == 5
        assert dps.last_emcy.code == 0x2201
    reset = dps.wait_for("EmcySent", code=0, since=emcy)
    assert reset.time >= emcy.time
    assert dps.emcy_count == count + 2


# ---------------------------------------------------------------- NMT, power, storage

def test_nmt_commands(pt):
    pt.nmt("start")
    assert pt.wait_for("NmtStateChanged").fields == {"old": "pre-operational", "new": "operational"}
    assert pt.nmt_state == "operational"
    pt.nmt("stop")
    assert pt.wait_for("NmtStateChanged", new="stopped").fields["old"] == "operational"
    pt.nmt("pre-operational")
    pt.wait_for("NmtStateChanged", new="pre-operational")
    pt.nmt("reset-communication")
    assert pt.wait_for("BootUp").fields == {"node_id": pt.node_id}
    pt.nmt("reset-node")
    pt.wait_for("BootUp")
    assert pt.nmt_state == "pre-operational"
    with pytest.raises(ValueError) as e:
        pt.nmt("explode")
    assert "pre-operational (preop)" in str(e.value)


def test_nmt_aliases_are_cansimctls_words(pt):
    pt.nmt("start")
    pt.nmt("preop")
    assert pt.wait_for("NmtStateChanged", new="pre-operational")
    pt.nmt("reset-comm")
    pt.wait_for("BootUp")
    pt.nmt("reset")
    assert pt.wait_for("BootUp")["node_id"] == pt.node_id


def test_power_cycle(pt):
    pt.power_cycle(off=1.0)
    assert not pt.powered
    boot = pt.wait_for("BootUp", timeout=5)
    off = pt.wait_for("NmtStateChanged", new="initialising")
    assert 1_000_000 <= us(boot.time - off.time) < 1_250_000
    assert pt.powered and pt.nmt_state == "pre-operational"


def test_store_survives_a_power_cycle_and_restore_brings_defaults(pt):
    pt.write(0x1017, 0, 321)
    pt.store()
    pt.power_cycle(off=0)
    pt.wait_for("BootUp", timeout=5)
    assert pt.read(0x1017) == 321
    pt.restore()
    pt.nmt("reset-node")
    pt.wait_for("BootUp", timeout=5)
    assert pt.read(0x1017) == 1000


# ---------------------------------------------------------------- objects

def test_read_is_typed_by_the_object_dictionary(pt):
    assert pt.read(0x1018, 1) == pt.read("0x1018:1") and isinstance(pt.read(0x1018, 1), int)
    assert pt.read(0x1018, 4) == 4  # serial: the count: group's 1 + index 3
    assert isinstance(pt.read(0x1008), str) and pt.read(0x1008)
    pv = pt.read(0x6130, 1)
    assert isinstance(pv, float) and not math.isnan(pv)
    assert pt.read(0x2001)[:4] == bytes.fromhex("00112233")  # DOMAIN
    assert pt.read(0x2000).startswith("cansimd reference node")


def test_write_strings_and_bytes(pt):
    pt.write(0x2001, 0, b"\x01\x02\x03")
    assert pt.read(0x2001) == b"\x01\x02\x03"
    pt.write(0x2000, 0, "bench 7")
    assert pt.read(0x2000) == "bench 7"


def test_write_then_read(pt):
    pt.write(0x1017, 0, 250)
    assert pt.read(0x1017) == 250
    pt.write("0x1017", 0, 1000)
    assert pt.read(0x1017) == 1000


def test_bad_objects_are_refused(pt):
    with pytest.raises(cansim.Refused) as e:
        pt.read(0x5FFF, 7)
    assert e.value.name == "io.cansim.Error.UnknownObject"
    with pytest.raises(cansim.Refused) as e:
        pt.write(0x1017, 0, 1 << 40)
    assert e.value.name == "io.cansim.Error.OutOfRange"
    with pytest.raises(cansim.Refused):
        pt.write(0x1017, 0, "text")
    with pytest.raises(TypeError):
        pt.write(0x1017, 0, [1, 2])


# ---------------------------------------------------------------- events

def test_wait_for_starts_at_the_last_action(pt):
    pt.nmt("start")
    pt.wait_for("NmtStateChanged", new="operational")
    pt.nmt("stop")
    # the earlier change to operational is before this action: not returned
    assert pt.wait_for("NmtStateChanged").fields["new"] == "stopped"
    with pytest.raises(cansim.Timeout) as e:
        pt.wait_for("NmtStateChanged", new="operational", timeout=0.2)
    assert "NmtStateChanged" in str(e.value) and e.value.seen
    pt.nmt("pre-operational")


def test_mark_and_since(pt, sim):
    mark = sim.mark()
    pt.nmt("start")
    pt.nmt("stop")
    first = pt.wait_for("NmtStateChanged", since=mark)
    assert first.fields["new"] == "operational"
    second = pt.wait_for("NmtStateChanged", since=first)
    assert second.fields["new"] == "stopped"
    names = [(e.name, e.fields.get("new")) for e in sim.events(since=mark) if e.node == pt.key]
    assert names == [("NmtStateChanged", "operational"), ("NmtStateChanged", "stopped")]
    assert [e.fields["new"] for e in pt.events(since=mark)] == ["operational", "stopped"]
    assert pt.wait_for("NmtStateChanged", since=mark, new=lambda s: s.startswith("st")) == second
    pt.nmt("pre-operational")


def test_events_carry_their_wall_time(pt, sim):
    before = time.time()
    pt.nmt("start")
    e = pt.wait_for("NmtStateChanged")
    after = time.time()
    assert e.wall_time == pytest.approx(sim.epoch + e.time, abs=1e-6)
    # the epoch is as good as the round trip it was read in (sim.epoch_error)
    slack = sim.epoch_error + 0.002
    assert 0 <= sim.epoch_error < 1, sim.epoch_error
    assert before - slack <= e.wall_time <= after + slack, (before, e.wall_time, after, sim.epoch_error)
    pt.nmt("pre-operational")


def test_wait_for_pdo_mapping_changed(pt):
    pt.nmt("reset-communication")  # the PDO configuration is loaded again
    e = pt.wait_for("PdoMappingChanged")
    assert e.node == pt.key and e.fields == {}
    pt.wait_for("BootUp")


def test_wait_for_names_are_checked(pt):
    with pytest.raises(ValueError) as e:
        pt.wait_for("Bootup")
    assert "BootUp" in str(e.value)


def test_events_of_other_nodes_do_not_match(sim):
    a, b = sim.node("pt/0"), sim.node("pt/1")
    b.nmt("start")
    with pytest.raises(cansim.Timeout):
        a.wait_for("NmtStateChanged", timeout=0.1)
    assert sim.wait_for("NmtStateChanged", node="pt/1").node == b.key
    b.nmt("pre-operational")


# ---------------------------------------------------------------- fleet changes

def test_add_and_remove(sim):
    nodes = sim.add("{profile: generic-404, interface: vcan0, node_id: 0x60, count: 2, name: extra}")
    assert [n.key for n in nodes] == ["vcan0/extra/0", "vcan0/extra/1"]
    assert sim.wait_for("NodeAdded").fields["key"] == "vcan0/extra/0"
    assert nodes[1].wait_for("BootUp").fields["node_id"] == 0x61
    sim.remove("extra/0")
    assert sim.wait_for("NodeRemoved").node == "vcan0/extra/0"
    with pytest.raises(cansim.NoSuchNode):
        sim.node("extra/0")
    with pytest.raises(cansim.NoSuchNode):
        nodes[0].nmt_state
    sim.remove(nodes[1])
    assert len(sim) == 14


def test_add_from_a_file(sim, tmp_path):
    fragment = tmp_path / "more.yaml"
    fragment.write_text("- {profile: generic-404, interface: vcan0, node_id: 0x70, name: filed}\n")
    (node,) = sim.add(str(fragment))
    assert node.node_id == 0x70
    sim.remove(node)


def test_bad_fragment_names_its_place(sim):
    with pytest.raises(cansim.Refused) as e:
        sim.add("{profile: generic-404, interface: vcan0, node_id: 0x61, nmae: typo}")
    assert e.value.name == "io.cansim.Error.Config"
    assert "nmae" in e.value.message and ":1:" in e.value.message
    with pytest.raises(cansim.Refused):
        sim.add("{profile: generic-404, interface: vcan0, node_id: 0x10}")  # node-ID taken
    assert len(sim) == 14


def test_reset_returns_the_fleet_to_power_on():
    fleet = (f"nodes:\n  - {{profile: {PROFILES}/generic-404.yaml, interface: vcan0, node_id: 0x10, count: 2, name: pt}}\n"
             f"  - {{profile: {PROFILES}/dps.yaml, interface: vcan0, bit_rate: 250, name: dps}}\n")
    with cansim.start(fleet) as sim:
        pt, dps = sim.node("pt/0"), sim.node("dps")
        pt.write(0x1017, 0, 321)
        pt.store()
        pt.nmt("start")
        pt.pressure.override(9.5, "bar")
        dps.fault("open", channel="pressure")
        sim.add("{profile: generic-404, interface: vcan0, node_id: 0x30, name: extra}")
        sim.remove("pt/1")
        sim.reset()
        assert [n.key for n in sim.nodes()] == ["vcan0/dps/0", "vcan0/pt/0", "vcan0/pt/1"]
        assert {s.nmt_state for s in sim.states()} == {"pre-operational"}
        assert pt.read(0x1017) == 1000  # the stored 321 is erased: the profile's default
        assert pt.state().overrides == [] and dps.faults() == []
        assert pt.wait_for("BootUp")["node_id"] == 0x10  # waits from the reset
        pt.power_cycle(off=0)
        pt.wait_for("BootUp", timeout=5)
        assert pt.read(0x1017) == 1000  # nothing stored comes back


def test_reload(sim):
    sim.reload()
    assert len(sim) == 14


def test_bus_statistics(sim):
    (vcan0,) = sim.bus_statistics()
    assert vcan0.interface == "vcan0" and vcan0.bit_rate_kbit == 250


# ---------------------------------------------------------------- connect

def test_connect_to_a_running_daemon(sim):
    with cansim.connect(sim.control_socket) as other:
        assert [n.key for n in other.nodes()] == [n.key for n in sim.nodes()]
        node = other.node("pt/5")
        node.nmt("start")
        assert node.wait_for("NmtStateChanged").fields["new"] == "operational"
        node.nmt("pre-operational")
    assert sim.node("pt/5").nmt_state == "pre-operational"  # the first connection still works


def test_connect_uses_the_environment(sim, monkeypatch):
    monkeypatch.setenv("CANSIM_CONTROL_SOCKET", sim.control_socket)
    with cansim.connect() as other:
        assert len(other) == 14


def test_connect_to_nothing_is_an_error(tmp_path):
    with pytest.raises(cansim.Error) as e:
        cansim.connect(str(tmp_path / "no-socket"))
    assert "no-socket" in str(e.value)
    with pytest.raises(ValueError):
        cansim.connect(bus="session")


# ---------------------------------------------------------------- start and stop

def test_start_one_profile():
    with cansim.start(profile=os.path.join(PROFILES, "dps.yaml"), node_id=5) as sim:
        (node,) = sim.nodes()
        assert (node.node_id, node.profile, node.nmt_state) == (5, "dps", "pre-operational")


def test_start_with_a_bad_config_reports_the_daemon_error(tmp_path):
    bad = tmp_path / "fleet.yaml"
    bad.write_text("interfaces:\n  vcan0: {bit_rate: 250}\nnodes:\n  - {profile: generic-404, interface: vcan0, node_id: 300}\n")
    with pytest.raises(cansim.Error) as e:
        cansim.start(str(bad))
    assert "fleet.yaml:4" in str(e.value) and "node_id" in str(e.value)
    assert "exited with status 1" in str(e.value)


def test_start_argument_errors(tmp_path):
    with pytest.raises(ValueError):
        cansim.start()
    with pytest.raises(ValueError):
        cansim.start("x.yaml", profile="dps")
    with pytest.raises(cansim.Error) as e:
        cansim.start(str(tmp_path / "missing.yaml"))
    assert "missing.yaml" in str(e.value)
    with pytest.raises(cansim.Error) as e:
        cansim.start(profile="dps", binary=str(tmp_path / "no-cansimd"))
    assert "no-cansimd" in str(e.value)


def test_a_crashed_daemon_is_an_error_not_a_hang():
    sim = cansim.start(profile=os.path.join(PROFILES, "generic-404.yaml"))
    node = sim.node("vcan0/0x10")
    os.kill(sim.pid, signal.SIGKILL)
    t0 = time.monotonic()
    with pytest.raises(cansim.Error):
        node.wait_for("BootUp", timeout=30)
    with pytest.raises(cansim.Error):
        node.nmt_state
    assert time.monotonic() - t0 < 5
    with pytest.raises(cansim.Error) as e:
        sim.close()
    assert "status -9" in str(e.value)


def test_close_stops_the_daemon():
    sim = cansim.start(profile=os.path.join(PROFILES, "generic-404.yaml"))
    pid = sim.pid
    sim.close()
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # stopped and reaped
    sim.close()  # twice is fine
