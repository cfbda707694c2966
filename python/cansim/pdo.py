"""A node's TPDOs decoded by its live mapping: ``node.tpdo(1).next()``.

The reader follows the node's PDO configuration as its engine runs it
(GetPdoMapping), asking again after each ``PdoMappingChanged`` event; a
frame is decoded by the mapping in force when it was sent (the event's
wall time against the frame's timestamp). Before it decodes a frame the
reader makes one round trip to cansimd, so every event cansimd sent before
that frame has arrived.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Dict, Iterator, List, Optional, Tuple, Union

from . import _checks
from ._decode import PdoMapping, Value, decode_pdo, pdo_mappings
from ._wire import Frame, candump_line
from .errors import Error, Timeout
from .events import Event, Mark

if TYPE_CHECKING:
    from .node import Node

#: a mapping is in force for frames stamped at most this long before its
#: PdoMappingChanged (the simulated-time epoch's estimate is this good)
_CHANGE_SLACK_S = 0.0002


@dataclass(frozen=True)
class PdoSample:
    """One TPDO frame decoded: ``values`` {object name: value in its unit},
    ``units`` {object name: unit ("" for none)}, ``frame`` the python-can
    ``Message`` as received, ``pdo`` ("TPDO1"), ``error`` when the frame was
    shorter than the mapping (only the entries that fit are in ``values``).
    ``values, frame = sample`` unpacks; ``sample["AI input PV 1"]`` reads a value."""

    pdo: str
    values: Dict[str, Value]
    units: Dict[str, str]
    frame: Any
    error: Optional[str] = None

    @property
    def time(self) -> float:
        """The frame's wall-clock timestamp."""
        return float(self.frame.timestamp)

    def __getitem__(self, name: str) -> Value:
        return self.values[name]

    def __iter__(self) -> Iterator[Any]:
        return iter((self.values, self.frame))

    def __str__(self) -> str:
        shown = ", ".join(f"{k} = {v:.6g}{' ' + self.units[k] if self.units[k] else ''}"
                          if isinstance(v, float) else f"{k} = {v!r}{' ' + self.units[k] if self.units[k] else ''}"
                          for k, v in self.values.items())
        return f"{self.pdo} [{self.time:.6f}] {shown}" + (f" ({self.error})" if self.error else "")


class Tpdo:
    """The frames of one TPDO of a node from now on, decoded (``node.tpdo(n)``)."""

    def __init__(self, node: "Node", number: int) -> None:
        if not 1 <= number <= 512:
            raise ValueError(f"TPDO number {number}: expected 1..512")
        self.node = node
        self.name = f"TPDO{number}"
        sim = node._sim
        self._capture = sim.capture(buses=[node.interface])
        self._events: Union[Mark, Event] = sim.mark()
        self._position = self._capture.start_position
        #: (in force from: wall-clock time, mapping), oldest first
        self._mappings: List[Tuple[float, PdoMapping]] = [(float("-inf"), self._fetch())]

    def _fetch(self) -> PdoMapping:
        (raw,) = self.node._call("GetPdoMapping")
        for m in pdo_mappings(raw):
            if m.name == self.name:
                return m
        raise Error(f"{self.node.key} has no {self.name}")

    def _follow_changes(self) -> None:
        """Asks for the mapping again after PdoMappingChanged events; it is
        in force from the first of them (a remapping is a sequence of writes
        while the PDO is invalid, so no frame of it lies between them)."""
        changes = [e for e in self.node._sim.events(since=self._events)
                   if e.name == "PdoMappingChanged" and e.node == self.node.key]
        if not changes:
            return
        self._events = changes[-1]
        self._mappings.append(((changes[0].wall_time or time.time()) - _CHANGE_SLACK_S, self._fetch()))

    @property
    def mapping(self) -> PdoMapping:
        """The mapping in force now (the CAN-ID, the entries with their types, scales and units)."""
        self.node._sim._sync()
        self._follow_changes()
        return self._mappings[-1][1]

    def _mapping_at(self, t: float) -> PdoMapping:
        chosen = self._mappings[0][1]
        for start, m in self._mappings:
            if t >= start:
                chosen = m
        return chosen

    def _could_be(self, f: Frame) -> bool:
        return f.channel == self.node.interface and any(
            f.can_id == m.can_id and f.extended == m.extended for _, m in self._mappings)

    def next(self, timeout: float = 2.0) -> PdoSample:
        """The next frame of this TPDO (after the one the last call returned,
        or after ``tpdo()``), decoded; cansim.Timeout when none comes."""
        deadline = time.monotonic() + _checks.seconds("timeout", timeout)
        log = self._capture._wire.log
        while True:
            self._follow_changes()
            found = log.wait(self._position, lambda _, f: self._capture._admits(f) and self._could_be(f),
                             min(deadline, time.monotonic() + 0.05))
            if found is not None:
                position, frame = found
                self.node._sim._sync()  # every event sent before this frame has arrived
                self._follow_changes()
                mapping = self._mapping_at(frame.timestamp)
                self._position = position + 1
                if frame.can_id != mapping.can_id or frame.extended != mapping.extended:
                    continue  # the CAN-ID of an earlier mapping, no longer this TPDO's
                values, units, error = decode_pdo(mapping, frame.data)
                return PdoSample(self.name, values, units, frame.message(), error)
            if time.monotonic() >= deadline:
                m = self._mappings[-1][1]
                seen = self._capture.raw()[-10:]
                lines = "\n".join(f"  {candump_line(f)}" for f in seen) or "  (none)"
                raise Timeout(f"{self.node.key}: no {self.name} (CAN-ID 0x{m.can_id:03X}, "
                              f"{'valid' if m.valid else 'invalid'}) within {timeout} s; "
                              f"the last frames on {self.node.interface}:\n{lines}", seen)

    def wait_for(self, condition: Callable[[PdoSample], bool], *, timeout: float = 2.0) -> PdoSample:
        """The next frames until one for which ``condition(sample)`` is true
        (``lambda s: abs(s["AI input PV 1"] - 6.5) < 0.01``): the effect of
        an action, which the first frame after it need not show yet."""
        deadline = time.monotonic() + _checks.seconds("timeout", timeout)
        last: Optional[PdoSample] = None
        while True:
            try:
                sample = self.next(max(deadline - time.monotonic(), 0.0))
            except Timeout as e:
                raise Timeout(f"{self.node.key}: no {self.name} matching within {timeout} s; the last one: "
                              f"{last if last else '(none)'}", [last] if last else []) from e
            if condition(sample):
                return sample
            last = sample

    def __iter__(self) -> Iterator[PdoSample]:
        while True:
            yield self.next()

    def close(self) -> None:
        self._capture.stop()

    def __enter__(self) -> "Tpdo":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Tpdo {self.node.key} {self.name}>"
