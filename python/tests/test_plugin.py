"""The pytest plugin, run by pytester in this process: skips with a reason,
the fixture's fleet from the command line, the ini file or a module's
override. This host has no CAN interface, so the interface check is
replaced where a test needs the fleet to start."""

import os

import pytest

import cansim.pytest_plugin

pytest_plugins = ["pytester"]

PROFILES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "profiles")

USES_FIXTURE = """
def test_fleet(cansim):
    assert [n.key for n in cansim.nodes()] == EXPECTED
"""


def run(pytester, source, *args, expected=()):
    pytester.makepyfile(f"EXPECTED = {list(expected)!r}\n" + source)
    return pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "-rs", *args)


@pytest.fixture
def has_can(monkeypatch):
    monkeypatch.setattr(cansim.pytest_plugin, "can_interface_exists", lambda name: name == "vcan7")


def test_skipped_without_a_fleet(pytester):
    result = run(pytester, USES_FIXTURE)
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*cansim: no fleet configured (--cansim-config PATH*"])


def test_skipped_without_the_interface(pytester, tmp_path):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text("nodes: []\n")
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet}", "--cansim-interface=vcan9")
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*cansim: no CAN interface vcan9 (ip link add vcan9 type vcan*"])


def test_fleet_from_the_command_line(pytester, has_can, tmp_path):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text("nodes:\n"
                     f"  - {{profile: {PROFILES}/generic-404.yaml, interface: vcan7, node_id: 0x10, count: 2, name: pt}}\n")
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet}", "--cansim-interface=vcan7",
                 expected=["vcan7/pt/0", "vcan7/pt/1"])
    result.assert_outcomes(passed=1)


def test_fleet_from_the_ini_file(pytester, has_can):
    pytester.makeini("[pytest]\ncansim_config = bench.yaml\ncansim_interface = vcan7\n")
    (pytester.path / "bench.yaml").write_text(
        f"nodes: [{{profile: {PROFILES}/dps.yaml, interface: vcan7, node_id: 5, name: dps}}]\n")
    result = run(pytester, USES_FIXTURE, expected=["vcan7/dps/0"])
    result.assert_outcomes(passed=1)


def with_own_fleet(pytester, entry, tests):
    """Runs a test module whose cansim_config fixture returns `entry` as a fleet."""
    pytester.makepyfile(f'''
import pytest

@pytest.fixture(scope="module")
def cansim_config():
    return "nodes: [{{profile: {PROFILES}/generic-404.yaml, interface: $INTERFACE, {entry}}}]"
''' + tests)
    return pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "--cansim-interface=vcan7")


def test_a_module_sets_its_own_fleet(pytester, has_can):
    result = with_own_fleet(pytester, "node_id: 0x20, count: 3, name: s", '''
def test_fleet(cansim, cansim_interface):
    assert cansim_interface == "vcan7"
    assert [n.node_id for n in cansim.nodes()] == [0x20, 0x21, 0x22]
    assert cansim.node("s/2").interface == "vcan7"
''')
    result.assert_outcomes(passed=1)


def test_one_daemon_per_module(pytester, has_can):
    result = with_own_fleet(pytester, "node_id: 0x20, name: s", '''
def test_first(cansim):
    cansim.node("s").write(0x1017, 0, 777)

def test_second(cansim):
    assert cansim.node("s").read(0x1017) == 777
''')
    result.assert_outcomes(passed=2)


def test_a_bad_fleet_is_an_error_naming_its_place(pytester, has_can, tmp_path):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text("nodes:\n  - {profile: generic-404, interface: vcan7, node_id: 0x10, colour: red}\n")
    result = run(pytester, USES_FIXTURE, f"--cansim-config={fleet}", "--cansim-interface=vcan7")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*fleet.yaml:2:*colour*"])


def test_options_in_help(pytester):
    result = pytester.runpytest_inprocess("-p", "cansim.pytest_plugin", "--help")
    result.stdout.fnmatch_lines(["*--cansim-config=PATH*", "*--cansim-interface=IFACE*", "*--cansim-binary=PATH*"])
