"""A simulated node, its measurement channels and its faults."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, List, NamedTuple, Optional, Tuple, TypeVar, Union

from . import _checks
from ._bus import NODE_IFACE
from .errors import Refused, Timeout
from .events import EVENT_NAMES, Event, Since

if TYPE_CHECKING:
    from ._decode import PdoMapping
    from .pdo import Tpdo
    from .simulator import Simulator

Value = Union[int, float, str, bytes]

#: NMT commands as CiA 301 names them (§7.2.8.3.1), and cansimctl's short
#: aliases, -> the name Nmt() gets (cansimctl nmt takes the same words)
_NMT_COMMANDS = {
    "start": "start",
    "stop": "stop",
    "pre-operational": "pre-operational",
    "preop": "pre-operational",
    "reset-node": "reset-node",
    "reset": "reset-node",
    "reset-communication": "reset-communication",
    "reset-comm": "reset-communication",
}

#: the off time of power_cycle() (cansimctl power-cycle has the same default)
POWER_CYCLE_OFF_S = 0.5

#: fault parameters that are durations or instants: a number means seconds
_TIME_PARAMS = ("at", "after", "duration", "period", "sdo_delay", "delay", "jitter")


class Reading(NamedTuple):
    """One channel's value as the node reports it and as the process is, both
    in ``unit``: they compare as they are."""

    value: float
    """reported value (what the node answers: sensor model, faults, override)
    as the device means it, in ``unit``; a PV in counts converted with the
    device's own scaling"""
    true_value: float
    """the process model's value, in ``unit``"""
    unit: str
    """the channel's current unit (0x6131), e.g. ``"bar"``, ``"degC"``"""
    status: int
    """the channel's status byte (0x6150)"""
    counts: Optional[float] = None
    """the PV as the node answers it when it is counts, not in ``unit`` (a
    device whose scaling says so: the ADZ SMC by default); None otherwise"""


class Emcy(NamedTuple):
    """The last EMCY a node sent."""

    time: float
    code: int
    register: int
    vendor: bytes


class FaultState(NamedTuple):
    id: int
    kind: str
    active: bool


@dataclass(frozen=True)
class NodeState:
    """Every property of a node at one instant (from one D-Bus call)."""

    key: str
    name: str
    index: int
    interface: str
    node_id: int
    profile: str
    personality: str
    nmt_state: str
    powered: bool
    on_bus: bool
    pressure: Optional[Reading]
    temperature: Optional[Reading]
    overrides: List[Tuple[str, float, str]]
    faults: List[FaultState]
    emcy_count: int
    last_emcy: Optional[Emcy]
    recording: str

    @classmethod
    def from_properties(cls, p: Dict[str, Any]) -> "NodeState":
        return cls(
            key=p.get("Key", ""), name=p.get("Name", ""), index=int(p.get("Index", 0)),
            interface=p.get("Interface", ""), node_id=int(p.get("NodeId", 0)),
            profile=p.get("Profile", ""), personality=p.get("Personality", ""),
            nmt_state=p.get("NmtState", ""), powered=bool(p.get("Powered", False)),
            on_bus=bool(p.get("OnBus", False)),
            pressure=_reading(p.get("Pressure"), p.get("PressureCounts")),
            temperature=_reading(p.get("Temperature"), p.get("TemperatureCounts")),
            overrides=[tuple(o) for o in p.get("Overrides", [])],  # type: ignore[misc]
            faults=[FaultState(int(i), k, bool(a)) for i, k, a in p.get("Faults", [])],
            emcy_count=int(p.get("EmcyCount", 0)), last_emcy=_emcy(p.get("LastEmcy")),
            recording=p.get("Recording", ""),
        )


def _reading(raw: Any, counts: Optional[float] = None) -> Optional[Reading]:
    if not raw:
        return None
    true_value, value, unit, status = raw
    if not unit and math.isnan(value):
        return None  # the node has no such channel
    return Reading(value, true_value, unit, status, None if counts is None or math.isnan(counts) else counts)


def _measure(x: float) -> str:
    """A measured value for people at every magnitude: no exponent, digits
    grouped in threes (9 990 440, not 9.99044e+06)."""
    if math.isnan(x) or math.isinf(x):
        return str(x)
    text = f"{x:,.6f}" if abs(x) < 1e15 else f"{x:g}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text.replace(",", " ")


def _emcy(raw: Any) -> Optional[Emcy]:
    if not raw or raw[0] < 0:
        return None
    t, code, register, vendor = raw
    return Emcy(t / 1e6, code, register, bytes(vendor))


def _param_text(name: str, value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)) and name in _TIME_PARAMS:
        return f"{value!r} s"
    return str(value)


def _variant(value: Value) -> Tuple[str, Any]:
    """A Python value as the D-Bus variant Write() takes."""
    if isinstance(value, bool):
        return ("b", value)
    if isinstance(value, int):
        return ("t", _checks.integer("value", value, "t")) if value >= 1 << 63 else \
            ("x", _checks.integer("value", value, "x"))
    if isinstance(value, float):
        return ("d", value)
    if isinstance(value, str):
        return ("s", value)
    if isinstance(value, (bytes, bytearray, memoryview)):
        return ("ay", bytes(value))
    raise TypeError(f"cannot write a {type(value).__name__} to an object (int, float, str or bytes)")


def parse_object(index: Union[int, str], sub: Optional[int]) -> Tuple[int, int]:
    """(index, sub) from 0x1018, 4 or "0x1018:4" / "1018sub4"; ValueError
    naming ``index`` or ``sub`` when one is not an object's (16 / 8 bits)."""
    if isinstance(index, str):
        text = index.strip().lower().replace("sub", ":")
        head, _, tail = text.partition(":")
        try:
            i = int(head, 16) if not head.startswith("0x") else int(head, 0)
            s = int(tail, 0) if tail else None
        except ValueError:
            raise ValueError(f"index must be an object index such as 0x1018 or '0x1018:4', got {index!r}") from None
        if s is not None:
            if sub not in (None, 0):
                raise ValueError(f"sub-index given twice: {index!r} and {sub}")
            sub = s
        index = i
    return _checks.integer("index", index, "q"), _checks.integer("sub", sub or 0, "y")


class Channel:
    """The ``pressure`` or ``temperature`` channel of a node: the process
    value (the truth) and what the node reports."""

    def __init__(self, node: "Node", name: str) -> None:
        self.node = node
        self.name = name
        self._property = name.capitalize()

    def __repr__(self) -> str:
        return f"<Channel {self.node.key} {self.name}>"

    def reading(self) -> Reading:
        """Reported value, true value, unit, status and counts, in one call."""
        props = self.node._get_all()
        r = _reading(props.get(self._property), props.get(self._property + "Counts"))
        if r is None:
            raise Refused("io.cansim.Error.UnknownChannel", f"{self.node.key} has no {self.name} channel")
        return r

    @property
    def value(self) -> float:
        """The reported value (float, in ``unit``)."""
        return self.reading().value

    @property
    def true_value(self) -> float:
        """The process model's value (float, in ``unit``)."""
        return self.reading().true_value

    @property
    def unit(self) -> str:
        return self.reading().unit

    @property
    def status(self) -> int:
        """The channel's 0x6150 status byte."""
        return self.reading().status

    def set(self, value: float, unit: Optional[str] = None, *, ramp: Optional[float] = None) -> None:
        """The true value becomes ``value`` (``unit``: default the channel's
        current unit) at once, or linearly over ``ramp`` seconds."""
        unit = unit or self.unit
        if ramp is None:
            self.node._act("Step", "sds", self.name, float(value), unit)
        else:
            self.node._act("Ramp", "sdsd", self.name, float(value), unit, float(ramp))

    def wait_for(self, value: float, *, tolerance: float = 0.01, timeout: float = 2.0,
                 true_value: bool = False) -> Reading:
        """Poll until the reported value (or the true value) is within
        ``tolerance`` of ``value`` (both in the channel's unit, the reported
        one as the device means it: counts converted); the reading, or
        cansim.Timeout with the last one. The reported value follows the
        process at the sensor's own pace (sampling, filter, PDO timing)."""
        value = _checks.finite("value", value)
        tolerance = _checks.finite("tolerance", tolerance)
        deadline = time.monotonic() + _checks.seconds("timeout", timeout)
        while True:
            r = self.reading()
            got = r.true_value if true_value else r.value
            if abs(got - value) <= tolerance:
                return r
            if time.monotonic() >= deadline:
                which = "true value" if true_value else "reported value"
                counts = f" ({_measure(r.counts)} counts)" if r.counts is not None and not true_value else ""
                raise Timeout(f"{self.node.key} {self.name}: {which} {_measure(got)} {r.unit}{counts}, "
                              f"not {_measure(value)} ± {_measure(tolerance)} within {timeout} s")
            time.sleep(0.01)

    def hold(self) -> None:
        """The true value stays where it is now."""
        self.node._act("Hold", "s", self.name)

    def override(self, value: float, unit: Optional[str] = None) -> None:
        """The node reports ``value`` whatever its sensor measures."""
        self.node._act("Override", "sds", self.name, float(value), unit or self.unit)

    def clear_override(self) -> None:
        self.node._act("ClearOverride", "s", self.name)

    def model(self, yaml_text: str) -> None:
        """Replace the channel's process model (a profile's ``physics:``
        channel: a term list or one term, YAML), starting now."""
        self.node._act("SetModel", "ss", self.name, yaml_text)

    def restore_model(self) -> None:
        """Back to the profile's process model."""
        self.node._act("RestoreModel", "s", self.name)


def _fault_texts(params: Dict[str, Any], duration: Any, at: Any) -> Dict[str, str]:
    """ArmFault's parameters (a node's or a plant's) as the texts cansimd parses."""
    given = {("class" if k == "class_" else k): v for k, v in params.items()}  # a Python keyword
    if duration is not None:
        given["duration"] = duration
    if at is not None:
        given["at"] = at
    return {k: _param_text(k, v) for k, v in given.items() if v is not None}


_F = TypeVar("_F", bound="_ArmedFault")


class _ArmedFault:
    """A fault armed on a node or a plant (``owner``: what answers
    ListFaults and CancelFault); a context manager that cancels it on exit."""

    def __init__(self, owner: Any, id: int, kind: str) -> None:
        self._owner = owner
        self.id = id
        self.kind = kind

    def _listed(self) -> Optional[Tuple[Any, ...]]:
        for f in self._owner._call("ListFaults")[0]:
            if f[0] == self.id:
                return tuple(f)
        return None

    @property
    def active(self) -> bool:
        """True while an occurrence of the fault is in effect."""
        f = self._listed()
        return bool(f and f[3])

    @property
    def armed(self) -> bool:
        """True until the fault has ended for good or was cancelled."""
        return self._listed() is not None

    def cancel(self) -> None:
        """End the fault now; a fault that has already ended is left alone."""
        try:
            self._owner._act("CancelFault", "u", self.id)
        except Refused as e:
            if e.name != "io.cansim.Error.UnknownFault":
                raise

    def __enter__(self: _F) -> _F:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.cancel()


class Fault(_ArmedFault):
    """An armed fault of a node; a context manager that cancels it on exit."""

    def __init__(self, node: "Node", id: int, kind: str, info: Optional[Tuple[Any, ...]] = None) -> None:
        super().__init__(node, id, kind)
        self.node = node
        self._info = info

    def __repr__(self) -> str:
        return f"<Fault {self.id} {self.kind} on {self.node.key}>"

    @property
    def channel(self) -> str:
        f = self._info or self._listed()
        return str(f[2]) if f else ""


class Node:
    """One simulated node, named by its fleet key (``vcan0/dps/0``).

    Identity (key, name, interface, profile, personality) is read once; the
    other properties are read from cansimd at each access (``state()``
    reads them all in one call)."""

    def __init__(self, sim: "Simulator", path: str, properties: Dict[str, Any]) -> None:
        self._sim = sim
        self.path = path
        self._props = properties
        self.pressure = Channel(self, "pressure")
        self.temperature = Channel(self, "temperature")

    def __repr__(self) -> str:
        return f"<Node {self.key} id=0x{self._props.get('NodeId', 0):02X} {self.profile}>"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Node) and other.path == self.path and other._sim is self._sim

    def __hash__(self) -> int:
        return hash(self.path)

    # ------------------------------------------------------------ plumbing
    def _get(self, name: str) -> Any:
        return self._sim._conn.get(self.path, NODE_IFACE, name)

    def _get_all(self) -> Dict[str, Any]:
        return self._sim._conn.get_all(self.path, NODE_IFACE)

    def _call(self, member: str, signature: Optional[str] = None, *args: Any) -> Tuple[Any, ...]:
        return self._sim._conn.method(self.path, NODE_IFACE, member, signature, tuple(args))

    def _act(self, member: str, signature: Optional[str] = None, *args: Any) -> Tuple[Any, ...]:
        """A call that changes the simulation: the point "wait_for" waits from."""
        self._sim._action()
        return self._call(member, signature, *args)

    # ------------------------------------------------------------ identity
    @property
    def key(self) -> str:
        """The fleet key, ``interface/name/index``: stable across LSS and reloads."""
        return str(self._props["Key"])

    @property
    def name(self) -> str:
        return str(self._props["Name"])

    @property
    def index(self) -> int:
        return int(self._props.get("Index", 0))

    @property
    def interface(self) -> str:
        return str(self._props["Interface"])

    @property
    def profile(self) -> str:
        return str(self._props["Profile"])

    @property
    def personality(self) -> str:
        return str(self._props["Personality"])

    # ------------------------------------------------------------ live state
    @property
    def node_id(self) -> int:
        """The current node-ID (255: LSS-unconfigured)."""
        return int(self._get("NodeId"))

    @property
    def nmt_state(self) -> str:
        """``"initialising"``, ``"pre-operational"``, ``"operational"`` or ``"stopped"``."""
        return str(self._get("NmtState"))

    @property
    def powered(self) -> bool:
        return bool(self._get("Powered"))

    @property
    def on_bus(self) -> bool:
        """Powered, not silent or bus-off, and at its bus's bit rate."""
        return bool(self._get("OnBus"))

    @property
    def emcy_count(self) -> int:
        return int(self._get("EmcyCount"))

    @property
    def last_emcy(self) -> Optional[Emcy]:
        """(time, code, register, vendor bytes) of the last EMCY sent, or None."""
        return _emcy(self._get("LastEmcy"))

    def state(self) -> NodeState:
        """Every property now, in one call."""
        props = self._sim._conn.get_all(self.path, NODE_IFACE)
        self._props = props
        return NodeState.from_properties(props)

    # ------------------------------------------------------------ actions
    def fault(self, kind: str, *, duration: Optional[Union[float, str]] = None,
              at: Optional[Union[float, str]] = None, **params: Any) -> Fault:
        """Arm a fault (``open``, ``short``, ``drift``, ``stuck``, ``bus_off``,
        ``power_loss`` ...: the kinds of a profile's ``faults:``). Numbers
        for ``duration``, ``at`` (simulated time), ``after``, ``period``,
        ``sdo_delay`` are seconds; other values are YAML text with their unit
        (``value="0.5 bar"``); ``delay``, ``jitter`` of ``frame_delay`` are
        seconds too, ``class_`` is ``class`` (of ``error_frames``: a Python
        keyword). Returns the fault; ``with`` cancels it."""
        (fault_id,) = self._act("ArmFault", "sa{ss}", kind, _fault_texts(params, duration, at))
        return Fault(self, int(fault_id), kind)

    def faults(self) -> List[Fault]:
        """The faults armed on this node now."""
        return [Fault(self, int(f[0]), f[1], tuple(f)) for f in self._call("ListFaults")[0]]

    def power_cycle(self, off: float = POWER_CYCLE_OFF_S) -> None:
        """Power off now, on again after ``off`` seconds (0: an immediate
        reboot; stored values kept)."""
        self._act("PowerCycle", "d", float(off))

    def nmt(self, command: str) -> None:
        """A local NMT transition: ``"start"``, ``"stop"``, ``"pre-operational"``,
        ``"reset-node"``, ``"reset-communication"`` (CiA 301's names), or
        cansimctl's aliases ``"preop"``, ``"reset"``, ``"reset-comm"``."""
        try:
            daemon_command = _NMT_COMMANDS[command]
        except KeyError:
            raise ValueError(f"NMT command {command!r}: expected one of start, stop, pre-operational (preop), "
                             "reset-node (reset), reset-communication (reset-comm)") from None
        self._act("Nmt", "s", daemon_command)

    def store(self, sub: int = 1) -> None:
        """As if the master wrote "save" to 0x1010:sub (1: all parameters)."""
        self._act("Store", "y", _checks.integer("sub", sub, "y"))

    def restore(self, sub: int = 1) -> None:
        """As if the master wrote "load" to 0x1011:sub (in effect at the next reset)."""
        self._act("Restore", "y", _checks.integer("sub", sub, "y"))

    def read(self, index: Union[int, str], sub: int = 0) -> Value:
        """The object's value, typed by the object dictionary: int, float,
        str or bytes. ``index`` may also be ``"0x1018:4"``."""
        i, s = parse_object(index, sub)
        (value,) = self._call("Read", "qy", i, s)
        sig, inner = value
        return bytes(inner) if sig == "ay" else inner

    def write(self, index: Union[int, str], sub: int, value: Value) -> None:
        """Write the object as the device's own application would (range and
        type checked, the same hooks as an SDO write)."""
        i, s = parse_object(index, sub)
        self._act("Write", "qyv", i, s, _variant(value))

    def dcf(self) -> str:
        """The node's CiA 306 DCF now (its EDS with current values)."""
        return str(self._call("GetDcf")[0])

    def record(self, path: Optional[str]) -> None:
        """CSV recording of true and reported values to ``path``; None stops it."""
        if path is None:
            self._call("StopRecording")
        else:
            self._call("StartRecording", "s", str(path))

    # ------------------------------------------------------------ the wire
    def tpdo(self, number: int) -> "Tpdo":
        """TPDO ``number``'s frames from now on, decoded by the node's live
        mapping: ``.next(timeout)`` gives a ``PdoSample`` ({object name:
        value in its unit} and the raw frame), ``.wait_for(condition)`` the
        first one that shows an effect (cansim/pdo.py)."""
        from .pdo import Tpdo
        return Tpdo(self, number)

    def pdo_mapping(self) -> List["PdoMapping"]:
        """Every PDO as the node's engine runs it now (GetPdoMapping)."""
        from ._decode import pdo_mappings
        return pdo_mappings(self._call("GetPdoMapping")[0])

    # ------------------------------------------------------------ events
    def wait_for(self, event: str, *, timeout: float = 2.0, since: Since = None,
                 **fields: Any) -> Event:
        """The first ``event`` of this node after ``since`` (default: the
        last action this Simulator took) whose fields equal ``fields`` (a
        callable field tests the value). Raises cansim.Timeout after
        ``timeout`` seconds."""
        return self._sim.wait_for(event, node=self, timeout=timeout, since=since, **fields)

    def events(self, since: Since = None) -> List[Event]:
        """This node's events received since ``since`` (default: all kept)."""
        return [e for e in self._sim.events(since) if e.node == self.key]


__all__ = ["Node", "Channel", "Fault", "NodeState", "Reading", "Emcy", "FaultState", "EVENT_NAMES"]
