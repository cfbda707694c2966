"""The client's edges: bad arguments raise ValueError naming the argument
before anything is sent, and every blocking step honours the timeout
(sending included), against a real cansimd on this host.

    CANSIMD=build/cansimd python3 -m pytest -q python/tests/test_edges.py
"""

import math
import os
import signal
import time

import pytest

import cansim

PROFILES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "profiles")


@pytest.fixture(scope="module")
def sim():
    with cansim.start(profile=os.path.join(PROFILES, "generic-404.yaml"), interface="vcan0", node_id=0x10) as s:
        yield s


@pytest.fixture
def node(sim):
    return sim.nodes()[0]


def raises_at_once(argument, call):
    """call() raises a ValueError naming ``argument`` within 0.5 s (nothing waited for)."""
    t0 = time.monotonic()
    with pytest.raises(ValueError, match=argument):
        call()
    assert time.monotonic() - t0 < 0.5


@pytest.mark.parametrize("timeout", [math.nan, math.inf, -1.0, "2", None])
def test_a_timeout_that_is_no_duration_is_refused(sim, node, timeout):
    raises_at_once("timeout", lambda: sim.wait_for("NmtStateChanged", timeout=timeout))
    raises_at_once("timeout", lambda: node.wait_for("NmtStateChanged", timeout=timeout))
    raises_at_once("timeout", lambda: node.pressure.wait_for(1.0, timeout=timeout))


def test_a_call_timeout_that_is_no_duration_is_refused(sim):
    raises_at_once("timeout", lambda: sim._conn.method(cansim._bus.ROOT_PATH, cansim._bus.FLEET_IFACE,
                                                       "ListFaults", timeout=math.nan))


@pytest.mark.parametrize("index, sub, argument", [
    (0x10000, 0, "index"), (-1, 0, "index"), ("0x1ffff", 0, "index"), ("zz", 0, "index"),
    (0x1018, 256, "sub"), (0x1018, -1, "sub"), ("0x1018:300", None, "sub"), (0x1018, 1.5, "sub"),
])
def test_an_object_address_out_of_range_is_refused(node, index, sub, argument):
    raises_at_once(argument, lambda: node.read(index, sub))
    raises_at_once(argument, lambda: node.write(index, sub, 1))


@pytest.mark.parametrize("value", [1 << 64, -(1 << 63) - 1])
def test_a_value_no_integer_type_holds_is_refused(node, value):
    raises_at_once("value", lambda: node.write(0x1017, 0, value))


def test_the_connection_is_fine_after_a_refused_argument(node):
    with pytest.raises(ValueError):
        node.write(0x1017, 0, 1 << 70)
    with pytest.raises(ValueError):
        node.store(300)
    assert isinstance(node.read(0x1017, 0), int)


@pytest.mark.parametrize("call, argument", [
    (lambda n: n.pressure.wait_for(math.nan), "value"),
    (lambda n: n.pressure.wait_for(1.0, tolerance=math.inf), "tolerance"),
    (lambda n: n.store(256), "sub"),
    (lambda n: n.restore(-1), "sub"),
])
def test_values_are_checked_before_the_call(node, call, argument):
    raises_at_once(argument, lambda: call(node))


# A value its D-Bus type carries (inf is a double) is the daemon's to judge.
def test_what_the_type_carries_is_the_daemons_to_refuse(node):
    with pytest.raises(cansim.Refused, match="io.cansim.Error.OutOfRange"):
        node.pressure.set(math.inf, "bar")


def test_start_checks_its_timeout():
    raises_at_once("timeout", lambda: cansim.start(profile="generic-404", timeout=math.nan))


# A 4 MB call to a cansimd that reads nothing (SIGSTOP): the socket fills and
# sendall blocked 45 s past a 30 s timeout. Now the timeout covers sending:
# Timeout within it, the connection closed (half a message went out).
def test_sending_honours_the_timeout(sim):
    os.kill(sim.pid, signal.SIGSTOP)
    try:
        t0 = time.monotonic()
        with pytest.raises(cansim.Timeout, match="took no AddNodes call within 1.0 s"):
            sim._conn.method(cansim._bus.ROOT_PATH, cansim._bus.FLEET_IFACE, "AddNodes", "s",
                             ("x" * (4 << 20),), timeout=1.0)
        elapsed = time.monotonic() - t0
    finally:
        os.kill(sim.pid, signal.SIGCONT)
    assert elapsed < 1.5, f"{elapsed:.2f} s"
