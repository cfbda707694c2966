"""pytest plugin: fleets of simulated sensors for a test, on a kernel CAN
interface or on a bus that needs no kernel CAN (docs/python.md).

    pytest --cansim-config bench.yaml [--cansim-interface can1] [--cansim-bus socketcand|IFACE]
           [--cansim-require] [--cansim-connect [SOCKET|system|user]] [--cansim-binary PATH]

or in pytest.ini / pyproject.toml (``cansim_config``, ``cansim_interface``,
``cansim_bus``, ``cansim_require``, ``cansim_binary``).

The bus: with ``--cansim-bus IFACE`` the fleet runs on that kernel CAN
interface; with ``--cansim-bus socketcand`` every interface of the fleet
becomes a kernel-free socketcand bus of the same name, served by the fleet's
own cansimd on a free loopback port; by default (auto) the configured
interface (vcan0) when it exists, else socketcand, and socketcand in every
pytest-xdist worker (workers on one interface would hear each other).

Fixtures: ``cansim`` (module: the fleet of the configuration, or of a
module's ``cansim_config`` override), ``cansim_bus`` (module: a python-can
bus on its interface), ``cansim_fleet`` (function: a factory, each call a
fresh fleet on its own bus), ``cansim_config``, ``cansim_interface``.

When a test that used them fails, the plugin writes the test's window of
each fleet's buses (candump -L), the decoded monitor lines and the event
timeline into the test's folder (its tmp_path) and attaches their paths to
the report: a "cansim evidence" section and user properties (JUnit XML).
"""

from __future__ import annotations

import importlib.util
import os
import re
import time
from dataclasses import dataclass
from typing import Any, Dict, Generator, Iterator, List, NamedTuple, NoReturn, Optional, Sequence, Tuple, Union

import pytest

import cansim as _cansim
from cansim._decode import Monitor, NodeView, pdo_mappings
from cansim._wire import write_candump
from cansim.events import Mark
from cansim.simulator import can_interface_exists

__all__ = ["can_interface_exists"]

_SLACK_S = 0.0005  # a frame stamped this much before a test's start still counts as in it


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("cansim", "cansimd simulated CANopen sensors")
    group.addoption("--cansim-config", metavar="PATH", default=None,
                    help="fleet file for the cansim fixture (ini: cansim_config)")
    group.addoption("--cansim-interface", metavar="IFACE", default=None,
                    help="CAN interface the fleet runs on, $INTERFACE in a fleet's text "
                         "(ini: cansim_interface; default vcan0)")
    group.addoption("--cansim-bus", metavar="socketcand|IFACE", default=None,
                    help="socketcand: every fleet on kernel-free socketcand buses; IFACE: on that kernel CAN "
                         "interface (ini: cansim_bus; default: the interface when it exists, else socketcand)")
    group.addoption("--cansim-require", action="store_true", default=None,
                    help="fail, instead of skipping, the tests whose fleet cannot run (ini: cansim_require)")
    group.addoption("--cansim-connect", metavar="SOCKET|system|user", nargs="?", const="", default=None,
                    help="the cansim fixture attaches to a running cansimd (its control socket, the system or "
                         "user bus; alone: cansimctl's default) instead of starting one")
    group.addoption("--cansim-binary", metavar="PATH", default=None,
                    help="cansimd to run (ini: cansim_binary; default $CANSIMD, else PATH)")
    parser.addini("cansim_config", "fleet file for the cansim fixture", default="")
    parser.addini("cansim_interface", "CAN interface the fleet runs on", default="vcan0")
    parser.addini("cansim_bus", "socketcand, or a kernel CAN interface (default: auto)", default="")
    parser.addini("cansim_require", "fail instead of skipping when a fleet cannot run", type="bool", default=False)
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


def _workers(config: Any) -> int:
    """pytest-xdist's worker count (in a worker, or what -n asks for in
    the controller); 1 without xdist."""
    workerinput = getattr(config, "workerinput", None)
    if workerinput:
        return int(workerinput.get("workercount", 1))
    n = getattr(config.option, "numprocesses", None)
    if not n:
        return 1
    return int(n) if str(n).isdigit() else 2  # "auto", "logical": several


class BusChoice(NamedTuple):
    """Where the plugin's fleets run: ``transport`` "socketcan" on the
    kernel interface ``interface``, or "socketcand" (each fleet's
    interfaces, ``interface`` among them, served by its own cansimd)."""

    transport: str
    interface: str
    why: str
    explicit: bool


def choose_bus(config: Any) -> BusChoice:
    """The bus of the options, as documented in docs/python.md."""
    bus = _option(config, "bus")
    given_interface = config.getoption("--cansim-interface")
    interface = _option(config, "interface") or "vcan0"
    if bus == "socketcand":
        return BusChoice("socketcand", interface, "--cansim-bus socketcand", True)
    if bus:
        if given_interface and given_interface != bus:
            raise pytest.UsageError(f"--cansim-bus {bus} and --cansim-interface {given_interface}: one interface")
        return BusChoice("socketcan", bus, f"--cansim-bus {bus}", True)
    if _workers(config) > 1:
        return BusChoice("socketcand", interface, "pytest-xdist: a kernel-free bus per fleet", False)
    if can_interface_exists(interface):
        return BusChoice("socketcan", interface, f"{interface} exists", False)
    return BusChoice("socketcand", interface, f"no CAN interface {interface}", False)


# ---------------------------------------------------------------- evidence

@dataclass
class _Window:
    """Where a test's share of a Simulator's frames and events begins."""

    frames: int = 0
    events: int = 0
    wall: float = 0.0


@dataclass
class _Tracked:
    sim: _cansim.Simulator
    label: str
    owner: Any  # the pytest node whose fixture made it (a module, or the test for cansim_fleet)
    start: _Window  # the window of the test that made it: from when the listeners began (every node booted)
    wire_error: Optional[str] = None


class _Session:
    """The plugin's state in one pytest process: the fleets alive, which
    test may see them, where each test's window begins."""

    def __init__(self, config: Any) -> None:
        self.config = config
        self.choice = choose_bus(config)
        self.require = bool(config.getoption("--cansim-require") or config.getini("cansim_require"))
        self.connect: Optional[str] = config.getoption("--cansim-connect")
        self.tracked: List[_Tracked] = []
        self.tmp_path_factory: Any = None

    def give_up(self, reason: str) -> NoReturn:
        """A fleet that cannot run: skipped, or failed with --cansim-require."""
        if self.require:
            pytest.fail(f"{reason} [--cansim-require]", pytrace=False)
        pytest.skip(reason)

    def track(self, sim: _cansim.Simulator, owner: Any, label: str) -> _Tracked:
        t = _Tracked(sim, label, owner, _Window(wall=time.time()))
        try:
            sim.capture()  # the listeners run from now on: the evidence has every frame
        except Exception as e:  # python-can missing, a bus not listening: no bus log, the rest stays
            t.wire_error = str(e)
        self.tracked.append(t)
        return t

    def untrack(self, sim: _cansim.Simulator) -> None:
        self.tracked = [t for t in self.tracked if t.sim is not sim]

    def visible(self, item: Any) -> List[_Tracked]:
        """The fleets a test used: those of its module's or its own fixtures."""
        chain = set(id(n) for n in item.listchain())
        uses_module = bool({"cansim", "cansim_bus"} & set(item.fixturenames))
        return [t for t in self.tracked if id(t.owner) in chain and (uses_module or t.owner is item)]

    # ---- hooks (registered as a plugin object)
    @pytest.hookimpl(hookwrapper=True)  # type: ignore[misc]
    def pytest_runtest_setup(self, item: Any) -> Iterator[None]:
        item.stash[_WINDOWS] = {id(t.sim): _window_now(t.sim) for t in self.tracked}
        yield

    @pytest.hookimpl(hookwrapper=True)  # type: ignore[misc]
    def pytest_runtest_makereport(self, item: Any, call: Any) -> Generator[None, Any, None]:
        outcome = yield
        report = outcome.get_result()
        if not report.failed or item.stash.get(_WRITTEN, False):
            return
        fleets = self.visible(item)
        if not fleets:
            return
        item.stash[_WRITTEN] = True
        try:
            folder = self.folder(item)
            written = write_evidence(folder, fleets, item.stash.get(_WINDOWS, {}))
        except Exception as e:  # evidence must never hide the failure itself
            report.sections.append(("cansim evidence", f"could not write the evidence: {e}"))
            return
        for name, path in written:
            item.user_properties.append((name, path))
            report.user_properties.append((name, path))
        report.sections.append(("cansim evidence", "\n".join(f"{name}: {path}" for name, path in written)))

    def pytest_report_header(self, config: Any) -> str:
        c = self.choice
        if self.connect is not None:
            return f"cansim: attached to a running cansimd ({self.connect or 'default address'})"
        where = "kernel-free socketcand buses" if c.transport == "socketcand" else f"CAN interface {c.interface}"
        return f"cansim: fleets on {where} ({c.why})"

    def folder(self, item: Any) -> str:
        tmp = item.funcargs.get("tmp_path") if hasattr(item, "funcargs") else None
        if tmp is not None:
            return str(tmp)
        factory = self.tmp_path_factory or item.config._tmp_path_factory
        return str(factory.mktemp(re.sub(r"[\W]", "_", item.name)[:30], numbered=True))


_WINDOWS = pytest.StashKey[Dict[int, _Window]]()
_WRITTEN = pytest.StashKey[bool]()
_SESSION = pytest.StashKey[_Session]()


def _window_now(sim: _cansim.Simulator) -> _Window:
    wire = sim._wire
    return _Window(wire.log.next_position if wire else 0, sim._log.next_position, time.time())


def _labels(states: Sequence[_cansim.NodeState]) -> Dict[str, str]:
    """What people call each node: its entry name, name/INDEX in a group."""
    counts: Dict[str, int] = {}
    for s in states:
        counts[f"{s.interface}/{s.name}"] = counts.get(f"{s.interface}/{s.name}", 0) + 1
    return {s.key: s.name if counts[f"{s.interface}/{s.name}"] == 1 else f"{s.name}/{s.index}" for s in states}


def _node_views(sim: _cansim.Simulator, limit: int = 512) -> List[NodeView]:
    states = sim.states()[:limit]
    labels = _labels(states)
    views = []
    for s in states:
        node = sim.node(s.key)
        codes = {int(c): str(m) for c, m in node._call("ListEmcyCodes")[0]}
        views.append(NodeView(s.key, labels[s.key], s.interface, s.node_id,
                              pdo_mappings(node._call("GetPdoMapping")[0]), codes))
    return views


def _event_line(e: _cansim.Event) -> str:
    wall = e.wall_time or 0.0
    clock = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(wall)) + f".{int(round((wall % 1) * 1e6)) % 1000000:06d}"
    return f"{clock} ({wall:.6f}) {e}"


def write_evidence(folder: str, fleets: Sequence[_Tracked], windows: Dict[int, _Window]) -> List[Tuple[str, str]]:
    """Writes each fleet's bus log, monitor lines and event timeline for the
    test's window into ``folder``; returns (property name, path) pairs."""
    out: List[Tuple[str, str]] = []
    for i, t in enumerate(fleets):
        prefix = "cansim" if len(fleets) == 1 else f"cansim-{i + 1}"
        suffix = "" if len(fleets) == 1 else f"_{i + 1}"
        window = windows.get(id(t.sim)) or t.start  # made in this test: from its start
        frames = []
        if t.sim._wire is not None:
            frames = [f for f in t.sim._wire.log.window(window.frames) if f.timestamp >= window.wall - _SLACK_S]
        bus_log = os.path.join(folder, f"{prefix}-bus.log")
        write_candump(bus_log, frames)
        out.append((f"cansim_bus_log{suffix}", bus_log))
        notes = [f"# {t.label}: {len(frames)} frame(s) from {window.wall:.6f}"]
        if t.wire_error:
            notes.append(f"# no frames: {t.wire_error}")
        if t.sim._wire is not None:
            notes += [f"# {e}" for e in t.sim._wire.errors()]
        try:
            monitor = Monitor(_node_views(t.sim))
        except Exception as e:  # cansimd died: the frames undecoded
            notes.append(f"# frames not decoded by their nodes: {e}")
            monitor = Monitor([])
        monitor_path = os.path.join(folder, f"{prefix}-monitor.txt")
        with open(monitor_path, "w", encoding="utf-8") as f:
            f.write("\n".join(notes + [monitor.line(frame) for frame in frames]) + "\n")
        out.append((f"cansim_monitor{suffix}", monitor_path))
        events = list(t.sim.events(since=Mark(window.events)))
        events_path = os.path.join(folder, f"{prefix}-events.txt")
        with open(events_path, "w", encoding="utf-8") as f:
            epoch = t.sim.epoch
            f.write(f"# {t.label}: {len(events)} event(s); simulated time 0 = "
                    f"{epoch:.6f} (Unix time)\n" if epoch is not None else f"# {t.label}: {len(events)} event(s)\n")
            f.write("".join(_event_line(e) + "\n" for e in events))
        out.append((f"cansim_events{suffix}", events_path))
    return out


# ---------------------------------------------------------------- fixtures

def pytest_configure(config: Any) -> None:
    # python-can 4.1 asks importlib.metadata the old way at each Bus(): noise in every bench's summary
    config.addinivalue_line("filterwarnings", "ignore:SelectableGroups dict interface:DeprecationWarning")
    session = _Session(config)
    _check_xdist(session)
    config.stash[_SESSION] = session
    config.pluginmanager.register(session, "cansim-session")


def _check_xdist(session: _Session) -> None:
    """One fleet, or one kernel interface, for several pytest-xdist workers:
    a usage error before any worker starts (they would act on the same
    nodes, or hear each other's frames)."""
    if _workers(session.config) <= 1:
        return
    if session.connect is not None:
        raise pytest.UsageError("--cansim-connect under pytest-xdist: the workers would share one fleet")
    c = session.choice
    if c.transport == "socketcan" and c.explicit:
        raise pytest.UsageError(f"--cansim-bus {c.interface} under pytest-xdist: the workers' fleets would share "
                                f"{c.interface} and hear each other's frames (run without -n, or with "
                                f"--cansim-bus socketcand)")


def _session(request: Any) -> _Session:
    return request.config.stash[_SESSION]  # type: ignore[no-any-return]


def _start(session: _Session, request: Any, config_or_path: Any, interface: str, **kwargs: Any) -> _cansim.Simulator:
    choice = session.choice
    if choice.transport == "socketcan" and not can_interface_exists(interface):
        session.give_up(f"cansim: no CAN interface {interface} "
                        f"(ip link add {interface} type vcan && ip link set {interface} up, "
                        f"or --cansim-bus socketcand)")
    binary = _option(request.config, "binary")
    return _cansim.start(config_or_path, interface=interface, binary=binary, transport=choice.transport, **kwargs)


@pytest.fixture(scope="module")
def cansim_config(request: Any) -> Optional[str]:
    """The fleet the ``cansim`` fixture starts: --cansim-config, the ini
    option cansim_config, or what a test module's override returns."""
    return _option(request.config, "config")


@pytest.fixture(scope="module")
def cansim_interface(request: Any) -> str:
    """The interface the fleet's ``$INTERFACE`` names and ``cansim_bus``
    is on (a socketcand bus of that name on the kernel-free bus)."""
    return _session(request).choice.interface


@pytest.fixture(scope="module")
def cansim(cansim_config: Optional[str], cansim_interface: str, request: Any,
           tmp_path_factory: Any) -> Iterator[_cansim.Simulator]:
    """A running cansimd with the configured fleet, every node booted (one
    per test module); with --cansim-connect, the running one."""
    session = _session(request)
    session.tmp_path_factory = tmp_path_factory
    if session.connect is not None:
        where = session.connect or None
        bus = where if where in ("system", "user") else None
        try:
            sim = _cansim.connect(None if bus else where, bus=bus)
        except _cansim.Error as e:
            session.give_up(f"cansim: {e}")
        label = f"cansimd at {sim.control_socket or bus or 'the default address'}"
    else:
        if not cansim_config:
            session.give_up("cansim: no fleet configured (--cansim-config PATH, ini option cansim_config, "
                            "or a cansim_config fixture in the test module)")
        sim = _start(session, request, cansim_config, cansim_interface)
        label = f"the fleet of {request.node.name}"
    session.track(sim, request.node, label)
    try:
        with sim:
            yield sim
    finally:
        session.untrack(sim)


@pytest.fixture(scope="module")
def cansim_bus(cansim: _cansim.Simulator, cansim_interface: str, request: Any) -> Iterator[Any]:
    """A python-can bus on the fleet's interface (python3-can): SocketCAN,
    or the socketcand client on the kernel-free bus."""
    if importlib.util.find_spec("can") is None:
        _session(request).give_up("cansim_bus needs python-can (python3-can)")
    names = [b.name for b in cansim.buses()]
    name = cansim_interface if cansim_interface in names or len(names) != 1 else names[0]
    bus = cansim.open_bus(name)
    try:
        yield bus
    finally:
        bus.shutdown()


class FleetFactory:
    """``cansim_fleet(yaml_or_path, ...)``: a fresh fleet for this test, on
    its own bus (its own cansimd; stopped after the test)."""

    def __init__(self, session: _Session, request: Any) -> None:
        self._session = session
        self._request = request
        self.fleets: List[_cansim.Simulator] = []

    def __call__(self, yaml_or_path: Union[str, "os.PathLike[str]"], *, interface: Optional[str] = None,
                 args: Sequence[str] = (), timeout: float = 10.0) -> _cansim.Simulator:
        """Starts the fleet (a file, or YAML text whose ``$INTERFACE`` is
        ``interface``, default the plugin's) and returns its Simulator, every
        node booted. ``args``: more cansimd options (``--seed 7`` ...)."""
        iface = interface or self._session.choice.interface
        sim = _start(self._session, self._request, yaml_or_path, iface, args=args, timeout=timeout)
        self.fleets.append(sim)
        self._session.track(sim, self._request.node, f"fleet {len(self.fleets)} of {self._request.node.name}")
        return sim

    def close(self) -> None:
        errors = []
        for sim in reversed(self.fleets):
            self._session.untrack(sim)
            try:
                sim.close()
            except _cansim.Error as e:
                errors.append(str(e))
        if errors:
            raise _cansim.Error("; ".join(errors))


@pytest.fixture
def cansim_fleet(request: Any, tmp_path_factory: Any) -> Iterator[FleetFactory]:
    """A factory: each call starts a fresh fleet on its own bus
    (kernel-free unless --cansim-bus names an interface), stopped after the
    test; several per test (gateways, redundant buses)."""
    session = _session(request)
    session.tmp_path_factory = tmp_path_factory
    factory = FleetFactory(session, request)
    try:
        yield factory
    finally:
        factory.close()
