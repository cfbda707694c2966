"""cansimd's signals as :class:`Event` values, and the log they are kept in.

A :class:`Simulator` subscribes once; its receiver thread appends every
signal to an :class:`EventLog` (bounded, oldest dropped first). A
:class:`Mark` is a position in that log plus the simulated time it was
taken at: "the events after this point".
"""

from __future__ import annotations

import re
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Deque, Dict, Iterator, List, Optional, Sequence, Tuple, Union

from .errors import Error

if TYPE_CHECKING:
    from ._wire import Capture

#: signal member -> names of its arguments after the leading time
_NODE_SIGNAL_FIELDS: Dict[str, Tuple[str, ...]] = {
    "NmtStateChanged": ("old", "new"),
    "BootUp": ("node_id",),
    "EmcySent": ("code", "register", "vendor"),
    "ObjectWritten": ("index", "sub", "value", "via"),
    "FaultStarted": ("id", "kind"),
    "FaultEnded": ("id", "kind"),
    "PdoMappingChanged": (),
}
_FLEET_SIGNALS = ("NodeAdded", "NodeRemoved")
#: fleet signals that start with the simulated time, like a node's
_TIMED_FLEET_SIGNAL_FIELDS: Dict[str, Tuple[str, ...]] = {
    "BusStateChanged": ("interface", "old", "state"),
}

#: every event name a wait can name
EVENT_NAMES: Tuple[str, ...] = tuple(_NODE_SIGNAL_FIELDS) + _FLEET_SIGNALS + tuple(_TIMED_FLEET_SIGNAL_FIELDS)


@dataclass(frozen=True)
class Event:
    """One thing that happened in cansimd.

    ``name``: ``"BootUp"``, ``"EmcySent"``, ``"NmtStateChanged"``,
    ``"ObjectWritten"``, ``"FaultStarted"``, ``"FaultEnded"``,
    ``"PdoMappingChanged"`` (node events), ``"NodeAdded"``, ``"NodeRemoved"``,
    ``"BusStateChanged"`` (fleet events); ``node``: the node's fleet key
    (None for fleet events); ``time``: simulated seconds (None for
    NodeAdded / NodeRemoved); ``wall_time``: the same instant in seconds
    since the Unix epoch (``Simulator.epoch + time``; for an event without
    a simulated time, when it was received), the clock of python-can's
    frame timestamps; ``fields``: the signal's arguments by name, e.g.
    ``code`` and ``register`` of an EMCY, ``old`` and ``new`` of an NMT
    state change.
    """

    name: str
    node: Optional[str]
    time: Optional[float]
    fields: Dict[str, Any]
    wall_time: Optional[float] = field(default=None, compare=False)
    position: int = field(default=-1, repr=False, compare=False)

    def __getitem__(self, key: str) -> Any:
        return self.fields[key]

    def __str__(self) -> str:
        t = f"{self.time:.6f} s" if self.time is not None else "-"
        args = ", ".join(f"{k}={_show(v)}" for k, v in self.fields.items())
        return f"[{t}] {self.node or 'fleet'} {self.name}({args})"


def _show(v: Any) -> str:
    if isinstance(v, bytes):
        return v.hex(" ") or "''"
    if isinstance(v, int) and not isinstance(v, bool) and v > 9:
        return f"0x{v:X}"
    return repr(v)


@dataclass(frozen=True)
class Mark:
    """A point in the event stream: events at ``position`` or later, and
    (when ``time`` is known) not older than ``time`` simulated seconds.
    The time bound keeps out an event that happened before the mark but was
    still on its way from cansimd when the mark was taken."""

    position: int
    time: Optional[float] = None

    def admits(self, event: Event) -> bool:
        if event.position < self.position:
            return False
        return self.time is None or event.time is None or event.time >= self.time


#: what ``since=`` takes: a Mark, an Event (the events after it), a Capture
#: (the events after its start), or None (the default of the call)
Since = Union[Mark, "Event", "Capture", None]


_ESCAPE = re.compile(r"_([0-9a-fA-F]{2})")


def key_of_path(path: str) -> Optional[str]:
    """The fleet key of a node object path (segments escaped as
    sd_bus_path_encode does: ``_2d`` for ``-``), None for other paths."""
    prefix = "/io/cansim/Cansimd1/node/"
    if not path.startswith(prefix):
        return None
    parts = path[len(prefix):].split("/")
    decoded = [_ESCAPE.sub(lambda m: chr(int(m.group(1), 16)), p) for p in parts]
    return "/".join(decoded)


def _plain(value: Any) -> Any:
    """A variant argument (signature, value) as its value."""
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
        sig, inner = value
        return bytes(inner) if sig == "ay" else inner
    return value


def event_of_signal(member: str, path: str, body: Sequence[Any]) -> Optional[Event]:
    """The Event of one cansimd signal, None for signals that are not events
    (PropertiesChanged ...)."""
    if member in _FLEET_SIGNALS:
        key = body[1] if len(body) > 1 else key_of_path(str(body[0]) if body else "")
        return Event(member, key, None, {"path": body[0] if body else "", "key": key})
    if member in _TIMED_FLEET_SIGNAL_FIELDS:
        if not body or not isinstance(body[0], int):
            return None
        names = _TIMED_FLEET_SIGNAL_FIELDS[member]
        return Event(member, None, body[0] / 1e6, dict(zip(names, body[1:])))
    key = key_of_path(path)
    if key is None or not body or not isinstance(body[0], int):
        return None
    names = _NODE_SIGNAL_FIELDS.get(member, ())
    args = list(body[1:])
    fields = {(names[i] if i < len(names) else f"arg{i}"): _plain(v) for i, v in enumerate(args)}
    if "vendor" in fields and isinstance(fields["vendor"], (list, bytearray)):
        fields["vendor"] = bytes(fields["vendor"])
    return Event(member, key, body[0] / 1e6, fields)


class EventLog:
    """The events received so far (the newest ``capacity``), thread-safe;
    positions count every event ever appended."""

    def __init__(self, capacity: int = 100_000) -> None:
        self._events: Deque[Event] = deque(maxlen=capacity)
        self._next = 0
        self._cond = threading.Condition()
        self._closed: Optional[str] = None

    @property
    def next_position(self) -> int:
        with self._cond:
            return self._next

    def append(self, make: Callable[[int], Optional[Event]]) -> None:
        with self._cond:
            event = make(self._next)
            if event is None:
                return
            self._events.append(event)
            self._next += 1
            self._cond.notify_all()

    def close(self, reason: str) -> None:
        with self._cond:
            self._closed = reason
            self._cond.notify_all()

    def _from(self, position: int) -> List[Event]:
        first = self._next - len(self._events)
        start = max(position - first, 0)
        return [self._events[i] for i in range(start, len(self._events))]

    def snapshot(self, mark: Mark) -> List[Event]:
        with self._cond:
            return [e for e in self._from(mark.position) if mark.admits(e)]

    def wait(self, mark: Mark, matches: Callable[[Event], bool], deadline: float,
             now: Callable[[], float]) -> Optional[Event]:
        """The first event after mark that matches, waiting until deadline
        (a value of now()); None on timeout."""
        scanned = mark.position
        with self._cond:
            while True:
                for e in self._from(scanned):
                    if mark.admits(e) and matches(e):
                        return e
                scanned = self._next
                if self._closed is not None:
                    raise Error(self._closed)
                remaining = deadline - now()
                if remaining <= 0:
                    return None
                self._cond.wait(remaining)

    def __iter__(self) -> Iterator[Event]:
        return iter(self.snapshot(Mark(0)))
