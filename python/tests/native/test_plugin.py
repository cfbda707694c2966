"""The pytest plugin, run by pytester: which bus a fleet gets, skips and
--cansim-require failures with their reason, the fleet from the command
line, the ini file or a module's override, --cansim-connect, the
cansim_fleet factory, sim.reset() between tests, pytest-xdist workers on
buses of their own, and the evidence a failing test leaves.

This host has no kernel CAN: the fleets run on the kernel-free socketcand
bus, python3-can's socketcand client is the master. Where a test needs the
plugin to believe in a kernel interface, the interface check is replaced
(the daemon then runs that fleet off the bus)."""

import os
import time
import xml.etree.ElementTree as ET

import can
import pytest

import cansim
import cansim.pytest_plugin

pytest_plugins = ["pytester"]

PROFILES = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "..", "profiles"))

USES_FIXTURE = """
def test_fleet(cansim):
    assert [n.key for n in cansim.nodes()] == EXPECTED
"""


def run(pytester, source, *args, expected=()):
    pytester.makepyfile(f"EXPECTED = {list(expected)!r}\n" + source)
    return pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "-rs", *args)


def fleet_file(tmp_path, entry="node_id: 0x10, count: 2, name: pt", interface="vcan7"):
    path = tmp_path / "fleet.yaml"
    path.write_text(f"nodes:\n  - {{profile: {PROFILES}/generic-404.yaml, interface: {interface}, {entry}}}\n")
    return path


@pytest.fixture
def has_can(monkeypatch):
    monkeypatch.setattr(cansim.pytest_plugin, "can_interface_exists", lambda name: name == "vcan7")


# ---------------------------------------------------------------- which bus

def test_skipped_without_a_fleet(pytester):
    result = run(pytester, USES_FIXTURE)
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*cansim: no fleet configured (--cansim-config PATH*"])


def test_without_the_interface_the_fleet_runs_on_the_kernel_free_bus(pytester, tmp_path):
    fleet = fleet_file(tmp_path, interface="vcan9")
    result = run(pytester, USES_FIXTURE + '''
def test_master(cansim, cansim_bus, cansim_interface):
    import can
    assert cansim_interface == "vcan9"
    assert [(b.name, b.transport) for b in cansim.buses()] == [("vcan9", "socketcand")]
    assert type(cansim_bus).__name__ == "SocketCanDaemonBus"  # python-can's socketcand client
    mark = cansim.mark()
    cansim_bus.send(can.Message(arbitration_id=0, data=[1, 0x11], is_extended_id=False))
    cansim.node(0x11).wait_for("NmtStateChanged", new="operational", since=mark)
''', f"--cansim-config={fleet}", "--cansim-interface=vcan9", expected=["vcan9/pt/0", "vcan9/pt/1"])
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["cansim: fleets on kernel-free socketcand buses (no CAN interface vcan9)"])


def test_an_explicit_interface_that_is_missing_skips(pytester, tmp_path):
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet_file(tmp_path)}", "--cansim-bus=vcan9")
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*cansim: no CAN interface vcan9 (ip link add vcan9 type vcan*--cansim-bus socketcand)"])


def test_require_fails_what_would_be_skipped(pytester, tmp_path):
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet_file(tmp_path)}", "--cansim-bus=vcan9",
                 "--cansim-require")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*cansim: no CAN interface vcan9*--cansim-require*"])
    assert result.ret == pytest.ExitCode.TESTS_FAILED


def test_require_from_the_ini_file(pytester):
    pytester.makeini("[pytest]\ncansim_require = true\n")
    result = run(pytester, USES_FIXTURE)
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*cansim: no fleet configured*--cansim-require*"])


def test_the_interface_when_it_exists(pytester, has_can, tmp_path):
    result = run(pytester, USES_FIXTURE + '''
def test_transport(cansim):
    assert [(b.name, b.transport) for b in cansim.buses()] == [("vcan7", "socketcan")]
''', f"--cansim-config={fleet_file(tmp_path)}", "--cansim-interface=vcan7", expected=["vcan7/pt/0", "vcan7/pt/1"])
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["cansim: fleets on CAN interface vcan7 (vcan7 exists)"])


def test_socketcand_chosen_where_the_interface_exists(pytester, has_can, tmp_path):
    result = run(pytester, '''
def test_transport(cansim):
    assert [(b.name, b.transport) for b in cansim.buses()] == [("vcan7", "socketcand")]
''', f"--cansim-config={fleet_file(tmp_path)}", "--cansim-interface=vcan7", "--cansim-bus=socketcand")
    result.assert_outcomes(passed=1)


def test_bus_and_interface_must_agree(pytester, tmp_path):
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet_file(tmp_path)}", "--cansim-bus=can1",
                 "--cansim-interface=can0")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--cansim-bus can1 and --cansim-interface can0: one interface*"])


def test_one_fleet_or_interface_for_all_xdist_workers_is_a_usage_error(pytester):
    """Told at once, as a usage error (exit 4), before any worker starts:
    the workers would act on one fleet, or hear each other on one interface."""
    pytester.makepyfile(USES_FIXTURE)
    for args, why in ((["--cansim-connect=/nonexistent/control"], "--cansim-connect under pytest-xdist*"),
                      (["--cansim-bus=vcan9"], "--cansim-bus vcan9 under pytest-xdist*")):
        result = pytester.runpytest_subprocess("-p", "cansim.pytest_plugin", "-p", "no:cacheprovider", "-n", "2", *args)
        assert result.ret == pytest.ExitCode.USAGE_ERROR, (args, result.ret)
        result.stderr.fnmatch_lines([f"*{why}"])


# ---------------------------------------------------------------- the fleet

def test_fleet_from_the_ini_file(pytester, has_can):
    pytester.makeini("[pytest]\ncansim_config = bench.yaml\ncansim_interface = vcan7\n")
    (pytester.path / "bench.yaml").write_text(
        f"nodes: [{{profile: {PROFILES}/dps.yaml, interface: vcan7, node_id: 5, name: dps}}]\n")
    result = run(pytester, USES_FIXTURE, expected=["vcan7/dps/0"])
    result.assert_outcomes(passed=1)


def with_own_fleet(pytester, entry, tests, *args):
    """Runs a test module whose cansim_config fixture returns `entry` as a fleet."""
    pytester.makepyfile(f'''
import pytest

@pytest.fixture(scope="module")
def cansim_config():
    return "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, {entry}}}]"
''' + tests)
    return pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "--cansim-interface=bench", *args)


def test_a_module_sets_its_own_fleet(pytester):
    result = with_own_fleet(pytester, "node_id: 0x20, count: 3, name: s", '''
def test_fleet(cansim, cansim_interface):
    assert cansim_interface == "bench"
    assert [n.node_id for n in cansim.nodes()] == [0x20, 0x21, 0x22]
    assert cansim.node("s/2").interface == "bench"
''')
    result.assert_outcomes(passed=1)


def test_one_daemon_per_module_and_reset_between_tests(pytester):
    result = with_own_fleet(pytester, "node_id: 0x20, name: s", '''
def test_first(cansim):
    cansim.node("s").write(0x1017, 0, 777)
    cansim.node("s").store()

def test_second(cansim):
    assert cansim.node("s").read(0x1017) == 777  # the module's daemon
    cansim.reset()

def test_third(cansim):
    assert cansim.node("s").read(0x1017) == 1000  # power-on as configured: nothing stored
''')
    result.assert_outcomes(passed=3)


def test_a_bad_fleet_is_an_error_naming_its_place(pytester, tmp_path):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text("nodes:\n  - {profile: generic-404, interface: vcan7, node_id: 0x10, colour: red}\n")
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet}")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*fleet.yaml:2:*colour*"])


def test_connect_attaches_to_a_running_daemon(pytester, tmp_path):
    with cansim.start(fleet_file(tmp_path), transport="socketcand") as running:
        running.node("pt/1").nmt("start")
        result = run(pytester, '''
def test_attached(cansim, cansim_bus):
    assert cansim.node("pt/1").nmt_state == "operational"
    assert cansim_bus.recv(2) is not None  # its bus
''', f"--cansim-connect={running.control_socket}")
        result.assert_outcomes(passed=1)
        result.stdout.fnmatch_lines([f"cansim: attached to a running cansimd ({running.control_socket})"])
        assert running.node("pt/1").nmt_state == "operational"  # still running, untouched


def test_cansim_fleet_gives_each_fleet_its_own_bus(pytester):
    result = run(pytester, f'''
import can

FLEET = "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, name: pt}}]"

def test_two_fleets(cansim_fleet):
    a, b = cansim_fleet(FLEET), cansim_fleet(FLEET, interface="redundant")
    assert [n.key for n in a.nodes()] == ["bench/pt/0"] and [n.key for n in b.nodes()] == ["redundant/pt/0"]
    assert a.buses()[0].port != b.buses()[0].port
    with a.capture() as on_a, b.capture() as on_b, a.open_bus() as master:
        master.send(can.Message(arbitration_id=0, data=[1, 0x10], is_extended_id=False))
        a.node(0x10).wait_for("NmtStateChanged", new="operational", since=on_a)
        assert on_a.wait_for(can_id=0x190).channel == "bench"
    assert b.node(0x10).nmt_state == "pre-operational"
    assert not [m for m in on_b.frames if m.arbitration_id in (0x000, 0x190)]
''', "--cansim-interface=bench")
    result.assert_outcomes(passed=1)


def test_xdist_workers_never_hear_each_other(pytester, tmp_path, monkeypatch):
    """Four tests on two workers, each master sending a frame that names its
    worker: every capture holds its own worker's frames only. And, whether
    or not the workers' tests overlapped in time, each worker had a bus of
    its own (a kernel-free bus, its own port)."""
    buses = tmp_path / "buses.txt"
    monkeypatch.setenv("CANSIM_TEST_BUSES", str(buses))
    pytester.makepyfile(f'''
import os
import time
import can
import pytest

@pytest.fixture(scope="module")
def cansim_config():
    return "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, name: pt}}]"

@pytest.mark.parametrize("n", range(4))
def test_private_bus(cansim, cansim_bus, n):
    me = int(os.environ["PYTEST_XDIST_WORKER"][2:])
    (bus,) = cansim.buses()
    with open(os.environ["CANSIM_TEST_BUSES"], "a") as f:
        f.write(f"{{me}} {{bus.transport}} {{bus.port}}\\n")
    cansim.node("pt").nmt("start")
    with cansim.capture() as wire:
        for i in range(20):  # over half a second, while the other worker's tests run
            cansim_bus.send(can.Message(arbitration_id=0x555, data=[me, n, i], is_extended_id=False))
            time.sleep(0.025)
        wire.wait_for(can_id=0x555, where=lambda m: m.data[1:] == bytes([n, 19]), timeout=3)
        wire.wait_for(can_id=0x190, timeout=3)  # the nodes' frames are there too
    markers = [m for m in wire.frames if m.arbitration_id == 0x555]
    assert len(markers) == 20 and {{m.data[0] for m in markers}} == {{me}}
''')
    result = pytester.runpytest_subprocess("-p", "cansim.pytest_plugin", "-n", "2", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=4)
    seen = {tuple(line.split()) for line in buses.read_text().splitlines()}
    assert {transport for _, transport, _ in seen} == {"socketcand"}, seen
    assert len({worker for worker, _, _ in seen}) == 2 and len({port for _, _, port in seen}) == 2, seen


# ---------------------------------------------------------------- evidence

FAILING = f'''
import can
import pytest

@pytest.fixture(scope="module")
def cansim_config():
    return "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, name: pt}}]"

def test_passes(cansim, cansim_bus):
    cansim.node("pt").nmt("start")  # before the failing test's window: not in its evidence
    cansim_bus.send(can.Message(arbitration_id=0x123, data=[1], is_extended_id=False))
    cansim.capture().wait_for(can_id=0x190)

def test_fails(cansim, cansim_bus):
    pt = cansim.node("pt")
    pt.nmt("stop")
    pt.wait_for("NmtStateChanged", new="stopped")
    cansim_bus.send(can.Message(arbitration_id=0x610, data=[0x40, 0x17, 0x10, 0, 0, 0, 0, 0], is_extended_id=False))
    pt.power_cycle(off=0)
    pt.wait_for("BootUp")
    assert pt.nmt_state == "operational", "the deliberate failure"
'''


def test_a_failing_test_leaves_its_bus_log_monitor_and_timeline(pytester, tmp_path):
    """A real failing bench in a subprocess pytest, JUnit XML included: the
    files are where the report says, in the test's folder, and hold the
    test's window of the bus only."""
    pytester.makepyfile(FAILING)
    junit = tmp_path / "junit.xml"
    result = pytester.runpytest_subprocess("-p", "cansim.pytest_plugin", "-p", "no:cacheprovider",
                                           f"--basetemp={tmp_path / 'base'}", f"--junitxml={junit}")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*- cansim evidence -*", "cansim_bus_log: *cansim-bus.log",
                                 "cansim_monitor: *cansim-monitor.txt", "cansim_events: *cansim-events.txt"])
    (case,) = [c for c in ET.parse(junit).getroot().iter("testcase") if c.get("name") == "test_fails"]
    props = {p.get("name"): p.get("value") for p in case.iter("property")}
    assert set(props) == {"cansim_bus_log", "cansim_monitor", "cansim_events"}
    folder = os.path.dirname(props["cansim_bus_log"])
    assert os.path.basename(folder).startswith("test_fails") and str(tmp_path / "base") in folder

    frames = list(can.LogReader(props["cansim_bus_log"]))  # candump -L, as python-can reads it
    ids = [m.arbitration_id for m in frames]
    assert 0x610 in ids and 0x710 in ids and 0x123 not in ids, ids  # its SDO, the boot-up; not the earlier test's
    assert all(not m.is_extended_id for m in frames) and frames == sorted(frames, key=lambda m: m.timestamp)
    monitor = open(props["cansim_monitor"]).read()
    assert " 610 pt SDO upload request 0x1017:00" in monitor and " 710 pt boot-up" in monitor, monitor
    events = open(props["cansim_events"]).read().splitlines()
    assert any("vcan0/pt/0 NmtStateChanged(old='operational', new='stopped')" in e for e in events), events
    assert any("BootUp" in e for e in events)
    assert not any("new='operational'" in e for e in events), "the earlier test's start is not in the window"


def test_the_first_test_of_a_fleet_has_its_window_from_the_fleets_start(pytester, tmp_path):
    """The fleet starts in the failing test's setup: its evidence is from
    when the plugin began to listen (every node booted), and says when."""
    pytester.makepyfile(f'''
import pytest

@pytest.fixture(scope="module")
def cansim_config():
    return "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, node_id: 0x10, name: pt}}]"

def test_fails_first(cansim, cansim_bus):
    assert False, "the deliberate failure"
''')
    result = pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", f"--basetemp={tmp_path / 'base'}")
    result.assert_outcomes(failed=1)
    (path,) = [line.split(": ", 1)[1] for line in result.outlines if line.startswith("cansim_monitor: ")]
    header = open(path).readline()
    start = float(header.split(" from ")[1].split()[0])
    assert time.time() - 60 < start < time.time(), header  # a wall-clock time, not 0.000000


def test_options_in_help(pytester):
    result = pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "--help")
    result.stdout.fnmatch_lines(["*--cansim-config=PATH*", "*--cansim-interface=IFACE*",
                                 "*--cansim-bus=socketcand|IFACE*", "*--cansim-require*",
                                 "*--cansim-connect=?SOCKET|system|user?*", "*--cansim-binary=PATH*"])
