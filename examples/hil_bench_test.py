"""A hardware-in-the-loop bench test against cansimd: copy it and adapt it.

The test plays the bench: it starts a simulated sensor fleet, drives the
sensors' physics through cansimd's control API (D-Bus, python3-dbus) and
checks what a PLC would see on the CAN bus (python3-can). In a real bench
the CAN side is your controller under test; here the test reads the frames
itself.

    python3 -m pytest -q examples/hil_bench_test.py

Needs: a CAN interface (vcan0: `ip link add vcan0 type vcan && ip link set
vcan0 up`), cansimd (CANSIMD=/path/to/cansimd, else `cansimd` in PATH),
Debian packages python3-can python3-dbus python3-gi python3-pytest.
Environment: CANSIMD, CANSIM_SOURCE_DIR (where profiles/ is, default: this
repository), CANSIM_IFACE (default vcan0), CANSIM_IT_TIME_SCALE (stretch the
time windows on a slow machine, default 1).

The fleet: a generic CiA 404 transmitter (node 0x10; TPDO1 = REAL32 pressure
in bar + status byte, every 100 ms) and a Honeywell DPS (node 0x7F; it
reports a broken sensor with EMCY 0x2201; the generic node only sets its
status byte). The tests share one cansimd and run in file order.
"""

import os
import shutil
import signal
import struct
import subprocess
import time

import can
import dbus
import dbus.connection
import pytest
from dbus.mainloop.glib import DBusGMainLoop
from gi.repository import GLib

HERE = os.path.dirname(os.path.abspath(__file__))
CANSIMD = os.environ.get("CANSIMD") or shutil.which("cansimd") or "cansimd"
SOURCE = os.environ.get("CANSIM_SOURCE_DIR") or os.path.dirname(HERE)
IFACE = os.environ.get("CANSIM_IFACE", "vcan0")
SLOW = float(os.environ.get("CANSIM_IT_TIME_SCALE", "1"))

SENSOR, DPS = 0x10, 0x7F
NOT_SUPPORTED = "io.cansim.Error.NotSupported"


# ---------------------------------------------------------------- CAN side

def wait_frame(bus, pred, seconds):
    """The first frame matching pred within seconds (x SLOW), else None."""
    deadline = time.monotonic() + seconds * SLOW
    while time.monotonic() < deadline:
        m = bus.recv(timeout=0.1)
        if m is not None and pred(m):
            return m
    return None


def frames(bus, seconds, pred):
    """All frames matching pred during seconds."""
    out, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        m = bus.recv(timeout=0.1)
        if m is not None and pred(m):
            out.append(m)
    return out


def drain(bus):
    while bus.recv(timeout=0) is not None:
        pass


def cob(base, node):
    return lambda m: m.arbitration_id == base + node and not m.is_remote_frame


def pressure_bar(tpdo1):
    """The generic node's TPDO1: REAL32 process value (bar), status byte."""
    return struct.unpack_from("<f", bytes(tpdo1.data))[0]


# ---------------------------------------------------------------- the simulator

class Cansimd:
    """cansimd with a control socket, and a python3-dbus connection to it."""

    def __init__(self, workdir):
        self.socket = os.path.join(workdir, "control")
        fleet = os.path.join(workdir, "fleet.yaml")
        with open(fleet, "w") as f:
            f.write(f"interfaces:\n  {IFACE}: {{bit_rate: 250}}\n"
                    f"nodes:\n"
                    f"  - {{profile: {SOURCE}/profiles/generic-404.yaml, interface: {IFACE}, "
                    f"node_id: {SENSOR}, name: pressure}}\n"
                    f"  - {{profile: {SOURCE}/profiles/dps.yaml, interface: {IFACE}, name: dps, bit_rate: 250}}\n")
        self.log = open(os.path.join(workdir, "cansimd.log"), "wb")
        self.proc = subprocess.Popen([CANSIMD, "--config", fleet, "--control-socket", self.socket, "--bus", "none",
                                      "--state-dir", os.path.join(workdir, "state")],
                                     stdout=self.log, stderr=subprocess.STDOUT, cwd=workdir)
        deadline = time.monotonic() + 10 * SLOW
        while not os.path.exists(self.socket):
            assert self.proc.poll() is None, f"cansimd exited with {self.proc.returncode}"
            assert time.monotonic() < deadline, "cansimd's control socket did not appear"
            time.sleep(0.05)
        # A main loop only to receive signals; method calls block.
        self.conn = dbus.connection.Connection(f"unix:path={self.socket}", mainloop=DBusGMainLoop())
        self.signals = []
        self.conn.add_signal_receiver(self._signal, member_keyword="member", path_keyword="path")
        self.fleet("Subscribe")

    def _signal(self, *args, member=None, path=None):
        self.signals.append((member, path, args))

    def call(self, path, interface, method, signature="", *args):
        return self.conn.call_blocking("io.cansim.Cansimd1", path, interface, method, signature, args)

    def fleet(self, method, signature="", *args):
        return self.call("/io/cansim/Cansimd1", "io.cansim.Fleet1", method, signature, *args)

    def node(self, name):
        """A node by name, key or IFACE/ID (e.g. "pressure", "vcan0/0x7F")."""
        return Node(self, self.fleet("GetNode", "s", name))

    def mark(self):
        """Dispatch what arrived; the index of the next signal (for wait_signal)."""
        while GLib.MainContext.default().iteration(False):
            pass
        return len(self.signals)

    def wait_signal(self, member, path, seconds, since):
        """The arguments of the first signal `member` from `path` at index >=
        since (a mark() taken before the action), else None."""
        deadline = time.monotonic() + seconds * SLOW
        while time.monotonic() < deadline:
            self.mark()
            for m, p, args in self.signals[since:]:
                if m == member and p == path:
                    return args
            time.sleep(0.01)
        return None

    def stop(self):
        self.conn.close()
        self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(10 * SLOW)
        self.log.close()
        return rc


class Node:
    def __init__(self, sim, path):
        self.sim, self.path = sim, path

    def __call__(self, method, signature="", *args):
        return self.sim.call(self.path, "io.cansim.Node1", method, signature, *args)

    def measurement(self, method, signature="", *args):
        """A physics method. While cansimd answers NotSupported to them (a build
        without the measurement methods), the test is skipped; any other
        error fails it."""
        try:
            return self(method, signature, *args)
        except dbus.DBusException as e:
            if e.get_dbus_name() == NOT_SUPPORTED:
                pytest.skip(f"{method}: cansimd answers {NOT_SUPPORTED} ({e.get_dbus_message()})")
            raise


@pytest.fixture(scope="module")
def can_bus():
    if not os.path.isdir(f"/sys/class/net/{IFACE}"):
        pytest.fail(f"no CAN interface {IFACE}")
    with can.Bus(interface="socketcan", channel=IFACE) as bus:
        yield bus


@pytest.fixture(scope="module")
def sim(can_bus, tmp_path_factory):
    drain(can_bus)
    sim = Cansimd(str(tmp_path_factory.mktemp("cansimd")))
    try:
        # Both sensors power on and send their boot-up.
        for node in (SENSOR, DPS):
            assert wait_frame(can_bus, lambda m: cob(0x700, node)(m) and bytes(m.data) == b"\0", 10), \
                f"no boot-up of node 0x{node:02X}"
        yield sim
    finally:
        assert sim.stop() == 0, "cansimd exit status"


# ---------------------------------------------------------------- the tests

def test_start(sim, can_bus):
    """The bench (the master) starts all nodes; the sensor sends its PDOs."""
    sensor = sim.node("pressure")
    since = sim.mark()
    can_bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0x00], is_extended_id=False))  # NMT start all
    changed = sim.wait_signal("NmtStateChanged", sensor.path, 2, since)  # (time, old state, new state)
    assert changed is not None and changed[2] == "operational", f"NmtStateChanged {changed}"
    pdo = wait_frame(can_bus, cob(0x180, SENSOR), 2)
    assert pdo is not None, "no TPDO1 after NMT start"
    assert 0 < pressure_bar(pdo) < 10


def test_pressure_ramp(sim, can_bus):
    """Step to 2 bar, then ramp to 8 bar over 3 s: the PDOs follow."""
    sensor = sim.node("pressure")
    sensor.measurement("Step", "sds", "pressure", 2.0, "bar")
    drain(can_bus)
    assert abs(pressure_bar(wait_frame(can_bus, cob(0x180, SENSOR), 1)) - 2.0) < 0.02
    sensor.measurement("Ramp", "sdsd", "pressure", 8.0, "bar", 3.0)
    values = [pressure_bar(m) for m in frames(can_bus, 3.0 + SLOW, cob(0x180, SENSOR))]
    assert len(values) >= 20, f"{len(values)} PDOs in {3 + SLOW:.0f} s"
    assert all(b >= a - 0.02 for a, b in zip(values, values[1:])), f"the pressure must rise: {values}"
    assert len([v for v in values if 3.0 < v < 7.0]) >= 10, f"too few values on the way: {values}"
    assert abs(values[-1] - 8.0) < 0.02, f"after the ramp: {values[-1]:.3f} bar"


def test_open_sensor(sim, can_bus):
    """A broken sensor: the DPS sends its EMCY 0x2201, and the error reset when repaired."""
    dps = sim.node("dps")
    drain(can_bus)
    fault = dps.measurement("ArmFault", "sa{ss}", "open", {"channel": "pressure"})
    emcy = wait_frame(can_bus, cob(0x80, DPS), 2)
    assert emcy is not None, "no EMCY of the open sensor"
    code, register = struct.unpack_from("<HB", bytes(emcy.data))
    assert (code, register & 0x01) == (0x2201, 0x01), f"EMCY {bytes(emcy.data).hex()}"
    dps.measurement("CancelFault", "u", fault)
    reset = wait_frame(can_bus, cob(0x80, DPS), 2)
    assert reset is not None and bytes(reset.data[:2]) == b"\0\0", "no error reset EMCY after the repair"


def test_power_cycle(sim, can_bus):
    """Power off for 1 s: the sensor falls silent, then boots (pre-operational)."""
    sensor = sim.node("pressure")
    since = sim.mark()
    t0 = time.time()
    sensor("PowerCycle", "d", 1.0)
    drain(can_bus)  # what the sensor sent before it went off
    boot = wait_frame(can_bus, lambda m: m.arbitration_id & 0x7F == SENSOR, 1 + 2)
    assert boot is not None and boot.arbitration_id == 0x700 + SENSOR and bytes(boot.data) == b"\0", \
        f"the first frame after the power cycle must be the boot-up: {boot}"
    assert boot.timestamp - t0 >= 1.0, f"boot-up {boot.timestamp - t0:.3f} s after power-off"
    assert sim.wait_signal("BootUp", sensor.path, 1, since) is not None, "no BootUp signal"
    assert sensor("Read", "qy", 0x1017, 0) == 1000
    assert wait_frame(can_bus, cob(0x180, SENSOR), 0.5) is None, "PDOs before the next NMT start"
