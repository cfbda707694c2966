"""pytest plugin: a ``cansim`` fixture with a running fleet.

    pytest --cansim-config bench.yaml [--cansim-interface can1] [--cansim-binary PATH]

or in pytest.ini / pyproject.toml::

    [pytest]
    cansim_config = bench.yaml
    cansim_interface = vcan0

A test module sets its own fleet by overriding the ``cansim_config``
fixture (a file path or YAML text; ``$INTERFACE`` in the text stands for the
interface given)::

    @pytest.fixture(scope="module")
    def cansim_config():
        return "nodes: [{profile: generic-404, interface: $INTERFACE, node_id: 0x10, count: 20, name: pt}]"

The ``cansim`` fixture (module scope) starts cansimd with that fleet and
yields the :class:`cansim.Simulator`; the module's tests are skipped, with
the reason, when no fleet is configured or the CAN interface is missing.
``cansim_bus`` is a python-can bus on the interface (module scope).
"""

from __future__ import annotations

import os
from typing import Any, Iterator, Optional

import pytest

import cansim as _cansim

ARPHRD_CAN = 280


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("cansim", "cansimd simulated CANopen sensors")
    group.addoption("--cansim-config", metavar="PATH", default=None,
                    help="fleet file for the cansim fixture (ini: cansim_config)")
    group.addoption("--cansim-interface", metavar="IFACE", default=None,
                    help="CAN interface the fleet runs on (ini: cansim_interface; default vcan0)")
    group.addoption("--cansim-binary", metavar="PATH", default=None,
                    help="cansimd to run (ini: cansim_binary; default $CANSIMD, else PATH)")
    parser.addini("cansim_config", "fleet file for the cansim fixture", default="")
    parser.addini("cansim_interface", "CAN interface the fleet runs on", default="vcan0")
    parser.addini("cansim_binary", "cansimd to run", default="")


def _option(config: Any, name: str) -> Optional[str]:
    value = config.getoption(f"--cansim-{name}")
    if value:
        return str(value)
    value = config.getini(f"cansim_{name}")
    if not value:
        return None
    if name in ("config", "binary") and not os.path.isabs(value) and config.inipath is not None:
        candidate = os.path.join(os.path.dirname(str(config.inipath)), value)
        if os.path.exists(candidate):
            return candidate
    return str(value)


def can_interface_exists(name: str) -> bool:
    """True when ``name`` is a CAN network interface (up or not)."""
    try:
        with open(f"/sys/class/net/{name}/type") as f:
            return int(f.read().strip()) == ARPHRD_CAN
    except (OSError, ValueError):
        return False


@pytest.fixture(scope="module")
def cansim_config(request: Any) -> Optional[str]:
    """The fleet the ``cansim`` fixture starts: --cansim-config, the ini
    option cansim_config, or what a test module's override returns."""
    return _option(request.config, "config")


@pytest.fixture(scope="module")
def cansim_interface(request: Any) -> str:
    return _option(request.config, "interface") or "vcan0"


@pytest.fixture(scope="module")
def cansim(cansim_config: Optional[str], cansim_interface: str, request: Any) -> Iterator[_cansim.Simulator]:
    """A running cansimd with the configured fleet, every node booted."""
    if not cansim_config:
        pytest.skip("cansim: no fleet configured (--cansim-config PATH, ini option cansim_config, "
                    "or a cansim_config fixture in the test module)")
    if not can_interface_exists(cansim_interface):
        pytest.skip(f"cansim: no CAN interface {cansim_interface} "
                    f"(ip link add {cansim_interface} type vcan && ip link set {cansim_interface} up)")
    binary = _option(request.config, "binary")
    with _cansim.start(cansim_config, interface=cansim_interface, binary=binary) as sim:
        yield sim


@pytest.fixture(scope="module")
def cansim_bus(cansim_interface: str) -> Iterator[Any]:
    """A python-can bus on the fleet's interface (python3-can)."""
    can = pytest.importorskip("can", reason="cansim_bus needs python-can (python3-can)")
    if not can_interface_exists(cansim_interface):
        pytest.skip(f"cansim: no CAN interface {cansim_interface}")
    with can.Bus(interface="socketcan", channel=cansim_interface) as bus:
        yield bus
