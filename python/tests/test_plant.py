"""cansim.plant against a real cansimd on this host: a plant's variables in
units (attributes, items, any unit of a kind), its inputs, overrides and
faults, and the transmitter that reads it. No CAN needed (the nodes run off
the bus); the frames of a closed loop are checked on a socketcand bus
(tests/native/test_example_closed_loop.py).

    CANSIMD=build/cansimd python3 -m pytest -q python/tests/test_plant.py
"""

import os
import time

import pytest

import cansim

HERE = os.path.dirname(os.path.abspath(__file__))
PROFILES = os.path.join(os.path.dirname(os.path.dirname(HERE)), "profiles")

FLEET = f"""
interfaces: {{vcan0: {{}}}}
plants:
  vessel:
    inputs:
      pump_speed: {{unit: '%', initial: 50 %}}
      valve: {{unit: '%', initial: 50 %}}
    blocks:
      tank: {{type: gas_volume, volume: 2 l, pressure: 3 bar, inflow: pump, outflow: vent}}
      pump: {{type: compressor, flow: 600 Nl/min, speed: pump_speed, outlet: tank.pressure}}
      vent: {{type: valve, kv: 0.5, upstream: tank.pressure, opening: valve}}
nodes:
  - {{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, name: pt,
      physics: {{pressure: [{{plant: vessel.pressure}}, {{constant: -1.01325 bar}}]}}}}
"""


def eventually(check, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "not within the time"
        time.sleep(0.02)
    return True


@pytest.fixture(scope="module")
def sim():
    with cansim.start(FLEET, interface="vcan0") as s:
        yield s


@pytest.fixture
def vessel(sim):
    plant = sim.plant("vessel")
    yield plant
    for f in plant.faults():
        f.cancel()
    for name in ("pump_speed", "valve"):
        plant.input(name).clear_override()


def test_variables_read_in_their_units(sim, vessel):
    p = vessel.pressure
    assert isinstance(p, cansim.Quantity) and p.unit == "bar"
    assert 1.0 < p < 20.0
    assert vessel["tank.pressure"].unit == "bar"
    assert vessel.value("pressure", "psi").unit == "psi"
    assert vessel.value("tank.temperature").unit == "degC"
    assert vessel.value("pump.flow", "kg/h").unit == "kg/h"
    v = vessel.variables()
    assert v["pump_speed"] == 50.0 and v["pump_speed"].unit == "%"
    assert set(v) >= {"tank.pressure", "tank.temperature", "tank.mass", "pump.flow", "vent.flow", "valve"}
    with pytest.raises(AttributeError):
        vessel.presure
    with pytest.raises(cansim.Refused) as e:
        vessel.value("pressure", "degC")
    assert e.value.name == "io.cansim.Error.UnknownUnit"
    assert [p.name for p in sim.plants()] == ["vessel"]
    with pytest.raises(cansim.Refused) as e:
        sim.plant("tank")
    assert e.value.name == "io.cansim.Error.UnknownPlant"


def test_an_override_moves_the_vessel_and_its_transmitter_follows(sim, vessel):
    valve = vessel.input("valve")
    valve.override(40, "%")  # settles near 5.8 bar gauge: inside the transmitter's 0..10 bar
    assert valve.value == 40.0 and valve.value.unit == "%"
    assert valve.state().overridden
    # Less vent: the vessel settles higher; the transmitter (gauge, bar) reports it.
    eventually(lambda: abs(vessel.value("vent.flow") - vessel.value("pump.flow")) < 0.01 * vessel.value("pump.flow"),
               timeout=30)
    settled = vessel.pressure
    pt = sim.node("pt")
    eventually(lambda: abs(pt.pressure.true_value - (settled - 1.01325)) < 0.01)
    eventually(lambda: abs(pt.pressure.value - (settled - 1.01325)) < 0.02)
    valve.clear_override()
    assert not valve.state().overridden


def test_set_and_the_age_of_an_input(sim, vessel):
    pump = vessel.input("pump_speed")
    assert pump.age is None  # never set
    pump.set(0.6)  # "" : its own unit, %
    assert pump.value == pytest.approx(0.6)
    assert pump.state().source == "the control API"
    assert pump.age is not None and pump.age < 5.0
    pump.set(50, "%")


def test_a_leak_lowers_the_vessel_until_cancelled(sim, vessel):
    before = vessel.pressure
    with vessel.fault("leak", target="tank", kv=0.2) as leak:
        assert leak.armed and leak.kind == "leak" and leak.target == "tank"
        eventually(lambda: vessel.pressure < before - 0.2, timeout=20)
        assert [f.kind for f in vessel.faults()] == ["leak"]
    assert not leak.armed
    with pytest.raises(cansim.Refused) as e:
        vessel.fault("blocked", target="tank")
    assert e.value.name == "io.cansim.Error.InvalidArgument"
    assert "expected a valve, pump or line" in str(e.value)
