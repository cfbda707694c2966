"""The simulator: start cansimd or connect to one, its nodes, its events."""

from __future__ import annotations

import atexit
import ctypes
import os
import re
import shutil
import signal
import socket as _socket
import subprocess
import sys
import tempfile
import time
from typing import TYPE_CHECKING, Any, Dict, Iterable, Iterator, List, NamedTuple, Optional, Sequence, Tuple, Union

from . import _checks
from ._bus import FLEET_IFACE, ROOT_PATH, Connection, choose_address, round_trip_offset
from ._wire import BusAddress, Capture, Wire, open_python_can_bus
from .errors import Error, NoSuchNode, Refused, Timeout
from .events import EVENT_NAMES, Event, EventLog, Mark, Since, event_of_signal
from .node import Node, NodeState

if TYPE_CHECKING:
    from .plant import Plant
    from ._replay import Replay

#: how far before the estimated simulated time of a mark an event may lie
#: and still count as after it (covers the clock estimate's error)
_MARK_SLACK_S = 0.002


def natural_key(text: str) -> List[Union[int, str]]:
    """Sort key that puts ``pt/2`` before ``pt/10``."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", text)]


class BusStatistics(NamedTuple):
    interface: str
    up: bool
    bit_rate_kbit: int
    frames_in: int
    frames_out: int
    frames_dropped: int
    frames_not_sent: int
    offered_load: float
    measured_load: float


class Simulator:
    """A running cansimd: its nodes, its simulated time, its events.

    Made by :func:`start` (which owns the process) or :func:`connect`. A
    context manager: leaving it closes the connection (and stops the
    process :func:`start` made)."""

    def __init__(self, socket: Optional[str] = None, *, bus: Optional[str] = None,
                 _process: Optional["_Process"] = None) -> None:
        address = choose_address(socket, bus)
        self._socket = address.socket
        self._process = _process
        self._log = EventLog()
        self._nodes: Dict[str, Node] = {}
        self._wire: Optional[Wire] = None
        self._epoch: Optional[float] = None
        self._conn = Connection(address, on_signal=self._on_signal, on_close=self._on_close)
        clock = round_trip_offset(self._conn)
        self._offset_us = clock.offset_us if clock else None
        self._epoch_error = clock.error_s if clock else None
        if self._offset_us is not None:
            mono, wall = time.monotonic(), time.time()
            self._epoch = wall - (mono + self._offset_us / 1e6)
        self._conn.method(ROOT_PATH, FLEET_IFACE, "Subscribe")
        self._last_action = self.mark()
        self._closed = False

    # ------------------------------------------------------------ receiver thread
    def _on_signal(self, msg: Any) -> None:
        from jeepney.low_level import HeaderFields
        member = msg.header.fields.get(HeaderFields.member, "")
        path = msg.header.fields.get(HeaderFields.path, "")
        self._log.append(lambda pos: _positioned(event_of_signal(member, path, msg.body), pos, self._epoch))

    def _on_close(self) -> None:
        self._log.close(self._lost_message())

    def _lost_message(self) -> str:
        text = f"lost the connection to cansimd on {self._conn.description}"
        if self._process is not None:
            text += self._process.exit_report()
        return text

    # ------------------------------------------------------------ fleet
    def nodes(self) -> List[Node]:
        """Every node, in natural key order (``pt/2`` before ``pt/10``), from one call."""
        objects = self._conn.managed_objects()
        nodes = [self._node_at(path, props) for path, props in objects.items()]
        return sorted(nodes, key=lambda n: natural_key(n.key))

    def states(self) -> List[NodeState]:
        """Every node's properties (values, NMT state, faults ...), natural
        key order, from one call."""
        states = [NodeState.from_properties(p) for p in self._conn.managed_objects().values()]
        return sorted(states, key=lambda s: natural_key(s.key))

    def node(self, name: Union[str, int, Node]) -> Node:
        """A node by fleet key (``vcan0/dps/0``), entry name (``dps``,
        ``pt/3`` in a ``count:`` group), ``IFACE/ID`` (``vcan0/0x10``) or
        integer node-ID (``0x11``: unique across the fleet, else
        cansim.NoSuchNode lists the candidates)."""
        if isinstance(name, Node):
            return name
        if isinstance(name, int) and not isinstance(name, bool):
            return self._node_by_id(name)
        (path,) = self._conn.method(ROOT_PATH, FLEET_IFACE, "GetNode", "s", (str(name),))
        cached = self._nodes.get(path)
        if cached is not None:
            return cached
        return self._node_at(path, self._conn.get_all(path, "io.cansim.Node1"))

    def _node_by_id(self, node_id: int) -> Node:
        if not 0 <= node_id <= 0xFF:
            raise ValueError(f"node-ID {node_id}: expected 1..127 (255: LSS-unconfigured)")
        objects = self._conn.managed_objects()
        found = sorted(((p, props) for p, props in objects.items() if props.get("NodeId") == node_id),
                       key=lambda item: natural_key(str(item[1].get("Key", ""))))
        if len(found) == 1:
            return self._node_at(*found[0])
        if not found:
            ids = sorted({int(props.get("NodeId", 0)) for props in objects.values()})
            have = ", ".join(f"0x{i:02X}" for i in ids[:40]) + (" ..." if len(ids) > 40 else "")
            raise NoSuchNode("io.cansim.Error.UnknownNode",
                             f"no node has node-ID 0x{node_id:02X} (the fleet's: {have or 'none'})")
        keys = ", ".join(str(props.get("Key")) for _, props in found)
        raise NoSuchNode("io.cansim.Error.UnknownNode",
                         f"node-ID 0x{node_id:02X} is used on {len(found)} buses: {keys}; "
                         f"name one by key or IFACE/ID")

    def _node_at(self, path: str, props: Dict[str, Any]) -> Node:
        node = self._nodes.get(path)
        if node is None or node.key != props.get("Key"):
            node = Node(self, path, props)
            self._nodes[path] = node
        else:
            node._props = props
        return node

    def __getitem__(self, name: str) -> Node:
        return self.node(name)

    def plant(self, name: str) -> "Plant":
        """A plant of the fleet's ``plants:`` by name (cansim.plant, docs/plants.md)."""
        from .plant import Plant
        return Plant(self, name)

    def plants(self) -> List["Plant"]:
        """Every plant of the fleet."""
        from .plant import plants
        return plants(self)

    def __iter__(self) -> Iterator[Node]:
        return iter(self.nodes())

    def __len__(self) -> int:
        return int(self._conn.get(ROOT_PATH, FLEET_IFACE, "NodeCount"))

    @property
    def time(self) -> float:
        """Simulated seconds since cansimd started (the clock of ``at:``)."""
        return float(self._conn.get(ROOT_PATH, FLEET_IFACE, "SimulatedTime")) / 1e6

    @property
    def epoch(self) -> Optional[float]:
        """Wall-clock time (seconds since the Unix epoch, the clock of
        python-can's frame timestamps) of simulated time 0: an event at
        simulated ``t`` happened at ``sim.epoch + t`` (``Event.wall_time``).
        None when cansimd's clock could not be read."""
        return self._epoch

    @property
    def epoch_error(self) -> Optional[float]:
        """How far :attr:`epoch` may be off, in seconds: half the round trip
        of the tightest clock read it was estimated from (a fraction of a
        millisecond on a quiet host, more on a loaded one). None with no epoch."""
        return self._epoch_error

    @property
    def version(self) -> str:
        return str(self._conn.get(ROOT_PATH, FLEET_IFACE, "Version"))

    def add(self, path_or_yaml_text: Union[str, "os.PathLike[str]"]) -> List[Node]:
        """Add nodes from a fleet fragment (one entry, a list, or a fleet
        document), given as a file or as YAML text; they boot at once."""
        text = _read_if_file(path_or_yaml_text)
        self._action()
        (paths,) = self._conn.method(ROOT_PATH, FLEET_IFACE, "AddNodes", "s", (text,))
        return [self._node_at(p, self._conn.get_all(p, "io.cansim.Node1")) for p in paths]

    def remove(self, name: Union[str, Node]) -> None:
        """The node falls silent and leaves the fleet."""
        key = name.key if isinstance(name, Node) else name
        self._action()
        self._conn.method(ROOT_PATH, FLEET_IFACE, "RemoveNode", "s", (key,))

    def reload(self) -> None:
        """Re-read the configuration file (as SIGHUP): changed nodes restart."""
        self._action()
        self._conn.method(ROOT_PATH, FLEET_IFACE, "Reload")

    def reset(self, timeout: float = 10.0) -> None:
        """The whole fleet back to power-on as configured (Fleet1.Reset):
        nodes added at run time gone, removed ones back, every node rebuilt
        (values, process models, faults, NMT state) with its stored
        parameters erased; returns once every node has booted again."""
        self._action()
        self._conn.method(ROOT_PATH, FLEET_IFACE, "Reset")
        _wait_booted(self, time.monotonic() + timeout, timeout)

    def bus_statistics(self) -> List[BusStatistics]:
        """Per interface: state, bit rate, frame counts and bus load."""
        (rows,) = self._conn.method(ROOT_PATH, FLEET_IFACE, "GetBusStatistics")
        return [BusStatistics(*r) for r in rows]

    # ------------------------------------------------------------ the wire
    def buses(self) -> List[BusAddress]:
        """Where the fleet's buses are: ``BusAddress(name, transport, host,
        port)``, transport ``"socketcan"`` (a kernel CAN interface) or
        ``"socketcand"`` (cansimd's kernel-free bus, at host:port)."""
        names = [str(row[0]) for row in self._conn.get(ROOT_PATH, FLEET_IFACE, "BusLoad")]
        try:
            served = {str(n): (str(h), int(p)) for n, h, p, *_ in
                      self._conn.get(ROOT_PATH, FLEET_IFACE, "SocketcandBuses")}
        except Refused:  # a cansimd without socketcand buses
            served = {}
        out = []
        for name in names:
            if name in served:
                host, port = served[name]
                out.append(BusAddress(name, "socketcand", _connect_host(host), port))
            else:
                out.append(BusAddress(name, "socketcan"))
        return out

    def _bus(self, name: Optional[str]) -> BusAddress:
        buses = self.buses()
        if name is None and len(buses) == 1:
            return buses[0]
        for b in buses:
            if b.name == name:
                return b
        have = ", ".join(b.name for b in buses) or "none"
        raise ValueError(f"the fleet has {'no bus ' + repr(name) if name else 'several buses'}: {have}")

    def _listen(self) -> Wire:
        if self._wire is None:
            self._wire = Wire()
        buses = self.buses()
        closed = [b.name for b in buses if b.transport == "socketcand" and b.port == 0]
        if closed:
            raise Error(f"socketcand bus {', '.join(closed)} is not listening (see {self.log or 'the log'})")
        self._wire.listen(buses)
        return self._wire

    def capture(self, buses: Optional[Sequence[str]] = None) -> Capture:
        """The frames on the fleet's buses (or the ``buses`` named) from now
        on, as python-can ``Message``s with wall-clock timestamps: a
        context manager (leaving it stops the capture) and a mark
        (``capture.wait_for(can_id=0x190)``, ``wait_for(..., since=capture)``).
        Needs python-can for SocketCAN interfaces and for ``frames``."""
        wire = self._listen()
        return Capture(wire, wire.log.next_position, time.time(), self.mark(), buses)

    def open_bus(self, name: Optional[str] = None, **kwargs: Any) -> Any:
        """A python-can bus on one of the fleet's buses (``name``; default:
        the only one): ``can.Bus(interface="socketcand", host=..., port=...,
        channel=name)`` on a kernel-free bus, ``interface="socketcan"`` on a
        kernel interface. The caller shuts it down (it is a context manager)."""
        return open_python_can_bus(self._bus(name), **kwargs)

    def replay(self, source: Union[str, "os.PathLike[str]", Capture, Iterable[Any]], on: str, *,
               loop: bool = False, filter: Union[str, int, Tuple[int, int], None] = None,
               speed: float = 1.0) -> "Replay":
        """Plays frames onto bus ``on`` as an outside participant, as
        ``cansimctl replay FILE --on BUS`` does (through Fleet1.QueueFrames:
        on a timed bus they arbitrate with the nodes' frames). ``source``: a
        candump -L file (``cansimctl capture``'s, ``Capture.save()``'s), a
        Capture, or python-can Messages. The first frame goes 100 ms after
        the call, the others with the source's spacing divided by ``speed``;
        ``loop``: again and again until ``stop()``; ``filter``: only frames
        whose (ID & MASK) == (FILTER & MASK), ``"181:7FF"`` as cansimctl's
        --filter. Returns the running Replay: ``.wait()`` until it is over."""
        from ._replay import replay
        return replay(self, source, on, loop=loop, filter=filter, speed=speed)

    def _sync(self) -> None:
        """One round trip: every signal cansimd sent before it has arrived."""
        self._conn.get(ROOT_PATH, FLEET_IFACE, "NodeCount")

    # ------------------------------------------------------------ events
    def mark(self) -> Mark:
        """A point in the event stream: ``wait_for(..., since=mark)`` and
        ``events(since=mark)`` see only what happened after it."""
        position = self._log.next_position
        if self._offset_us is None:
            return Mark(position)
        now = (time.monotonic() * 1e6 + self._offset_us) / 1e6
        return Mark(position, now - _MARK_SLACK_S)

    def _action(self) -> None:
        self._last_action = self.mark()

    def events(self, since: Since = None) -> Iterator[Event]:
        """The events received since ``since`` (default: all kept, the newest
        100,000), oldest first."""
        return iter(self._log.snapshot(_as_mark(since) or Mark(0)))

    def wait_for(self, event: str, *, node: Union[str, Node, None] = None, timeout: float = 2.0,
                 since: Since = None, **fields: Any) -> Event:
        """The first ``event`` (of ``node``, when given) after ``since``
        (default: the last action this Simulator took) whose fields match
        ``fields`` (equal, or a callable returning true). cansim.Timeout
        after ``timeout`` seconds, with what was seen."""
        if event not in EVENT_NAMES:
            raise ValueError(f"unknown event {event!r}: expected one of {', '.join(EVENT_NAMES)}")
        timeout = _checks.seconds("timeout", timeout)
        key = self.node(node).key if isinstance(node, str) else (node.key if node else None)
        mark = _as_mark(since) or self._last_action

        def matches(e: Event) -> bool:
            if e.name != event or (key is not None and e.node != key):
                return False
            return all(_field_matches(e.fields.get(k, _MISSING), v) for k, v in fields.items())

        found = self._log.wait(mark, matches, time.monotonic() + timeout, time.monotonic)
        if found is not None:
            return found
        seen = [e for e in self._log.snapshot(mark) if key is None or e.node == key]
        want = ", ".join(f"{k}={v!r}" for k, v in fields.items())
        where = f" of {key}" if key else ""
        lines = "\n".join(f"  {e}" for e in seen[-20:]) or "  (none)"
        raise Timeout(f"no {event}({want}){where} within {timeout} s; events{where} since the mark:\n{lines}",
                      seen)

    # ------------------------------------------------------------ lifetime
    @property
    def control_socket(self) -> Optional[str]:
        """The private control socket this Simulator talks to (None on a
        bus): ``cansimctl --socket PATH`` reaches the same daemon."""
        return self._socket

    @property
    def pid(self) -> Optional[int]:
        """cansimd's process ID, when this Simulator started it."""
        return self._process.proc.pid if self._process else None

    @property
    def log(self) -> Optional[str]:
        """cansimd's log file, when this Simulator started cansimd."""
        return self._process.log_path if self._process else None

    def close(self) -> None:
        """Close the connection; stop cansimd if :func:`start` started it.
        Raises cansim.Error with its log tail when cansimd exited with an error."""
        if self._closed:
            return
        self._closed = True
        if self._wire is not None:
            self._wire.close()
        self._conn.close()
        if self._process is not None:
            self._process.stop()

    def __enter__(self) -> "Simulator":
        return self

    def __exit__(self, exc_type: Any, exc: Optional[BaseException], tb: Any) -> None:
        try:
            self.close()
        except Error as error:
            if exc is None:
                raise
            if hasattr(exc, "add_note"):
                exc.add_note(str(error))
            else:
                print(f"cansim: {error}", file=sys.stderr)

    def __repr__(self) -> str:
        return f"<Simulator {self._conn.description}>"


_MISSING = object()


def _field_matches(actual: Any, wanted: Any) -> bool:
    if actual is _MISSING:
        return False
    if callable(wanted):
        return bool(wanted(actual))
    return bool(actual == wanted)


def _positioned(event: Optional[Event], position: int, epoch: Optional[float]) -> Optional[Event]:
    if event is None:
        return None
    wall = epoch + event.time if epoch is not None and event.time is not None else time.time()
    return Event(event.name, event.node, event.time, event.fields, wall, position)


def _as_mark(since: Since) -> Optional[Mark]:
    if since is None:
        return None
    if isinstance(since, Event):
        return Mark(since.position + 1)
    if isinstance(since, Mark):
        return since
    if isinstance(since, Capture):
        return since.mark  # type: ignore[no-any-return]
    raise TypeError(f"since: expected a Mark (sim.mark()), an Event or a Capture, got {type(since).__name__}")


def _connect_host(listen_host: str) -> str:
    """Where a client reaches a server listening on ``listen_host``."""
    return {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}.get(listen_host, listen_host)


def _read_if_file(path_or_text: Union[str, "os.PathLike[str]"]) -> str:
    if isinstance(path_or_text, os.PathLike) or (isinstance(path_or_text, str) and "\n" not in path_or_text
                                                  and os.path.isfile(path_or_text)):
        with open(path_or_text, encoding="utf-8") as f:
            return f.read()
    return str(path_or_text)


# ---------------------------------------------------------------- the process

def find_binary(binary: Optional[str]) -> str:
    """cansimd: ``binary``, else $CANSIMD, else cansimd in PATH."""
    candidate = binary or os.environ.get("CANSIMD") or shutil.which("cansimd")
    if not candidate:
        raise Error("cansimd not found: pass binary=, set $CANSIMD, or put cansimd in PATH")
    if not (os.path.isfile(candidate) and os.access(candidate, os.X_OK)):
        raise Error(f"cansimd {candidate!r} is not an executable file")
    return candidate


class _Process:
    """cansimd started by this client: private socket, --bus none, its log
    and (unless ``args`` says otherwise) its state in a temporary folder."""

    LOG_TAIL = 30

    def __init__(self, command: List[str], workdir: str) -> None:
        self.workdir = workdir
        self.log_path = os.path.join(workdir, "cansimd.log")
        self.socket = os.path.join(workdir, "control")
        self.command = command
        self._notify = _socket.socket(_socket.AF_UNIX, _socket.SOCK_DGRAM)
        notify_path = os.path.join(workdir, "notify")
        self._notify.bind(notify_path)
        env = dict(os.environ, NOTIFY_SOCKET=notify_path)
        for name in ("WATCHDOG_USEC", "WATCHDOG_PID", "LISTEN_FDS", "LISTEN_PID", "LISTEN_FDNAMES"):
            env.pop(name, None)
        self._log_file = open(self.log_path, "wb")
        try:
            self.proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=self._log_file,
                                         stderr=subprocess.STDOUT, env=env, preexec_fn=_die_with_parent)
        except OSError as e:
            self._log_file.close()
            self._notify.close()
            raise Error(f"cannot run {command[0]}: {e}") from e
        self._stopped = False
        _running.add(self)

    def wait_ready(self, timeout: float) -> None:
        """Until cansimd says READY=1 (sd_notify: every node's boot-up is on
        its bus), else Error with its log tail."""
        deadline = time.monotonic() + timeout
        try:
            while True:
                if self.proc.poll() is not None:
                    raise Error("cansimd did not start" + self.exit_report())
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    self.kill()
                    raise Error(f"cansimd was not ready within {timeout} s" + self.exit_report(tail_only=True))
                self._notify.settimeout(min(remaining, 0.1))
                try:
                    data = self._notify.recv(4096)
                except _socket.timeout:
                    continue
                if b"READY=1" in data.split(b"\n"):
                    return
        finally:
            self._notify.close()

    def tail(self) -> str:
        try:
            with open(self.log_path, "rb") as f:
                lines = f.read().decode("utf-8", "replace").splitlines()
        except OSError:
            return ""
        return "\n".join(lines[-self.LOG_TAIL:])

    def exit_report(self, tail_only: bool = False) -> str:
        rc = self.proc.poll()
        head = "" if tail_only or rc is None else f"; cansimd exited with status {rc}"
        tail = self.tail()
        return f"{head}; its log ({self.log_path}) ends:\n{tail}" if tail else f"{head}; its log is empty"

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._finish()

    def stop(self, timeout: float = 10.0) -> None:
        """SIGTERM, wait; Error with the log tail on a failed exit."""
        if self._stopped:
            return
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                self._finish(keep=True)
                raise Error(f"cansimd did not stop within {timeout} s of SIGTERM (killed)"
                            + self.exit_report(tail_only=True))
        rc = self.proc.returncode
        if rc != 0:
            report = self.exit_report()
            self._finish(keep=True)
            raise Error(f"cansimd failed (status {rc})" + report)
        self._finish()

    def _finish(self, keep: bool = False) -> None:
        self._stopped = True
        _running.discard(self)
        self._log_file.close()
        if not keep:
            shutil.rmtree(self.workdir, ignore_errors=True)


_running: "set[_Process]" = set()


@atexit.register
def _stop_leftovers() -> None:
    """A Simulator that was never closed: its cansimd stops with the interpreter."""
    for process in list(_running):
        try:
            process.kill()
        except Exception:
            pass


def _die_with_parent() -> None:
    """In the child: SIGTERM when the process that started cansimd dies
    (a killed pytest leaves no cansimd behind)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


#: cansimd's option that serves every interface of the fleet as a
#: kernel-free socketcand bus of the same name on a free loopback port
SOCKETCAND_OPTION = "--socketcand"

TRANSPORTS = ("socketcan", "socketcand", "auto")

ARPHRD_CAN = 280


def can_interface_exists(name: str) -> bool:
    """True when ``name`` is a kernel CAN network interface (up or not)."""
    try:
        with open(f"/sys/class/net/{name}/type") as f:
            return int(f.read().strip()) == ARPHRD_CAN
    except (OSError, ValueError):
        return False


def start(config: Union[str, "os.PathLike[str]", None] = None, *, profile: Optional[str] = None,
          interface: str = "vcan0", node_id: Optional[int] = None, binary: Optional[str] = None,
          args: Sequence[str] = (), timeout: float = 10.0, transport: str = "socketcan") -> Simulator:
    """Start cansimd and return once every node has sent its boot-up.

    ``config``: a fleet file, or a fleet as YAML text (``$INTERFACE`` in the
    text stands for ``interface``). ``profile``: one node instead (profile
    name or file, on ``interface``, at ``node_id`` or the profile's).
    ``transport``: ``"socketcan"`` (the fleet's interfaces are kernel CAN
    interfaces, as the file says), ``"socketcand"`` (every interface of the
    fleet is served as a kernel-free socketcand bus of the same name on a
    free loopback port: ``sim.buses()``, ``sim.open_bus()``), or
    ``"auto"`` (socketcan when ``interface`` exists, else socketcand).
    cansimd gets its own private control socket in a temporary folder,
    ``--bus none``, and its stored parameters there too unless ``args``
    has ``--state-dir``. Use it as a context manager: on exit cansimd gets
    SIGTERM, and cansim.Error (with its log tail) if it exited with an error.
    """
    if (config is None) == (profile is None):
        raise ValueError("start(): give a fleet (config=) or one profile (profile=), not both or neither")
    timeout = _checks.seconds("timeout", timeout)
    if transport not in TRANSPORTS:
        raise ValueError(f"start(): transport {transport!r}: expected one of {', '.join(TRANSPORTS)}")
    if transport == "auto":
        transport = "socketcan" if can_interface_exists(interface) else "socketcand"
    command = [find_binary(binary)]
    workdir = tempfile.mkdtemp(prefix="cansim-")
    try:
        if config is not None:
            command += ["--config", _config_file(config, interface, workdir)]
        else:
            command += ["--profile", str(profile), "--interface", interface]
            if node_id is not None:
                command += ["--node-id", str(node_id)]
        command += _private_options(workdir, transport, args)
        process = _Process(command, workdir)
    except BaseException:
        shutil.rmtree(workdir, ignore_errors=True)
        raise
    deadline = time.monotonic() + timeout
    try:
        process.wait_ready(timeout)
        sim = Simulator(process.socket, _process=process)
    except BaseException:
        process.kill()
        raise
    try:
        _wait_booted(sim, deadline, timeout)
    except BaseException:
        sim._conn.close()
        process.kill()
        raise
    return sim


def _private_options(workdir: str, transport: str, args: Sequence[str]) -> List[str]:
    """A started cansimd's own control socket and state folder, its bus, then ``args``."""
    options = ["--control-socket", os.path.join(workdir, "control"), "--bus", "none"]
    if transport == "socketcand":
        options.append(SOCKETCAND_OPTION)
    if not any(a == "--state-dir" or str(a).startswith("--state-dir=") for a in args):
        options += ["--state-dir", os.path.join(workdir, "state")]
    return options + [str(a) for a in args]


def _wait_booted(sim: Simulator, deadline: float, timeout: float) -> None:
    """Until no powered node is still initialising (a boot-up delay of the
    device, e.g. the SMC's 150 ms) other than LSS-unconfigured ones."""
    while True:
        waiting = [s.key for s in sim.states()
                   if s.nmt_state == "initialising" and s.powered and s.node_id != 255]
        if not waiting:
            return
        if time.monotonic() >= deadline:
            raise Error(f"cansimd started, but {len(waiting)} node(s) sent no boot-up within {timeout} s: "
                        + ", ".join(waiting[:10]))
        time.sleep(0.01)


def _config_file(config: Union[str, "os.PathLike[str]"], interface: str, workdir: str) -> str:
    if isinstance(config, os.PathLike) or os.path.exists(str(config)):
        path = os.fspath(config)
        if not os.path.isfile(path):
            raise Error(f"fleet configuration {path!r} is not a file")
        return os.path.abspath(path)
    text = str(config)
    if "\n" not in text and ":" not in text:
        raise Error(f"fleet configuration {text!r}: no such file (YAML text needs a mapping)")
    path = os.path.join(workdir, "fleet.yaml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace("$INTERFACE", interface))
    return path


def connect(socket: Optional[str] = None, *, bus: Optional[str] = None) -> Simulator:
    """Attach to a running cansimd: ``socket`` (its private control socket),
    or ``bus="system"|"user"``; by default cansimctl's order
    ($CANSIM_CONTROL_SOCKET, the default socket paths, then the system bus
    as root, else the user bus)."""
    return Simulator(socket, bus=bus)
