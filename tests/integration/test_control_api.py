#!/usr/bin/env python3
"""The runtime control API (docs/control-api.md) on the private peer-to-peer
D-Bus socket (--control-socket PATH --bus none), driven with python3-dbus and
checked on vcan0 with python-can (the frames), as a bench would see it.

Fleet: two generic-404 nodes (0x10, 0x11, entry "generic") and a Honeywell
DPS (0x7F, entry "dps", at 250 kbit/s) on vcan0.

 1. ListNodes / GetNode by key, name/INDEX, IFACE/ID, name; fleet properties;
    busctl --address=unix:path=... tree lists the node paths, and introspects
    a node (the XML, without reading properties).
 2. Nmt("start") -> operational heartbeat and TPDO1 on the wire, NmtStateChanged.
 3. Write 0x1017 = 200 -> the heartbeat period changes on the wire; Read back;
    a local write raises no ObjectWritten.
 4. Write a read-only object (0x1018:04) locally -> an SDO upload by the test
    returns it, an SDO download is refused (read-only).
 5. A master SDO download and an RPDO -> ObjectWritten (via "sdo" / "rpdo").
 6. PowerCycle(0.5) -> silence, then the boot-up >= 0.5 s later; Powered,
    BootUp signal with a simulated time >= 0.5 s later.
 7. AddNodes of a fragment -> boot-up of 0x20 on the wire, NodeAdded;
    RemoveNode -> NodeRemoved and the node falls silent; AddNodes collisions.
 8. Errors by name: UnknownNode, UnknownObject, OutOfRange, InvalidArgument,
    Config, Refused, sd-bus's UnknownObject for a removed node's path.
 9. Measurement (Step / Ramp / Override on generic-404's TPDO1, REAL32 PV in
    bar every 100 ms; ArmFault open / CancelFault on the DPS -> EMCY 0x2201 and
    the error reset 0x0000, EmcySent / FaultStarted / FaultEnded; properties
    Pressure / Temperature / Overrides / Faults, busctl introspect with values).
    While the daemon answers io.cansim.Error.NotSupported to these methods
    (they are being written) the checks are skipped with a SKIP line; the skip
    is all-or-nothing: a check skips only when its FIRST measurement call
    answers exactly io.cansim.Error.NotSupported, and if some measurement
    checks run while others skip, the test fails.
"""

# ctest-timeout: 240

import math
import os
import shutil
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

import dbus  # noqa: E402  (python3-dbus)

G0, G1, DPS, ADDED = 0x10, 0x11, 0x7F, 0x20
KEYS = {"vcan0/generic/0": G0, "vcan0/generic/1": G1, "vcan0/dps/0": DPS}

E = "io.cansim.Error."
UNKNOWN_OBJECT_PATH = "org.freedesktop.DBus.Error.UnknownObject"


def from_node(node: int):
    """Any frame a node sends (its COB-IDs carry its node-ID in the low 7 bits)."""
    return lambda m: m.arbitration_id & 0x7F == node and m.arbitration_id >= 0x80


def tpdo1_bar(m) -> float:
    """generic-404 TPDO1: REAL32 PV 0x6130:01 (bar) + status 0x6150:01."""
    assert m.dlc == 5, f"generic-404 TPDO1 must be REAL32 + status (DLC 5): {it.fmt(m)}"
    return struct.unpack_from("<f", bytes(m.data))[0]


def next_tpdo1(bus, node: int = G0):
    """The next TPDO1 of node sent after the call we just got the answer to.
    cansimd puts what its nodes sent before a call on the wire before it
    answers, so a frame stamped (by the kernel) before now is older than the
    call, even if python-can had not read it yet."""
    answered = time.time()
    it.drain(bus)
    is_tpdo1 = it.is_tpdo(node, 1)
    return it.expect(bus, lambda m: is_tpdo1(m) and m.timestamp >= answered, 2, f"TPDO1 of node 0x{node:02X}")


def tpdo1_reaching(bus, target: float, tol: float = 0.02, node: int = G0) -> float:
    """The first TPDO1 after the call carrying `target` (it.pdo_after_call)."""
    return it.pdo_after_call(bus, node, 1, tpdo1_bar, lambda v: abs(v - target) <= tol,
                             f"TPDO1 of node 0x{node:02X} reaching {target} bar")


# --------------------------------------------------------------------------
# 1. fleet

def fleet(c: it.ControlClient, sock: str) -> None:
    nodes = c.fleet("ListNodes")
    it.log(f"ListNodes: {[(n[1], hex(n[4]), n[5], n[6], n[7]) for n in nodes]}")
    by_key = {n[1]: n for n in nodes}
    assert set(by_key) == set(KEYS), f"ListNodes keys {sorted(by_key)}"
    for key, node_id in KEYS.items():
        path, k, name, iface, nid, profile, personality, state = by_key[key]
        iface_, name_, index = key.split("/")
        assert path == it.control_node_path(iface_, name_, int(index)), path
        assert (name, iface, nid) == (name_, "vcan0", node_id), by_key[key]
        assert state == "pre-operational", by_key[key]
    assert by_key["vcan0/dps/0"][5:7] == ("dps", "honeywell-dps"), by_key["vcan0/dps/0"]
    assert by_key["vcan0/generic/0"][5:7] == ("generic-404", "generic"), by_key["vcan0/generic/0"]
    assert by_key["vcan0/dps/0"][0] == "/io/cansim/Cansimd1/node/vcan0/dps/_30"

    g0, g1, dps = (it.control_node_path("vcan0", "generic", 0), it.control_node_path("vcan0", "generic", 1),
                   it.control_node_path("vcan0", "dps", 0))
    for spec, path in [("vcan0/generic/0", g0), ("generic/1", g1), ("vcan0/16", g0), ("vcan0/0x11", g1),
                       ("vcan0/0x7F", dps), ("dps", dps), ("vcan0/dps/0", dps)]:
        got = c.fleet("GetNode", "s", spec)
        assert got == path, f"GetNode({spec!r}) = {got}, expected {path}"
    msg = it.expect_dbus_error(lambda: c.fleet("GetNode", "s", "generic"), E + "UnknownNode",
                               "GetNode of the ambiguous name 'generic'")
    it.log(f"GetNode('generic'): UnknownNode: {msg}")
    for spec in ["nope", "vcan0/0x42", "vcan1/0x10", "generic/7"]:
        it.expect_dbus_error(lambda: c.fleet("GetNode", "s", spec), E + "UnknownNode", f"GetNode({spec!r})")

    assert c.fleet_property("NodeCount") == 3
    version = c.fleet_property("Version")
    assert isinstance(version, str) and version, repr(version)
    t1 = c.fleet_property("SimulatedTime")
    time.sleep(0.2)
    t2 = c.fleet_property("SimulatedTime")
    assert 0 < t1 < t2, f"SimulatedTime {t1} then {t2}"
    assert c.fleet_property("ConfigFile").endswith("fleet.yaml")
    n = c.node("dps")
    props = {p: n.get(p) for p in ["Key", "Name", "Index", "Profile", "Personality", "Interface", "NodeId",
                                   "NmtState", "Powered", "OnBus"]}
    assert props == {"Key": "vcan0/dps/0", "Name": "dps", "Index": 0, "Profile": "dps",
                     "Personality": "honeywell-dps", "Interface": "vcan0", "NodeId": DPS,
                     "NmtState": "pre-operational", "Powered": True, "OnBus": True}, props
    stats = c.fleet("GetBusStatistics")
    assert [s[0] for s in stats] == ["vcan0"] and stats[0][1] is True and stats[0][2] == 250, stats
    it.log(f"fleet ok: version {version}, simulated time {t2} us, vcan0 statistics {stats[0]}")

    busctl = shutil.which("busctl")
    if busctl is None:
        raise AssertionError("busctl not found (Debian package systemd, scripts/install-deps)")
    addr = f"--address=unix:path={sock}"
    out = subprocess.run([busctl, addr, "--list", "tree"], capture_output=True, text=True,
                         timeout=it.scaled(10))
    assert out.returncode == 0, f"busctl tree: {out.returncode} {out.stderr}"
    for p in [g0, g1, dps]:
        assert p in out.stdout.split(), f"busctl tree does not list {p}:\n{out.stdout}"
    out = subprocess.run([busctl, addr, "introspect", "--xml-interface", it.CONTROL_BUS_NAME, dps],
                         capture_output=True, text=True, timeout=it.scaled(10))
    assert out.returncode == 0, f"busctl introspect --xml-interface: {out.returncode} {out.stderr}"
    for s in ['<interface name="io.cansim.Node1">', '<method name="PowerCycle">', '<method name="ArmFault">',
              '<signal name="ObjectWritten">', '<property name="NmtState" type="s" access="read">',
              '<interface name="org.freedesktop.DBus.Properties">']:
        assert s in out.stdout, f"busctl introspect of {dps} lacks {s}:\n{out.stdout}"
    out = subprocess.run([busctl, addr, "call", it.CONTROL_BUS_NAME, it.CONTROL_PATH, it.FLEET_INTERFACE,
                          "GetNode", "s", "vcan0/0x10"], capture_output=True, text=True, timeout=it.scaled(10))
    assert out.returncode == 0 and out.stdout.strip() == f'o "{g0}"', f"busctl call: {out.stdout} {out.stderr}"
    it.log("busctl: tree lists the 3 node paths, introspect shows io.cansim.Node1, call GetNode works")


# --------------------------------------------------------------------------
# 2.-5. NMT, heartbeat, objects, ObjectWritten

def nmt_and_objects(c: it.ControlClient, bus) -> None:
    g0 = c.node("vcan0/0x10")
    mark = c.mark()
    it.drain(bus)
    g0.call("Nmt", "s", "start")
    it.expect(bus, it.is_heartbeat(G0, it.STATE_OPERATIONAL), 3, "operational heartbeat of 0x10")
    t = it.expect(bus, it.is_tpdo(G0, 1), 2, "TPDO1 of 0x10 after Nmt start")
    s = c.expect_signal("NmtStateChanged", 2, path=g0.path, start=mark, what="0x10 started")
    assert s.args[1:] == ["pre-operational", "operational"], s
    assert g0.get("NmtState") == "operational"
    it.log(f"Nmt start: operational heartbeat, TPDO1 {it.fmt(t)} ({tpdo1_bar(t):.4f} bar), {s}")
    it.expect_none(bus, it.is_tpdo(G1, 1), 0.5, "TPDO1 of 0x11 (only 0x10 was started)")

    # Heartbeat 1000 ms -> 200 ms, written locally.
    assert g0.read(0x1017, 0) == 1000
    g0.write(0x1017, 0, dbus.UInt16(200))
    it.drain(bus)
    beats = it.collect(bus, it.scaled(1.0) + 1.0, it.is_heartbeat(G0))
    assert len(beats) >= 4, f"{len(beats)} heartbeats in {it.scaled(1.0) + 1.0:.1f}s after 0x1017 = 200"
    mean = it.mean_gap(beats)
    assert 0.15 < mean < 0.2 + 0.05 * it.SCALE, f"mean heartbeat gap {mean:.3f}s after 0x1017 = 200 ms"
    assert all(b.data[0] == it.STATE_OPERATIONAL for b in beats)
    assert g0.read(0x1017, 0) == 200
    sdo = it.SdoClient(bus, G0)
    assert sdo.upload_u16(0x1017) == 200, "SDO upload of 0x1017 after the local write"
    it.log(f"Write 0x1017 = 200: heartbeat every {mean * 1000:.0f} ms on the wire, Read and SDO read 200")

    # A read-only object, written locally, is what the master reads.
    assert g0.read(0x1018, 4) == 1
    g0.write(0x1018, 4, dbus.UInt32(0xDEADBEEF))
    assert g0.read(0x1018, 4) == 0xDEADBEEF
    assert sdo.upload_u32(0x1018, 4) == 0xDEADBEEF, "SDO upload of 0x1018:04 after the local write"
    code = it.SdoClient.abort_code_of(lambda: sdo.download_u32(0x1018, 4, 5))
    assert code == 0x06010002, f"SDO download to read-only 0x1018:04: abort {code!r}"
    it.log("Write of read-only 0x1018:04 = 0xDEADBEEF: SDO upload returns it; SDO download aborts 0x06010002")

    # Strings and a typed Read.
    assert g0.read(0x1008, 0) == "cansimd generic-404 pressure transmitter"
    assert isinstance(g0.read(0x6130, 1), float)

    # A master write: ObjectWritten with the value, via sdo / rpdo. Local
    # writes (above) raise none.
    mark = c.mark()
    sdo.download_u32(0x2100, 1, 0xCAFEBABE)
    s = c.expect_signal("ObjectWritten", 2, path=g0.path, start=mark, what="SDO download of 0x2100:01")
    assert s.args[1:] == [0x2100, 1, 0xCAFEBABE, "sdo"], s
    it.send(bus, 0x200 + G0, struct.pack("<IH", 0x12345678, 0xBEEF))
    s = c.expect_signal("ObjectWritten", 2, path=g0.path, start=mark, pred=lambda x: x.args[4] == "rpdo",
                        what="RPDO1 of 0x10")
    assert s.args[1:4] == [0x2100, 1, 0x12345678] or s.args[1:4] == [0x2100, 2, 0xBEEF], s
    c.pump(0.2)
    rpdo = [x.args[1:] for x in c.signals[mark:] if x.member == "ObjectWritten" and x.args[4] == "rpdo"]
    assert [0x2100, 1, 0x12345678, "rpdo"] in rpdo and [0x2100, 2, 0xBEEF, "rpdo"] in rpdo, rpdo
    assert g0.read(0x2100, 2) == 0xBEEF
    local = [x for x in c.signals if x.member == "ObjectWritten" and x.args[1] in (0x1017, 0x1018)]
    assert not local, f"ObjectWritten for a local Write: {local}"
    it.log("ObjectWritten on 0x10: sdo 0x2100:01 = 0xCAFEBABE; rpdo "
           + ", ".join(f"0x{i:04X}:{s:02X} = 0x{v:X}" for i, s, v, _ in rpdo))


# --------------------------------------------------------------------------
# 6. power cycle

def power_cycle(c: it.ControlClient, bus) -> None:
    g1 = c.node("generic/1")
    mark = c.mark()
    sim0 = c.fleet_property("SimulatedTime")
    it.drain(bus)
    t0 = time.time()
    g1.call("PowerCycle", "d", 0.5)
    t_ret = time.time()
    assert g1.get("Powered") is False, "Powered during the off time"
    frames = []
    boot = None
    deadline = time.monotonic() + 0.5 + it.scaled(2.0)
    while boot is None and time.monotonic() < deadline:
        m = it.wait_for(bus, from_node(G1), deadline - time.monotonic())
        if m is None:
            break
        if it.is_bootup(G1)(m):
            boot = m
        else:
            frames.append(m)
    assert boot is not None, "no boot-up of 0x11 after PowerCycle(0.5)"
    # Frames stamped before the reply arrived may predate the power-off (the
    # node's heartbeat); nothing may follow it until the boot-up.
    before = [f for f in frames if f.timestamp < t_ret]
    frames = [f for f in frames if f.timestamp >= t_ret]
    assert not frames, f"0x11 sent while powered off: {[it.fmt(f) for f in frames]}"
    if before:
        it.log(f"frames of 0x11 sent before the reply (before the power-off): {[it.fmt(f) for f in before]}")
    off = boot.timestamp - t0
    assert off >= 0.5 - 0.002, f"boot-up {off:.3f}s after PowerCycle(0.5) was called"
    assert boot.timestamp - t_ret < 0.5 + it.scaled(1.0), f"boot-up {boot.timestamp - t_ret:.3f}s after the reply"
    s = c.expect_signal("BootUp", 2, path=g1.path, start=mark, what="BootUp of 0x11")
    assert s.args[1] == G1 and s.args[0] - sim0 >= 500_000, f"{s} (SimulatedTime before the call {sim0})"
    assert g1.get("Powered") is True and g1.get("NmtState") == "pre-operational"
    it.log(f"PowerCycle(0.5): silent, boot-up {off:.3f}s after the call ({it.fmt(boot)}), "
           f"BootUp at +{(s.args[0] - sim0) / 1e6:.3f}s simulated")
    it.expect_dbus_error(lambda: g1.call("PowerCycle", "d", -1.0), E + "OutOfRange", "PowerCycle(-1)")


# --------------------------------------------------------------------------
# 7. AddNodes / RemoveNode

def add_remove(c: it.ControlClient, bus, ctx: it.Context) -> None:
    profile = ctx.source("profiles", "generic-404.yaml")
    mark = c.mark()
    it.drain(bus)
    paths = c.fleet("AddNodes", "s", f"{{profile: {profile}, interface: vcan0, node_id: 0x20, name: added}}")
    want = it.control_node_path("vcan0", "added", 0)
    assert paths == [want], f"AddNodes returned {paths}"
    boot = it.expect(bus, it.is_bootup(ADDED), 3, "boot-up of the added node 0x20")
    s = c.expect_signal("NodeAdded", 2, path=it.CONTROL_PATH, start=mark, what="NodeAdded")
    assert s.args == [want, "vcan0/added/0"], s
    assert c.fleet_property("NodeCount") == 4
    it.log(f"AddNodes: {paths}, {it.fmt(boot)} on the wire, {s}")

    # Make it talk (100 ms heartbeat, TPDOs), then remove it.
    added = c.node("added")
    added.write(0x1017, 0, dbus.UInt16(100))
    added.call("Nmt", "s", "start")
    talk = it.collect(bus, it.scaled(0.5) + 0.5, from_node(ADDED))
    assert len(talk) >= 4, f"{len(talk)} frames of 0x20 in {it.scaled(0.5) + 0.5:.1f}s"
    mark = c.mark()
    c.fleet("RemoveNode", "s", "vcan0/0x20")
    it.drain(bus)
    s = c.expect_signal("NodeRemoved", 2, path=it.CONTROL_PATH, start=mark, what="NodeRemoved")
    assert s.args == [want, "vcan0/added/0"], s
    it.expect_none(bus, from_node(ADDED), 1.0, "frame of the removed node 0x20")
    assert c.fleet_property("NodeCount") == 3
    assert sorted(n[1] for n in c.fleet("ListNodes")) == sorted(KEYS)
    it.expect_dbus_error(lambda: c.fleet("GetNode", "s", "added"), E + "UnknownNode", "GetNode of a removed node")
    it.expect_dbus_error(lambda: added.read(0x1000, 0), UNKNOWN_OBJECT_PATH, "Read on a removed node's path")
    it.expect_dbus_error(lambda: c.fleet("RemoveNode", "s", "added"), E + "UnknownNode", "RemoveNode twice")
    it.log(f"RemoveNode: {s}, 0x20 silent ({len(talk)} frames before)")

    # Atomic refusals: a node-ID collision, a duplicate name, bad YAML, a bad profile.
    for what, yaml in [("node-ID collision", f"{{profile: {profile}, interface: vcan0, node_id: 0x10, name: x}}"),
                       ("duplicate name", f"{{profile: {profile}, interface: vcan0, node_id: 0x21, name: generic}}"),
                       ("YAML syntax", "nodes: ["),
                       ("missing profile", "{profile: /nonexistent.yaml, interface: vcan0, name: y}"),
                       ("list with one bad entry", f"- {{profile: {profile}, interface: vcan0, node_id: 0x22, name: ok}}\n"
                                                   f"- {{profile: {profile}, interface: vcan0, node_id: 0x10, name: bad}}\n")]:
        msg = it.expect_dbus_error(lambda: c.fleet("AddNodes", "s", yaml), E + "Config", f"AddNodes: {what}")
        it.log(f"AddNodes ({what}): Config: {msg}")
    assert c.fleet_property("NodeCount") == 3, "a refused AddNodes added something"
    it.expect_none(bus, it.is_bootup(0x22), 0.3, "boot-up of a node of a refused AddNodes")


# --------------------------------------------------------------------------
# 8. errors by name

def errors(c: it.ControlClient) -> None:
    g0 = c.node("vcan0/generic/0")
    cases = [
        ("Read of a missing object", lambda: g0.read(0x2FFF, 0), "UnknownObject"),
        ("Read of a missing sub-index", lambda: g0.read(0x1018, 9), "UnknownObject"),
        ("Write of a missing object", lambda: g0.write(0x2FFF, 0, dbus.UInt32(1)), "UnknownObject"),
        ("Write 70000 to UNSIGNED16 0x1017", lambda: g0.write(0x1017, 0, dbus.UInt32(70000)), "OutOfRange"),
        ("Write -1 to UNSIGNED16 0x1017", lambda: g0.write(0x1017, 0, dbus.Int32(-1)), "OutOfRange"),
        ("Write 9 to 0x6132:01 (high: 4)", lambda: g0.write(0x6132, 1, dbus.Byte(9)), "OutOfRange"),
        ("Write 1.5 to UNSIGNED16", lambda: g0.write(0x1017, 0, dbus.Double(1.5)), "InvalidArgument"),
        ("Write a string to UNSIGNED16", lambda: g0.write(0x1017, 0, "abc"), "InvalidArgument"),
        ("Nmt bogus", lambda: g0.call("Nmt", "s", "bogus"), "InvalidArgument"),
        ("Store sub 0", lambda: g0.call("Store", "y", 0), "OutOfRange"),
        ("Store sub 200", lambda: g0.call("Store", "y", 200), "OutOfRange"),
    ]
    for what, fn, name in cases:
        msg = it.expect_dbus_error(fn, E + name, what)
        it.log(f"{what}: {name}: {msg}")
    # Text numbers are accepted where they fit; the value is unchanged by the refusals above.
    g0.write(0x1017, 0, "0xC8")
    assert g0.read(0x1017, 0) == 200
    # Store / Restore work (as 0x1010 / 0x1011 "save" / "load").
    g0.call("Store", "y", 1)
    g0.call("Restore", "y", 1)


# --------------------------------------------------------------------------
# 9. measurement (pending methods skip, all or nothing)

class Pending(Exception):
    """The first measurement call of a check answered io.cansim.Error.NotSupported."""


class Measurement:
    """Measurement calls: the first one of a check may answer exactly
    io.cansim.Error.NotSupported (the methods are not written yet) -> Pending;
    any other error, or NotSupported after a measurement call of the same check
    succeeded, fails."""

    def __init__(self):
        self.calls = 0

    def call(self, node: it.ControlNode, method: str, signature: str = "", *args):
        return self._do(f"{method}{tuple(args)!r}", lambda: node.call(method, signature, *args))

    def get(self, node: it.ControlNode, prop: str):
        return self._do(f"property {prop}", lambda: node.get(prop))

    def get_all(self, node: it.ControlNode):
        return self._do("GetAll(io.cansim.Node1)", lambda: node.client.call(
            node.path, "org.freedesktop.DBus.Properties", "GetAll", "s", it.NODE_INTERFACE))

    def _do(self, what: str, fn):
        try:
            r = fn()
        except dbus.DBusException as e:
            if e.get_dbus_name() == it.ERROR_NOT_SUPPORTED:
                if self.calls == 0:
                    raise Pending(f"{what} answered {e.get_dbus_name()} ({e.get_dbus_message()})") from None
                raise AssertionError(f"{what} answered {e.get_dbus_name()} ({e.get_dbus_message()}) "
                                     f"after {self.calls} measurement call(s) of this check succeeded") from None
            raise
        self.calls += 1
        return r


def check_step(c: it.ControlClient, bus, m: Measurement) -> None:
    g0 = c.node("vcan0/0x10")
    m.call(g0, "Step", "sds", "pressure", 7.5, "bar")
    v = tpdo1_reaching(bus, 7.5)
    assert abs(v - 7.5) <= 0.02, f"TPDO1 after Step(7.5 bar): {v:.4f} bar"
    true, reported, unit, status = m.get(g0, "Pressure")
    assert (unit, status) == ("bar", 0) and abs(true - 7.5) < 1e-9 and abs(reported - 7.5) <= 0.02, \
        f"Pressure {(true, reported, unit, status)}"
    it.log(f"Step 7.5 bar: next TPDO1 {v:.4f} bar; Pressure {(true, reported, unit, status)}")
    m.call(g0, "Step", "sds", "pressure", 500.0, "kPa")
    v = tpdo1_reaching(bus, 5.0)
    assert abs(v - 5.0) <= 0.02, f"TPDO1 after Step(500 kPa): {v:.4f} bar"
    it.log(f"Step 500 kPa: next TPDO1 {v:.4f} bar")
    for what, fn, name in [
            ("Step in degC", lambda: g0.call("Step", "sds", "pressure", 1.0, "degC"), "UnknownUnit"),
            ("Step of channel flow", lambda: g0.call("Step", "sds", "flow", 1.0, "bar"), "UnknownChannel"),
            ("Temperature channel of the DPS", lambda: c.node("dps").call("Step", "sds", "temperature", 20.0, "degC"),
             "UnknownChannel"),
            ("Ramp over -1 s", lambda: g0.call("Ramp", "sdsd", "pressure", 1.0, "bar", -1.0), "OutOfRange")]:
        msg = it.expect_dbus_error(fn, E + name, what)
        it.log(f"{what}: {name}: {msg}")
    t = m.get(c.node("dps"), "Temperature")
    assert math.isnan(t[0]) and t[2] == "", f"DPS Temperature (no channel): {t}"


def check_ramp(c: it.ControlClient, bus, m: Measurement) -> None:
    g0 = c.node("vcan0/0x10")
    m.call(g0, "Step", "sds", "pressure", 5.0, "bar")
    it.drain(bus)
    m.call(g0, "Ramp", "sdsd", "pressure", 2.5, "bar", 2.0)
    window = 2.0 + max(1.0, it.scaled(0.3))
    values = [tpdo1_bar(x) for x in it.collect(bus, window, it.is_tpdo(G0, 1))]
    it.log(f"Ramp 5 -> 2.5 bar over 2 s: {len(values)} TPDO1s: "
           f"{[round(v, 3) for v in values[:3]]} .. {[round(v, 3) for v in values[-3:]]}")
    assert len(values) >= 10, f"{len(values)} TPDO1s in {window:.1f}s"
    assert 4.7 <= values[0] <= 5.02, f"first value of the ramp {values[0]:.4f}"
    assert all(b <= a + 0.02 for a, b in zip(values, values[1:])), f"the ramp must fall: {values}"
    between = [v for v in values if 2.6 < v < 4.9]
    assert len(between) >= 5, f"only {len(between)} values on the way from 5 to 2.5 bar: {values}"
    assert abs(values[-1] - 2.5) <= 0.02, f"value after the ramp {values[-1]:.4f}"
    assert abs(m.get(g0, "Pressure")[0] - 2.5) < 1e-9


def check_override(c: it.ControlClient, bus, m: Measurement) -> None:
    g0 = c.node("vcan0/0x10")
    m.call(g0, "Override", "sds", "pressure", 4.321, "bar")
    first = next_tpdo1(bus)
    more = it.collect(bus, 0.5, it.is_tpdo(G0, 1))
    want = struct.pack("<f", 4.321)
    for x in [first] + more:
        assert bytes(x.data[:4]) == want, f"TPDO1 under Override(4.321 bar): {it.fmt(x)}, want {want.hex()}"
    overrides = m.get(g0, "Overrides")
    assert len(overrides) == 1 and overrides[0][0] == "pressure" and abs(overrides[0][1] - 4.321) < 1e-6 \
        and overrides[0][2] == "bar", f"Overrides {overrides}"
    true, reported, unit, _ = m.get(g0, "Pressure")
    assert abs(reported - 4.321) < 1e-5 and abs(true - 2.5) < 1e-6, f"Pressure {(true, reported, unit)}"
    it.log(f"Override 4.321 bar: {1 + len(more)} TPDO1s exactly {want.hex()}; Overrides {overrides}")
    m.call(g0, "ClearOverride", "s", "pressure")
    v = tpdo1_bar(next_tpdo1(bus))
    assert abs(v - 2.5) <= 0.02, f"TPDO1 after ClearOverride: {v:.4f}"
    assert m.get(g0, "Overrides") == []
    it.log(f"ClearOverride: TPDO1 {v:.4f} bar")


def check_fault(c: it.ControlClient, bus, m: Measurement) -> None:
    dps = c.node("dps")
    dps.call("Nmt", "s", "start")
    it.expect(bus, it.is_tpdo(DPS, 1), 2, "TPDO1 of the DPS")
    count0 = dps.get("EmcyCount")
    mark = c.mark()
    it.drain(bus)
    fid = m.call(dps, "ArmFault", "sa{ss}", "open", {"channel": "pressure"})
    emcy = it.expect(bus, it.is_emcy(DPS), 2, "EMCY of the open sensor")
    code, reg, vendor = it.emcy_fields(emcy)
    assert code == 0x2201 and reg & 0x01, f"EMCY of the DPS's open sensor: {it.fmt(emcy)}"
    s = c.expect_signal("EmcySent", 2, path=dps.path, start=mark, what="EmcySent")
    assert s.args[1:] == [code, reg, list(vendor)], f"{s} vs {it.fmt(emcy)}"
    f = c.expect_signal("FaultStarted", 2, path=dps.path, start=mark, what="FaultStarted")
    assert f.args[1:] == [fid, "open"], f
    faults = m.call(dps, "ListFaults")
    mine = [x for x in faults if x[0] == fid]
    assert len(mine) == 1 and mine[0][1:4] == ("open", "pressure", True) and mine[0][5] == -1, f"ListFaults {faults}"
    assert (fid, "open", True) in m.get(dps, "Faults")
    last = dps.get("LastEmcy")
    assert last[1:3] == (code, reg) and last[0] >= 0, f"LastEmcy {last}"
    assert dps.get("EmcyCount") == count0 + 1
    it.log(f"ArmFault open -> id {fid}: {it.fmt(emcy)}, {s}, {f}, ListFaults {mine}")

    mark = c.mark()
    it.drain(bus)
    m.call(dps, "CancelFault", "u", fid)
    reset = it.expect(bus, it.is_emcy(DPS), 2, "error reset EMCY after CancelFault")
    assert it.emcy_fields(reset)[0] == 0x0000, f"expected the error reset EMCY: {it.fmt(reset)}"
    s = c.expect_signal("EmcySent", 2, path=dps.path, start=mark, what="EmcySent of the error reset")
    assert s.args[1] == 0, s
    f = c.expect_signal("FaultEnded", 2, path=dps.path, start=mark, what="FaultEnded")
    assert f.args[1:] == [fid, "open"], f
    assert not [x for x in m.call(dps, "ListFaults") if x[0] == fid]
    it.log(f"CancelFault {fid}: {it.fmt(reset)}, {s}, {f}")
    it.expect_dbus_error(lambda: dps.call("CancelFault", "u", fid), E + "UnknownFault", "CancelFault twice")
    it.expect_dbus_error(lambda: dps.call("ArmFault", "sa{ss}", "melted", {}), E + "UnknownFault",
                         "ArmFault of an unknown kind")


def check_properties(c: it.ControlClient, sock: str, m: Measurement) -> None:
    g0 = c.node("vcan0/0x10")
    props = m.get_all(g0)
    for p in ["Pressure", "Temperature", "Overrides", "Faults", "EmcyCount", "LastEmcy", "Recording"]:
        assert p in props, f"GetAll lacks {p}: {sorted(props)}"
    assert props["Temperature"][2] == "degC" and -40 < props["Temperature"][0] < 125, props["Temperature"]
    managed = c.call(it.CONTROL_PATH, "org.freedesktop.DBus.ObjectManager", "GetManagedObjects")
    assert sorted(managed) == sorted(it.control_node_path(*k.split("/")[:2], int(k.split("/")[2])) for k in KEYS), \
        sorted(managed)
    out = subprocess.run(["busctl", f"--address=unix:path={sock}", "introspect", it.CONTROL_BUS_NAME, g0.path],
                         capture_output=True, text=True, timeout=it.scaled(10))
    assert out.returncode == 0 and ".Pressure" in out.stdout, f"busctl introspect: {out.stderr}\n{out.stdout}"
    it.log(f"GetAll: Pressure {props['Pressure']}, Temperature {props['Temperature']}; GetManagedObjects "
           f"lists {len(managed)} nodes; busctl introspect with values works")


def measurement(c: it.ControlClient, bus, sock: str) -> None:
    checks = [("Step", lambda m: check_step(c, bus, m)),
              ("Ramp", lambda m: check_ramp(c, bus, m)),
              ("Override", lambda m: check_override(c, bus, m)),
              ("ArmFault/CancelFault", lambda m: check_fault(c, bus, m)),
              ("properties", lambda m: check_properties(c, sock, m))]
    ran, skipped = [], []
    for name, check in checks:
        try:
            check(Measurement())
            ran.append(name)
        except Pending as p:
            it.log(f"SKIP measurement check {name}: {p}")
            skipped.append((name, str(p)))
    if skipped and ran:
        raise AssertionError(f"measurement checks {ran} ran but {[s[0] for s in skipped]} answered "
                             f"{it.ERROR_NOT_SUPPORTED}: {skipped} (a generic-404 / DPS node has a measurement "
                             f"source: NotSupported is wrong once the measurement methods exist)")
    if skipped:
        it.log(f"SKIPPED all {len(skipped)} measurement checks ({', '.join(s[0] for s in skipped)}): the daemon "
               f"answers {it.ERROR_NOT_SUPPORTED} (measurement methods not implemented yet); they run by "
               f"themselves once it does not")
    else:
        it.log(f"measurement checks passed: {', '.join(ran)}")


# --------------------------------------------------------------------------

def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    sock = os.path.join(ctx.tmp, "control")
    fleet_file = it.write_control_fleet(ctx)
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d = ctx.start_daemon("--config", fleet_file, "--control-socket", sock, "--bus", "none",
                             "--state-dir", "{state_dir}")
        booted = set()
        deadline = time.monotonic() + it.scaled(10)
        while booted != set(KEYS.values()) and time.monotonic() < deadline:
            m = it.wait_for(bus, lambda x: x.arbitration_id - 0x700 in KEYS.values() and bytes(x.data) == b"\0",
                            deadline - time.monotonic())
            if m is not None:
                booted.add(m.arbitration_id - 0x700)
        assert booted == set(KEYS.values()), f"boot-ups seen: {sorted(map(hex, booted))}"
        it.wait_for_path(sock, 5)
        st = os.stat(sock)
        assert oct(st.st_mode & 0o777) == oct(0o660), f"control socket mode {oct(st.st_mode)}"
        it.log(f"3 boot-ups seen; control socket {sock} mode {oct(st.st_mode & 0o777)}")

        with it.ControlClient.private(sock) as c:
            c.subscribe()
            fleet(c, sock)
            nmt_and_objects(c, bus)
            power_cycle(c, bus)
            add_remove(c, bus, ctx)
            errors(c)
            measurement(c, bus, sock)
            c.fleet("Unsubscribe")
            mark = c.mark()
            c.node("generic/1").call("Nmt", "s", "reset")
            it.expect(bus, it.is_bootup(G1), 3, "boot-up after Nmt reset")
            c.pump(0.3)
            assert not c.signals[mark:], f"signals after Unsubscribe: {c.signals[mark:]}"
            it.log("Nmt reset: boot-up on the wire; no signal after Unsubscribe")
            d.assert_alive()
        assert d.stop() == 0, "exit status after SIGTERM"
        assert not os.path.exists(sock), "the control socket is left behind after exit"


it.main(test)
