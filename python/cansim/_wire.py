"""The frames on a fleet's buses, as a bus participant hears them.

A :class:`Wire` listens on every bus of one Simulator's fleet: a kernel CAN
interface through python-can's SocketCAN bus, a kernel-free socketcand bus
(cansimd's TCP server, docs/socketcand.md) through this module's own
socketcand client (python-can's takes every frame for an extended one).
Each listener is a thread that appends what it hears to one
:class:`FrameLog`; a :class:`Capture` is a window of that log.

Frames are kept as plain tuples (about a tenth of a python-can Message) and
become ``can.Message`` only when asked for; timestamps are wall-clock
seconds since the Unix epoch, the kernel's receive time on SocketCAN, the
time cansimd put on the frame on a socketcand bus.
"""

from __future__ import annotations

import os
import select
import socket as _socket
import threading
import time
from collections import deque
from typing import Any, Callable, Deque, Dict, Iterable, Iterator, List, NamedTuple, Optional, Sequence, Tuple, Union

from . import _checks
from .errors import Error, Timeout

#: frames kept per Simulator (the newest; about 150 bytes each)
FRAME_CAPACITY = 200_000

#: how far before a capture's start a frame's timestamp may lie and still
#: count as after it (a frame in flight when the capture began is kept out)
_START_SLACK_S = 0.0005


class Frame(NamedTuple):
    """One frame as heard: wall-clock time, bus, CAN-ID, flags, data (none
    for a remote frame, whose DLC is ``dlc``)."""

    timestamp: float
    channel: str
    can_id: int
    extended: bool
    rtr: bool
    data: bytes
    dlc: int

    def message(self) -> Any:
        """As a python-can ``Message``."""
        from can.message import Message
        return Message(timestamp=self.timestamp, arbitration_id=self.can_id, is_extended_id=self.extended,
                       is_remote_frame=self.rtr, dlc=self.dlc, data=None if self.rtr else self.data,
                       channel=self.channel)


def frame_of_message(msg: Any, channel: Optional[str] = None) -> Frame:
    rtr = bool(msg.is_remote_frame)
    return Frame(float(msg.timestamp), str(channel if channel is not None else msg.channel or ""),
                 int(msg.arbitration_id), bool(msg.is_extended_id), rtr,
                 b"" if rtr else bytes(msg.data[:msg.dlc]), int(msg.dlc))


# ---------------------------------------------------------------- candump -L

def candump_line(f: Frame) -> str:
    """``(1700000000.123456) vcan0 190#0000C84000``: candump -L, canplayer's
    input (a remote frame ``711#R``, with its DLC when not 0: ``711#R1``),
    as ``cansimctl capture`` writes it."""
    ident = f"{f.can_id:08X}" if f.extended else f"{f.can_id:03X}"
    body = ("R" + (str(min(f.dlc, 8)) if f.dlc else "")) if f.rtr else f.data.hex().upper()
    us = round(f.timestamp * 1e6)
    return f"({us // 1000000}.{us % 1000000:06d}) {f.channel} {ident}#{body}"


_CAN_ERR_FLAG = 0x20000000


class NotReplayed(ValueError):
    """A well-formed line of a frame that is not replayed: an error frame, a CAN FD frame."""


def parse_candump_line(line: str, where: str = "") -> Optional[Frame]:
    """A candump -L line as a Frame; None for a blank or comment line;
    NotReplayed for an error or CAN FD frame; ValueError naming ``where``
    for anything else."""
    text = line.strip()
    if not text or text.startswith("#"):
        return None
    prefix = f"{where}: " if where else ""
    try:
        words = text.split()
        if len(words) < 3:
            raise ValueError("expected (SECONDS.MICROSECONDS) INTERFACE ID#DATA")
        stamp, channel, frame = words[:3]
        if not (len(stamp) > 2 and stamp.startswith("(") and stamp.endswith(")")):
            raise ValueError("expected (SECONDS.MICROSECONDS) INTERFACE ID#DATA")
        ident, sep, body = frame.partition("#")
        if not sep or len(ident) not in (3, 8):
            raise ValueError("expected ID#DATA with an identifier of 3 or 8 hex digits")
        can_id = int(ident, 16)
        if body.startswith("#"):
            raise NotReplayed(f"{prefix}a CAN FD frame")
        if len(ident) == 8 and can_id & _CAN_ERR_FLAG:
            raise NotReplayed(f"{prefix}an error frame")
        if len(ident) == 3 and can_id > 0x7FF:
            raise ValueError("an 11-bit identifier above 7FF")
        if body[:1] in ("R", "r"):
            dlc = int(body[1:], 16) if len(body) > 1 else 0
            if len(body) > 2 or dlc > 8:
                raise ValueError("expected R or R0..R8 for a remote frame")
            return Frame(float(stamp[1:-1]), channel, can_id & 0x1FFFFFFF, len(ident) == 8, True, b"", dlc)
        if len(body) % 2 or len(body) > 16:
            raise ValueError("expected 0 to 8 data bytes as pairs of hex digits")
        data = bytes.fromhex(body)
        return Frame(float(stamp[1:-1]), channel, can_id & 0x1FFFFFFF, len(ident) == 8, False, data, len(data))
    except NotReplayed:
        raise
    except ValueError as e:
        raise ValueError(f"{prefix}{e}: {text[:80]!r}") from None


def write_candump(path: Union[str, "os.PathLike[str]"], frames: Iterable[Frame]) -> int:
    """Writes the frames as a candump -L log; returns how many."""
    n = 0
    with open(path, "w", encoding="ascii") as f:
        for frame in frames:
            f.write(candump_line(frame) + "\n")
            n += 1
    return n


def read_candump(path: Union[str, "os.PathLike[str]"], skipped: Optional[List[str]] = None) -> List[Frame]:
    """The frames of a candump -L log (ValueError naming file:line for a
    bad line); error and CAN FD frames are left out (``skipped`` gets why)."""
    out = []
    with open(path, encoding="ascii", errors="replace") as f:
        for number, line in enumerate(f, 1):
            try:
                frame = parse_candump_line(line, f"{os.fspath(path)}:{number}")
            except NotReplayed as e:
                if skipped is not None:
                    skipped.append(str(e))
                continue
            if frame is not None:
                out.append(frame)
    return out


# ---------------------------------------------------------------- the log

class FrameLog:
    """The frames heard so far (the newest ``capacity``), thread-safe;
    positions count every frame ever appended."""

    def __init__(self, capacity: int = FRAME_CAPACITY) -> None:
        self._frames: Deque[Frame] = deque(maxlen=capacity)
        self._next = 0
        self._cond = threading.Condition()

    @property
    def next_position(self) -> int:
        with self._cond:
            return self._next

    def append(self, frame: Frame) -> None:
        with self._cond:
            self._frames.append(frame)
            self._next += 1
            self._cond.notify_all()

    def _from(self, position: int, stop: Optional[int]) -> List[Frame]:
        first = self._next - len(self._frames)
        start = max(position - first, 0)
        end = len(self._frames) if stop is None else max(min(stop - first, len(self._frames)), 0)
        return [self._frames[i] for i in range(start, end)]

    def window(self, start: int, stop: Optional[int] = None) -> List[Frame]:
        with self._cond:
            return self._from(start, stop)

    def wait(self, start: int, matches: Callable[[int, Frame], bool], deadline: float,
             stop: Optional[int] = None) -> Optional[Tuple[int, Frame]]:
        """The first (position, frame) from ``start`` that matches, waiting
        until ``deadline`` (time.monotonic()); None on timeout."""
        scanned = start
        with self._cond:
            while True:
                first = self._next - len(self._frames)
                for i, f in enumerate(self._from(scanned, stop)):
                    position = max(scanned, first) + i
                    if matches(position, f):
                        return position, f
                scanned = self._next
                if stop is not None and scanned >= stop:
                    return None
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._cond.wait(remaining)


# ---------------------------------------------------------------- listeners

class BusAddress(NamedTuple):
    """Where one bus of a fleet is: ``transport`` ``"socketcan"`` (a kernel
    interface named ``name``) or ``"socketcand"`` (cansimd's TCP server at
    ``host``:``port``, bus ``name``)."""

    name: str
    transport: str
    host: str = ""
    port: int = 0


class SocketcandClient:
    """A raw-mode socketcand client (the protocol python-can speaks, each
    frame's ID kept standard or extended by its width: 3 or 8 digits; the
    server's answer to ``< echo >`` and its other messages are skipped)."""

    def __init__(self, address: BusAddress, timeout: float = 5.0) -> None:
        self.address = address
        self._buffer = b""
        try:
            self.sock = _socket.create_connection((address.host, address.port), timeout=timeout)
        except OSError as e:
            raise Error(f"cannot connect to socketcand bus {address.name} at {address.host}:{address.port}: {e}") \
                from e
        try:
            self._expect(b"hi")
            self._send(f"< open {address.name} >")
            self._expect(b"ok")
            self._send("< rawmode >")
            self._expect(b"ok")
            # cansimd holds the bus's frames after that < ok > until the client
            # speaks again (python-can reads the answer alone): speak at once.
            self._send("< echo >")
        except BaseException:
            self.sock.close()
            raise
        self.sock.settimeout(None)

    def _send(self, text: str) -> None:
        self.sock.sendall(text.encode("ascii"))

    def _expect(self, word: bytes) -> None:
        deadline = time.monotonic() + 5.0
        while True:
            message = self._next_message()
            if message is not None:
                if message.split()[:1] != [word]:
                    raise Error(f"socketcand bus {self.address.name}: expected < {word.decode()} >, "
                                f"got < {message.decode(errors='replace')[:60]} >")
                return
            if time.monotonic() > deadline or not self._fill(max(deadline - time.monotonic(), 0.01)):
                raise Error(f"socketcand bus {self.address.name}: no < {word.decode()} > from the server")

    def _fill(self, timeout: Optional[float]) -> bool:
        """Reads what is there (up to ``timeout``); False at the end of the stream."""
        ready, _, _ = select.select([self.sock], [], [], timeout)
        if not ready:
            return True
        chunk = self.sock.recv(65536)
        if not chunk:
            return False
        self._buffer += chunk
        if len(self._buffer) > 1 << 20 and b">" not in self._buffer:
            self._buffer = b""  # no message ends in a megabyte: not socketcand
        return True

    def _next_message(self) -> Optional[bytes]:
        start = self._buffer.find(b"<")
        if start < 0:
            self._buffer = b""
            return None
        end = self._buffer.find(b">", start)
        if end < 0:
            self._buffer = self._buffer[start:]
            return None
        message = self._buffer[start + 1:end].strip()
        self._buffer = self._buffer[end + 1:]
        return message

    def messages(self, timeout: Optional[float]) -> Optional[List[bytes]]:
        """The complete messages that arrive within ``timeout``; None when the
        server closed the connection."""
        if not self._fill(timeout):
            return None
        out = []
        while (m := self._next_message()) is not None:
            out.append(m)
        return out

    def frame(self, message: bytes) -> Optional[Frame]:
        """``frame ID SECONDS.MICROS DATA`` (or ``rtr ID SECONDS.MICROS
        DLC``) as a Frame; None for other messages."""
        words = message.split()
        if len(words) < 3 or words[0] not in (b"frame", b"rtr"):
            return None
        try:
            ident = words[1].decode()
            can_id = int(ident, 16)
            rtr = words[0] == b"rtr"
            extended = len(ident) > 3 or can_id > 0x7FF
            if rtr:
                dlc = int(words[3]) if len(words) > 3 else 0
                return Frame(float(words[2]), self.address.name, can_id, extended, True, b"", dlc)
            data = bytes.fromhex(words[3].decode()) if len(words) > 3 else b""
            return Frame(float(words[2]), self.address.name, can_id, extended, False, data, len(data))
        except ValueError:
            return None

    def send(self, f: Frame) -> None:
        """Puts a frame on the bus as a participant (socketcand ``< send >`` / ``< sendrtr >``)."""
        ident = f"{f.can_id:08X}" if f.extended else f"{f.can_id:03X}"
        if f.rtr:
            self._send(f"< sendrtr {ident} {f.dlc} >")
            return
        data = " ".join(f"{b:02X}" for b in f.data)
        self._send(f"< send {ident} {len(f.data)} {data} >" if data else f"< send {ident} 0 >")

    def close(self) -> None:
        try:
            self.sock.shutdown(_socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()


class _Listener(threading.Thread):
    """Appends what one bus carries to the log until stopped."""

    def __init__(self, address: BusAddress, log: FrameLog) -> None:
        super().__init__(name=f"cansim-wire-{address.name}", daemon=True)
        self.address = address
        self._log = log
        self._halt = threading.Event()
        self.error: Optional[str] = None
        self._open()

    def _open(self) -> None:
        raise NotImplementedError

    def _read(self, timeout: float) -> Optional[List[Frame]]:
        """The frames that arrive within ``timeout``; None when the bus went away."""
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError

    def run(self) -> None:
        try:
            while not self._halt.is_set():
                frames = self._read(0.1)
                if frames is None:
                    self.error = f"{self.address.name}: the server closed the connection"
                    return
                for f in frames:
                    self._log.append(f)
        except Exception as e:  # OSError, python-can's CanError: the interface went away
            self.error = f"{self.address.name}: {e}"
        finally:
            self._close()

    def _wake(self) -> None:
        """Ends a read in progress early (stop() does not wait for its timeout)."""

    def stop(self) -> None:
        self._halt.set()
        self._wake()
        self.join(2.0)


class _SocketcandListener(_Listener):
    def _open(self) -> None:
        self._client = SocketcandClient(self.address)

    def _read(self, timeout: float) -> Optional[List[Frame]]:
        messages = self._client.messages(timeout)
        if messages is None:
            return None
        return [f for f in map(self._client.frame, messages) if f is not None]

    def _wake(self) -> None:
        try:
            self._client.sock.shutdown(_socket.SHUT_RDWR)  # the read returns at once: the end of the stream
        except OSError:
            pass

    def _close(self) -> None:
        self._client.close()


class _SocketcanListener(_Listener):
    def _open(self) -> None:
        self._bus = open_python_can_bus(self.address)

    def _read(self, timeout: float) -> Optional[List[Frame]]:
        msg = self._bus.recv(timeout)
        return [frame_of_message(msg, self.address.name)] if msg is not None else []

    def _close(self) -> None:
        self._bus.shutdown()


def open_python_can_bus(address: BusAddress, **kwargs: Any) -> Any:
    """A python-can bus on one of the fleet's buses (python3-can)."""
    try:
        from can.interface import Bus
    except ImportError as e:
        raise Error("the wire needs python-can (Debian: python3-can)") from e
    make: Callable[..., Any] = Bus  # python-can's factory (its type is the abstract BusABC)
    if address.transport == "socketcand":
        return make(interface="socketcand", host=address.host, port=address.port, channel=address.name, **kwargs)
    return make(interface="socketcan", channel=address.name, **kwargs)


class Wire:
    """What a fleet's buses carry, heard by one listener per bus (opened on
    first use, closed with the Simulator)."""

    def __init__(self) -> None:
        self.log = FrameLog()
        self._listeners: Dict[str, _Listener] = {}
        self._lock = threading.Lock()

    def listen(self, addresses: Sequence[BusAddress]) -> None:
        """Listens on each bus not yet listened on; returns once each
        listener hears the bus (a frame sent after this is in the log)."""
        with self._lock:
            for a in addresses:
                current = self._listeners.get(a.name)
                if current is not None and current.address == a and current.is_alive():
                    continue
                if current is not None:
                    current.stop()
                listener: _Listener = (_SocketcandListener if a.transport == "socketcand" else _SocketcanListener)(a, self.log)
                listener.start()
                self._listeners[a.name] = listener

    def errors(self) -> List[str]:
        return [lis.error for lis in self._listeners.values() if lis.error]

    def close(self) -> None:
        with self._lock:
            for listener in self._listeners.values():
                listener.stop()
            self._listeners.clear()


# ---------------------------------------------------------------- captures

FrameMatch = Callable[[Frame], bool]


class Capture:
    """The frames on the fleet's buses from a starting point on (a ``Mark``
    for frames): ``sim.capture()``. A context manager: leaving the block
    stops it (the frames stay). ``frames`` are python-can ``Message``s with
    wall-clock timestamps and the bus as ``channel``."""

    def __init__(self, wire: Wire, start_position: int, start_time: float, mark: Any,
                 buses: Optional[Sequence[str]] = None) -> None:
        self._wire = wire
        self.start_position = start_position
        #: wall-clock time the capture began (seconds since the Unix epoch)
        self.start_time = start_time
        #: the event stream's Mark taken at the same point (``since=capture`` works too)
        self.mark = mark
        self.buses = list(buses) if buses else None
        self._stop: Optional[int] = None
        self.stop_time: Optional[float] = None

    def _admits(self, f: Frame) -> bool:
        return f.timestamp >= self.start_time - _START_SLACK_S and (self.buses is None or f.channel in self.buses)

    def raw(self) -> List[Frame]:
        """The frames as plain :class:`Frame` tuples (cheaper than ``frames``)."""
        return [f for f in self._wire.log.window(self.start_position, self._stop) if self._admits(f)]

    @property
    def frames(self) -> List[Any]:
        """The frames so far, as python-can ``Message``s."""
        return [f.message() for f in self.raw()]

    def __iter__(self) -> Iterator[Any]:
        return iter(self.frames)

    def __len__(self) -> int:
        return len(self.raw())

    def stop(self) -> None:
        """Frames after this are not in the capture."""
        if self._stop is None:
            self._stop = self._wire.log.next_position
            self.stop_time = time.time()

    def __enter__(self) -> "Capture":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def wait_for(self, can_id: Optional[int] = None, *, timeout: float = 2.0, since: Any = None,
                 channel: Optional[str] = None, where: Optional[Callable[[Any], bool]] = None) -> Any:
        """The first frame of the capture (after ``since``: a Message, or a
        wall-clock time) with ``can_id`` on ``channel`` for which ``where``
        (a test of the Message) is true, waiting up to ``timeout`` seconds;
        cansim.Timeout listing the last frames seen."""
        after = float(since.timestamp) if hasattr(since, "timestamp") else (float(since) if since is not None else None)

        def matches(_: int, f: Frame) -> bool:
            if not self._admits(f) or (can_id is not None and f.can_id != can_id):
                return False
            if channel is not None and f.channel != channel:
                return False
            if after is not None and (f.timestamp < after or (hasattr(since, "timestamp") and _same(f, since))):
                return False
            return where is None or bool(where(f.message()))

        found = self._wire.log.wait(self.start_position, matches, time.monotonic() + _checks.seconds("timeout", timeout),
                                    self._stop)
        if found is not None:
            return found[1].message()
        seen = self.raw()
        wanted = f"0x{can_id:03X}" if can_id is not None else "any ID"
        lines = "\n".join(f"  {candump_line(f)}" for f in seen[-15:]) or "  (none)"
        errors = "".join(f"\n  ({e})" for e in self._wire.errors())
        raise Timeout(f"no frame {wanted}{' on ' + channel if channel else ''} within {timeout} s; "
                      f"{len(seen)} frame(s) in the capture, the last:\n{lines}{errors}", seen)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> int:
        """Writes the capture as a candump -L log (what ``cansimctl capture``
        writes, canplayer and ``can.LogReader`` read); returns the frame count."""
        return write_candump(path, self.raw())

    def __repr__(self) -> str:
        return f"<Capture {len(self)} frame(s) since {self.start_time:.6f}>"


def _same(f: Frame, msg: Any) -> bool:
    return bool(f.timestamp == float(msg.timestamp) and f.can_id == msg.arbitration_id and f.data == bytes(msg.data))
