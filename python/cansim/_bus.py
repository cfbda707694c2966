"""One D-Bus connection to cansimd (jeepney, a receiver thread).

The receiver thread reads the socket all the time: method replies go to the
waiting caller, signals to a sink. So a bench that sleeps while the fleet
runs never lets cansimd's queue for it grow, and waiting for an event needs
no main loop.
"""

from __future__ import annotations

import concurrent.futures
from concurrent.futures import Future
import os
import socket as _socket
import struct
import time
from typing import Any, Callable, Dict, List, NamedTuple, Optional, Tuple

from jeepney import DBusAddress, MatchRule, Message, MessageType, new_method_call
from jeepney.bus_messages import message_bus
from jeepney.io.common import RouterClosed
from jeepney.io.threading import DBusConnection, DBusRouter, ReceiveStopped, open_dbus_connection
from jeepney.low_level import HeaderFields

from ._checks import optional_seconds
from .errors import Error, NoSuchNode, Refused, Timeout

BUS_NAME = "io.cansim.Cansimd1"
ROOT_PATH = "/io/cansim/Cansimd1"
NODE_PATH = ROOT_PATH + "/node"
FLEET_IFACE = "io.cansim.Fleet1"
NODE_IFACE = "io.cansim.Node1"
PROPS_IFACE = "org.freedesktop.DBus.Properties"
OBJECT_MANAGER_IFACE = "org.freedesktop.DBus.ObjectManager"

#: D-Bus errors that mean "this node does not exist (any more)"
_GONE = {"io.cansim.Error.UnknownNode", "org.freedesktop.DBus.Error.UnknownObject"}

#: default seconds to wait for a reply (the daemon answers between two loop
#: passes: milliseconds; AddNodes of a big fragment or Reload take longer)
CALL_TIMEOUT = 30.0


def default_socket_paths() -> List[str]:
    """Where cansimd puts its private control socket by default, in the
    order cansimctl tries them."""
    paths = []
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime:
        paths.append(os.path.join(runtime, "cansimd", "control"))
    paths.append("/run/cansimd/control")
    paths.append(f"/tmp/cansimd-{os.geteuid()}/control")
    return paths


def _is_socket(path: str) -> bool:
    try:
        import stat
        return stat.S_ISSOCK(os.stat(path).st_mode)
    except OSError:
        return False


class Address(NamedTuple):
    """Where a cansimd's control API is: jeepney's address, words for
    messages, the private socket's path (None on a bus)."""

    jeepney: str
    description: str
    socket: Optional[str]

    @property
    def is_bus(self) -> bool:
        return self.socket is None


def choose_address(socket: Optional[str], bus: Optional[str]) -> Address:
    """In cansimctl's order: an explicit socket or bus,
    $CANSIM_CONTROL_SOCKET, the default socket paths, then the system bus
    as root, else the user bus."""
    if socket is not None and bus is not None:
        raise ValueError("give socket or bus, not both")
    if bus is not None:
        if bus not in ("system", "user"):
            raise ValueError(f"bus must be 'system' or 'user', got {bus!r}")
        return Address("SYSTEM" if bus == "system" else "SESSION", f"the {bus} bus", None)
    if socket is None:
        socket = os.environ.get("CANSIM_CONTROL_SOCKET") or None
    if socket is None:
        socket = next((p for p in default_socket_paths() if _is_socket(p)), None)
    if socket is not None:
        return Address(f"unix:path={_escape_address(socket)}", f"the control socket {socket}", socket)
    if os.geteuid() == 0:
        return Address("SYSTEM", "the system bus", None)
    return Address("SESSION", "the user bus", None)


def _escape_address(path: str) -> str:
    plain = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_/.\\*")
    return "".join(c if c in plain else "".join(f"%{b:02x}" for b in c.encode()) for c in path)


def unwrap(variant: Tuple[str, Any]) -> Any:
    """A D-Bus variant, as jeepney gives it (signature, value), as its value
    (``ay`` as bytes)."""
    signature, value = variant
    return bytes(value) if signature == "ay" else value


class _SendTimeout(TimeoutError):
    """The call did not fit into the socket in time (cansimd reads nothing)."""


class _Router(DBusRouter):  # type: ignore[misc]
    """jeepney's router, with signals handed to a callback and a quiet end
    when cansimd closes the connection."""

    def __init__(self, conn: DBusConnection, on_signal: Callable[[Message], None],
                 on_close: Callable[[], None]) -> None:
        self._on_signal = on_signal
        self._on_close = on_close
        super().__init__(conn)

    # Both run in the receiver thread.
    def _dispatch(self, msg: Message) -> None:
        if self._replies.dispatch(msg):
            return
        if msg.header.message_type is MessageType.signal:
            try:
                self._on_signal(msg)
            except Exception:  # a malformed signal must not stop the receiver
                pass

    def call(self, msg: Message, timeout: Optional[float]) -> Message:
        """send_and_get_reply, with ``timeout`` over every step: the
        message packed before anything is sent (a value that does not fit
        its type raises ValueError), the send lock, sending (a daemon that
        stopped reading fills the socket: sendall blocked past any bound),
        then the reply. A send cut short leaves half a message on the
        stream: the connection is closed, Timeout raised."""
        deadline = None if timeout is None else time.monotonic() + timeout
        if not self._rcv_thread.is_alive():
            raise RouterClosed("the receiver stopped")
        serial = next(self.conn.outgoing_serial)
        try:
            data = msg.serialise(serial=serial)
        except (struct.error, OverflowError, TypeError, ValueError) as e:
            member = msg.header.fields.get(HeaderFields.member)
            raise ValueError(f"{member}: an argument does not fit its D-Bus type: {e}") from None
        # As ReplyMatcher.catch(), which fails with KeyError when the
        # receiver dropped every future (the connection ended) meanwhile.
        futures = self._replies._futures
        reply: Future[Message] = Future()
        futures[serial] = reply
        try:
            if self._send(data, deadline):
                return reply.result(timeout=_remaining(deadline))
        finally:
            futures.pop(serial, None)
        try:
            self.conn.sock.shutdown(_socket.SHUT_RDWR)  # the receiver sees the end and reports it
        except OSError:
            pass
        raise _SendTimeout()

    def _send(self, data: bytes, deadline: Optional[float]) -> bool:
        """False when the time ran out while sending (part of it may be out)."""
        sock = self.conn.sock
        if not self.conn.send_lock.acquire(timeout=-1 if deadline is None else _remaining(deadline)):
            raise TimeoutError("another call is still sending")
        try:
            # (a timeout of 0 would make the socket non-blocking: BlockingIOError)
            sock.settimeout(None if deadline is None else max(_remaining(deadline) or 0.0, 0.001))
            try:
                sock.sendall(data)
                return True
            except (_socket.timeout, BlockingIOError):
                return False
            finally:
                sock.settimeout(None)
        finally:
            self.conn.send_lock.release()

    def _receiver(self) -> None:
        try:
            while True:
                self._dispatch(self.conn.receive())
        except ReceiveStopped:
            pass
        except Exception:  # cansimd closed the connection or exited
            self._on_close()
        finally:
            self._replies.drop_all()


class Connection:
    """A connection to one cansimd, with a receiver thread."""

    def __init__(self, address: Address, *, on_signal: Callable[[Message], None],
                 on_close: Callable[[], None]) -> None:
        self.description = address.description
        try:
            self._conn: DBusConnection = open_dbus_connection(address.jeepney, auth_timeout=5.0)
        except (OSError, ValueError, RuntimeError, TimeoutError, KeyError) as e:
            raise Error(f"cannot connect to cansimd on {address.description}: {e}") from e
        self._closed = False
        self._router = _Router(self._conn, on_signal, on_close)
        self._destination = BUS_NAME
        if address.is_bus:
            # On a bus, cansimd's signals reach this connection through a
            # match rule (on the private socket, Subscribe alone does it).
            rule = MatchRule(type="signal", sender=BUS_NAME, path_namespace=ROOT_PATH)
            self.call(message_bus.AddMatch(rule))

    def call(self, msg: Message, timeout: Optional[float] = CALL_TIMEOUT) -> Tuple[Any, ...]:
        timeout = optional_seconds("timeout", timeout)
        try:
            reply = self._router.call(msg, timeout)
        except ValueError:
            raise
        except _SendTimeout as e:
            raise Timeout(f"cansimd took no {msg.header.fields.get(HeaderFields.member)} call within {timeout} s "
                          f"(it reads nothing: stopped?); the connection to it is closed") from e
        except (TimeoutError, concurrent.futures.TimeoutError) as e:
            raise Timeout(f"cansimd did not answer {msg.header.fields.get(HeaderFields.member)} "
                          f"within {timeout} s") from e
        except Exception as e:  # RouterClosed, OSError: the connection is gone
            raise Error(f"lost the connection to cansimd on {self.description}: {e}") from e
        if reply.header.message_type is MessageType.error:
            name = reply.header.fields.get(HeaderFields.error_name, "")
            text = reply.body[0] if reply.body and isinstance(reply.body[0], str) else ""
            if name in _GONE:
                raise NoSuchNode(name, text)
            if name == "org.freedesktop.DBus.Error.NoReply" and self._closed:
                raise Error(f"lost the connection to cansimd on {self.description}")
            raise Refused(name, text)
        return tuple(reply.body)

    def method(self, path: str, interface: str, member: str, signature: Optional[str] = None,
               body: Tuple[Any, ...] = (), timeout: Optional[float] = CALL_TIMEOUT) -> Tuple[Any, ...]:
        addr = DBusAddress(path, bus_name=self._destination, interface=interface)
        return self.call(new_method_call(addr, member, signature, body), timeout)

    def get(self, path: str, interface: str, name: str) -> Any:
        return unwrap(self.method(path, PROPS_IFACE, "Get", "ss", (interface, name))[0])

    def get_all(self, path: str, interface: str) -> Dict[str, Any]:
        props = self.method(path, PROPS_IFACE, "GetAll", "s", (interface,))[0]
        return {k: unwrap(v) for k, v in props.items()}

    def managed_objects(self) -> Dict[str, Dict[str, Any]]:
        """Every node object's io.cansim.Node1 properties, in one call."""
        objects = self.method(ROOT_PATH, OBJECT_MANAGER_IFACE, "GetManagedObjects")[0]
        out = {}
        for path, interfaces in objects.items():
            props = interfaces.get(NODE_IFACE)
            if props is not None:
                out[path] = {k: unwrap(v) for k, v in props.items()}
        return out

    def alive(self) -> bool:
        return not self._closed and self._router._rcv_thread.is_alive()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._router.close()
        finally:
            try:
                self._conn.sock.shutdown(_socket.SHUT_RDWR)
            except OSError:
                pass
            self._conn.close()


def _remaining(deadline: Optional[float]) -> Optional[float]:
    """Seconds left until ``deadline`` (None: no bound), never below 0."""
    return None if deadline is None else max(0.0, deadline - time.monotonic())


class ClockOffset(NamedTuple):
    """cansimd's simulated time minus this host's CLOCK_MONOTONIC (µs), and
    how far it may be off (s): half the round trip it was read in."""
    offset_us: float
    error_s: float


def round_trip_offset(conn: Connection, samples: int = 8, tight: float = 0.0005) -> Optional[ClockOffset]:
    """The clock offset from the tightest of up to `samples` SimulatedTime
    reads, the first within `tight` seconds ending the search (None when it
    cannot be read). Simulated time is CLOCK_MONOTONIC counted from
    cansimd's start, so the offset is constant for a local daemon; the read
    happened within the round trip, so the midpoint is off by at most half."""
    best: Optional[ClockOffset] = None
    for _ in range(samples):
        t0 = time.monotonic()
        sim = conn.get(ROOT_PATH, FLEET_IFACE, "SimulatedTime")
        t1 = time.monotonic()
        if not isinstance(sim, int):
            return None
        sample = ClockOffset(sim - (t0 + t1) / 2 * 1e6, (t1 - t0) / 2)
        if best is None or sample.error_s < best.error_s:
            best = sample
        if best.error_s * 2 <= tight:
            break
    return best
