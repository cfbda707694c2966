"""Helpers for cansimd integration tests on real SocketCAN (vcan).

Tests are plain python3 scripts registered in tests/integration/CMakeLists.txt
and run by ctest (label "integration"), natively when the host kernel has vcan
or inside the test VM (scripts/vm/run). They get:

  --cansimd PATH      the built daemon (empty when the target does not exist)
  --source-dir DIR    the repository
  --binary-dir DIR    the CMake build directory

and the same in the environment (CANSIMD, CANSIM_SOURCE_DIR, CANSIM_BINARY_DIR).

A test looks like:

    import cansim_it as it

    def test(ctx):
        d = ctx.start_daemon("--profile", ctx.source("profiles/x.yaml"),
                             "--interface", "vcan0", "--node-id", "5")
        with it.open_bus("vcan0") as bus:
            it.expect(bus, it.is_bootup(5), 10, "boot-up of node 5")
            ...
        assert d.stop() == 0

    it.main(test)

Everything is written by hand on python-can's raw Bus: no 'canopen' package.
Time windows are generous and scaled by it.SCALE (5x inside the VM, where
CPU-bound code runs 50-100x slower and timer granularity is a few ms;
override with CANSIM_IT_TIME_SCALE).

Exit codes: 0 pass, 1 fail, 77 skip (ctest SKIP_RETURN_CODE).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import threading
import traceback
from typing import IO, Callable, Iterable, List, Optional, Sequence

import can

SKIP_CODE = 77
IN_VM = os.environ.get("CANSIM_IN_VM") == "1"
SCALE = float(os.environ.get("CANSIM_IT_TIME_SCALE", "5" if IN_VM else "1"))


def scaled(seconds: float) -> float:
    """A time window scaled for slow environments (the VM)."""
    return seconds * SCALE


# --------------------------------------------------------------------------
# outcome helpers

class Skip(Exception):
    """Raise (or call skip()) to end the test as skipped (exit 77)."""


def stop_process(proc: subprocess.Popen, reader: threading.Thread, err: IO[str]) -> int:
    """SIGTERM a background tool (SIGKILL when it has not exited 5 s later,
    scaled), join the thread reading its stdout and close its stderr file;
    returns its exit status."""
    if proc.poll() is None:
        proc.terminate()
    try:
        rc = proc.wait(scaled(5))
    except subprocess.TimeoutExpired:
        proc.kill()
        rc = proc.wait()
    reader.join(2)
    err.close()
    return rc


def skip(reason: str) -> None:
    raise Skip(reason)


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


# --------------------------------------------------------------------------
# interfaces and the bus

def iface_exists(name: str) -> bool:
    return os.path.isdir(f"/sys/class/net/{name}")


def require_iface(name: str) -> None:
    if not iface_exists(name):
        raise AssertionError(
            f"CAN interface {name} does not exist (run natively with "
            f"scripts/has-vcan --up, or inside scripts/vm/run)")


def open_bus(channel: str = "vcan0", receive_own_messages: bool = False,
             can_filters: Optional[list] = None) -> can.BusABC:
    """A raw SocketCAN bus. Use as a context manager so it is shut down."""
    require_iface(channel)
    return can.Bus(interface="socketcan", channel=channel,
                   receive_own_messages=receive_own_messages,
                   can_filters=can_filters)


def frame(can_id: int, data: Sequence[int] | bytes = b"", rtr: bool = False,
          dlc: Optional[int] = None) -> can.Message:
    data = bytes(data)
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=can_id > 0x7FF,
                       is_remote_frame=rtr, dlc=dlc if dlc is not None else len(data))


def send(bus: can.BusABC, can_id: int, data: Sequence[int] | bytes = b"",
         rtr: bool = False, dlc: Optional[int] = None) -> None:
    bus.send(frame(can_id, data, rtr, dlc))


def drain(bus: can.BusABC) -> int:
    """Throw away frames already queued; returns how many."""
    n = 0
    while bus.recv(timeout=0) is not None:
        n += 1
    return n


Predicate = Callable[[can.Message], bool]


def wait_for(bus: can.BusABC, pred: Predicate, timeout: float) -> Optional[can.Message]:
    """First frame matching pred within timeout seconds (unscaled), else None.
    Frames that do not match are consumed."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return None
        msg = bus.recv(timeout=min(left, 0.5))
        if msg is not None and not msg.is_error_frame and pred(msg):
            return msg


def expect(bus: can.BusABC, pred: Predicate, timeout: float, what: str) -> can.Message:
    """Like wait_for, but timeout is scaled and a miss fails the test."""
    msg = wait_for(bus, pred, scaled(timeout))
    if msg is None:
        raise AssertionError(f"timed out after {scaled(timeout):.1f}s waiting for {what}")
    return msg


def expect_none(bus: can.BusABC, pred: Predicate, duration: float, what: str) -> None:
    """Fail if a matching frame arrives within duration seconds (unscaled:
    silence checks get no longer in the VM)."""
    msg = wait_for(bus, pred, duration)
    if msg is not None:
        raise AssertionError(f"unexpected {what}: {fmt(msg)}")


def collect(bus: can.BusABC, duration: float, pred: Optional[Predicate] = None) -> List[can.Message]:
    """All frames (matching pred) received during duration seconds (unscaled)."""
    out = []
    deadline = time.monotonic() + duration
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return out
        msg = bus.recv(timeout=min(left, 0.5))
        if msg is not None and not msg.is_error_frame and (pred is None or pred(msg)):
            out.append(msg)


def wire_bits(can_id: int, data: bytes) -> int:
    """Bits of a classic 11-bit data frame on the wire: SOF to CRC stuffed,
    CRC delimiter, ACK, EOF, 3 bits of intermission (src/io/wire_bits.hpp),
    computed bit by bit."""
    bits = [0] + [(can_id >> (10 - i)) & 1 for i in range(11)] + [0, 0, 0]
    bits += [(len(data) >> (3 - i)) & 1 for i in range(4)]
    for byte in data:
        bits += [(byte >> (7 - i)) & 1 for i in range(8)]
    crc = 0
    for b in bits:
        nxt = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    bits += [(crc >> (14 - i)) & 1 for i in range(15)]
    stuffed, last, run = 0, None, 0
    for b in bits:
        run = run + 1 if b == last else 1
        last = b
        if run == 5:
            stuffed, last, run = stuffed + 1, 1 - b, 1
    return len(bits) + stuffed + 1 + 2 + 7 + 3


def fmt(msg: can.Message) -> str:
    if msg.is_remote_frame:
        return f"{msg.arbitration_id:03X}#R{msg.dlc}"
    return f"{msg.arbitration_id:03X}#{msg.data.hex().upper()}"


# predicates -----------------------------------------------------------------

def has_id(can_id: int) -> Predicate:
    return lambda m: m.arbitration_id == can_id and not m.is_remote_frame


def is_bootup(node: int) -> Predicate:
    return lambda m: m.arbitration_id == 0x700 + node and bytes(m.data) == b"\x00"


def is_heartbeat(node: int, state: Optional[int] = None) -> Predicate:
    def p(m: can.Message) -> bool:
        return (m.arbitration_id == 0x700 + node and not m.is_remote_frame and len(m.data) == 1
                and (state is None or (m.data[0] & 0x7F) == state))
    return p


def is_emcy(node: int) -> Predicate:
    return lambda m: m.arbitration_id == 0x80 + node and len(m.data) == 8


def is_tpdo(node: int, n: int = 1) -> Predicate:
    """TPDO n (1..4) with the default COB-ID 0x180/0x280/0x380/0x480 + node."""
    return has_id(0x80 + 0x100 * n + node)


# --------------------------------------------------------------------------
# CANopen: NMT, heartbeat states, EMCY, LSS

NMT_START = 0x01
NMT_STOP = 0x02
NMT_PRE_OPERATIONAL = 0x80
NMT_RESET_NODE = 0x81
NMT_RESET_COMMUNICATION = 0x82

STATE_BOOTUP = 0x00
STATE_STOPPED = 0x04
STATE_OPERATIONAL = 0x05
STATE_PRE_OPERATIONAL = 0x7F
STATE_NAMES = {0x00: "boot-up", 0x04: "stopped", 0x05: "operational", 0x7F: "pre-operational"}


def nmt(bus: can.BusABC, command: int, node: int = 0) -> None:
    """Send an NMT command (node 0 = all nodes)."""
    send(bus, 0x000, [command, node])


def emcy_fields(msg: can.Message) -> tuple:
    """(error code, error register, 5 manufacturer bytes) of an EMCY frame."""
    code, reg = struct.unpack_from("<HB", bytes(msg.data))
    return code, reg, bytes(msg.data[3:8])


LSS_TX = 0x7E5  # master -> slaves
LSS_RX = 0x7E4  # slave -> master


def lss(bus: can.BusABC, cs: int, payload: Sequence[int] | bytes = b"") -> None:
    """Send an LSS request (command specifier + up to 7 bytes, zero-padded)."""
    data = bytes([cs]) + bytes(payload)
    send(bus, LSS_TX, data.ljust(8, b"\x00"))


def lss_expect(bus: can.BusABC, cs: int, timeout: float = 2.0) -> can.Message:
    return expect(bus, lambda m: m.arbitration_id == LSS_RX and len(m.data) >= 1 and m.data[0] == cs,
                  timeout, f"LSS reply 0x{cs:02X}")


# --------------------------------------------------------------------------
# SDO client (expedited and segmented), by hand

class SdoAbort(AssertionError):
    def __init__(self, index: int, sub: int, code: int):
        super().__init__(f"SDO abort 0x{code:08X} on 0x{index:04X}:{sub}")
        self.index, self.sub, self.code = index, sub, code


class SdoError(AssertionError):
    pass


class SdoClient:
    """SDO client for one node. Timeouts are per response and scaled.

        sdo = SdoClient(bus, 5)
        raw = sdo.upload(0x1018, 1)            # bytes
        v = sdo.upload_u32(0x1018, 1)
        sdo.download(0x1017, 0, struct.pack("<H", 100))
        sdo.download_u16(0x1017, 0, 100)
        code = sdo.abort_code_of(lambda: sdo.download(0x1000, 0, b"\\0\\0\\0\\0"))
    """

    def __init__(self, bus: can.BusABC, node: int, timeout: float = 2.0,
                 tx_cob: Optional[int] = None, rx_cob: Optional[int] = None):
        self.bus = bus
        self.node = node
        self.timeout = timeout
        self.tx = tx_cob if tx_cob is not None else 0x600 + node  # client -> server
        self.rx = rx_cob if rx_cob is not None else 0x580 + node  # server -> client

    # -- plumbing
    def _send(self, data: bytes) -> None:
        send(self.bus, self.tx, data.ljust(8, b"\x00"))

    def _recv(self, index: int, sub: int) -> bytes:
        msg = wait_for(self.bus, lambda m: m.arbitration_id == self.rx and not m.is_remote_frame,
                       scaled(self.timeout))
        if msg is None:
            self.abort(index, sub, 0x05040000)
            raise SdoError(f"SDO timeout on 0x{index:04X}:{sub} (node {self.node})")
        data = bytes(msg.data)
        if len(data) != 8:
            raise SdoError(f"SDO response with DLC {len(data)}: {fmt(msg)}")
        if data[0] == 0x80:
            code = struct.unpack_from("<I", data, 4)[0]
            raise SdoAbort(index, sub, code)
        return data

    def _check_mux(self, data: bytes, index: int, sub: int) -> None:
        i, s = struct.unpack_from("<HB", data, 1)
        if (i, s) != (index, sub):
            raise SdoError(f"SDO response for 0x{i:04X}:{s}, expected 0x{index:04X}:{sub}")

    def abort(self, index: int, sub: int, code: int) -> None:
        self._send(struct.pack("<BHBI", 0x80, index, sub, code))

    # -- upload (read)
    def upload(self, index: int, sub: int = 0) -> bytes:
        drain(self.bus)
        self._send(struct.pack("<BHB", 0x40, index, sub))
        r = self._recv(index, sub)
        if r[0] & 0xE0 != 0x40:
            self.abort(index, sub, 0x05040001)
            raise SdoError(f"bad upload initiate response 0x{r[0]:02X}")
        self._check_mux(r, index, sub)
        e, s, n = r[0] & 0x02, r[0] & 0x01, (r[0] >> 2) & 0x03
        if e:
            return r[4:8 - n] if s else r[4:8]
        size = struct.unpack_from("<I", r, 4)[0] if s else None
        out = bytearray()
        toggle = 0
        while True:
            self._send(bytes([0x60 | (toggle << 4)]))
            r = self._recv(index, sub)
            if r[0] & 0xE0 != 0x00:
                self.abort(index, sub, 0x05040001)
                raise SdoError(f"bad upload segment response 0x{r[0]:02X}")
            if (r[0] >> 4) & 1 != toggle:
                self.abort(index, sub, 0x05030000)
                raise SdoError("upload segment toggle bit not alternated")
            n = (r[0] >> 1) & 0x07
            out += r[1:8 - n]
            if r[0] & 0x01:
                break
            toggle ^= 1
        if size is not None and len(out) != size:
            raise SdoError(f"segmented upload: {len(out)} bytes, size indicated {size}")
        return bytes(out)

    # -- download (write)
    def download(self, index: int, sub: int, data: bytes, force_segmented: bool = False) -> None:
        data = bytes(data)
        drain(self.bus)
        if 0 < len(data) <= 4 and not force_segmented:
            n = 4 - len(data)
            self._send(struct.pack("<BHB", 0x23 | (n << 2), index, sub) + data)
            r = self._recv(index, sub)
            if r[0] != 0x60:
                raise SdoError(f"bad download initiate response 0x{r[0]:02X}")
            self._check_mux(r, index, sub)
            return
        self._send(struct.pack("<BHBI", 0x21, index, sub, len(data)))
        r = self._recv(index, sub)
        if r[0] != 0x60:
            raise SdoError(f"bad download initiate response 0x{r[0]:02X}")
        self._check_mux(r, index, sub)
        toggle = 0
        pos = 0
        while True:
            chunk = data[pos:pos + 7]
            pos += len(chunk)
            last = pos >= len(data)
            cmd = (toggle << 4) | ((7 - len(chunk)) << 1) | (1 if last else 0)
            self._send(bytes([cmd]) + chunk)
            r = self._recv(index, sub)
            if r[0] & 0xE0 != 0x20:
                raise SdoError(f"bad download segment response 0x{r[0]:02X}")
            if (r[0] >> 4) & 1 != toggle:
                self.abort(index, sub, 0x05030000)
                raise SdoError("download segment toggle bit not alternated")
            if last:
                return
            toggle ^= 1

    # -- typed conveniences
    def upload_u8(self, index: int, sub: int = 0) -> int:
        return self._unpack("<B", self.upload(index, sub))

    def upload_u16(self, index: int, sub: int = 0) -> int:
        return self._unpack("<H", self.upload(index, sub))

    def upload_u32(self, index: int, sub: int = 0) -> int:
        return self._unpack("<I", self.upload(index, sub))

    def upload_i16(self, index: int, sub: int = 0) -> int:
        return self._unpack("<h", self.upload(index, sub))

    def upload_i32(self, index: int, sub: int = 0) -> int:
        return self._unpack("<i", self.upload(index, sub))

    def upload_f32(self, index: int, sub: int = 0) -> float:
        return self._unpack("<f", self.upload(index, sub))

    def upload_str(self, index: int, sub: int = 0) -> str:
        return self.upload(index, sub).decode("latin-1")

    def download_u8(self, index: int, sub: int, v: int) -> None:
        self.download(index, sub, struct.pack("<B", v))

    def download_u16(self, index: int, sub: int, v: int) -> None:
        self.download(index, sub, struct.pack("<H", v))

    def download_u32(self, index: int, sub: int, v: int) -> None:
        self.download(index, sub, struct.pack("<I", v))

    def download_i16(self, index: int, sub: int, v: int) -> None:
        self.download(index, sub, struct.pack("<h", v))

    def download_i32(self, index: int, sub: int, v: int) -> None:
        self.download(index, sub, struct.pack("<i", v))

    def download_f32(self, index: int, sub: int, v: float) -> None:
        self.download(index, sub, struct.pack("<f", v))

    @staticmethod
    def _unpack(f: str, raw: bytes):
        if len(raw) != struct.calcsize(f):
            raise SdoError(f"expected {struct.calcsize(f)} bytes, got {raw.hex()}")
        return struct.unpack(f, raw)[0]

    @staticmethod
    def abort_code_of(fn: Callable[[], object]) -> Optional[int]:
        """Run fn; return the SDO abort code it raised, or None if it succeeded."""
        try:
            fn()
        except SdoAbort as a:
            return a.code
        return None


# --------------------------------------------------------------------------
# sd_notify: a stand-in for systemd's notification socket

class NotifySocket:
    """An AF_UNIX SOCK_DGRAM socket that collects sd_notify(3) messages, as
    systemd's NOTIFY_SOCKET does. Give the daemon env=ns.env() (NOTIFY_SOCKET,
    plus WATCHDOG_USEC when watchdog_usec is set). A thread receives each
    datagram and splits it into its assignments:

        with it.NotifySocket(watchdog_usec=2_000_000) as ns:
            d = ctx.start_daemon(..., env=ns.env())
            ns.expect(lambda m: m.get("READY") == "1", 10, "READY=1")

    Every message is a Notification: .fields (dict of NAME -> value),
    .time (time.time() on arrival, comparable with python-can timestamps),
    .mono (time.monotonic() on arrival), .raw (the datagram text).
    """

    class Notification:
        def __init__(self, raw: str):
            self.raw = raw
            self.time = time.time()
            self.mono = time.monotonic()
            self.fields = {}
            for line in raw.split("\n"):
                if "=" in line:
                    k, v = line.split("=", 1)
                    self.fields[k] = v

        def get(self, key: str, default: Optional[str] = None) -> Optional[str]:
            return self.fields.get(key, default)

        def __repr__(self) -> str:
            return repr(self.raw)

    def __init__(self, watchdog_usec: int = 0, path: Optional[str] = None):
        import socket
        import threading
        self._dir = None if path else tempfile.mkdtemp(prefix="cansim-notify-")
        self.path = path or os.path.join(self._dir, "notify.sock")
        self.watchdog_usec = watchdog_usec
        self.messages: List["NotifySocket.Notification"] = []
        self._cond = threading.Condition()
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._sock.bind(self.path)
        self._sock.settimeout(0.2)
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="notify", daemon=True)
        self._thread.start()

    def env(self) -> dict:
        e = {"NOTIFY_SOCKET": self.path}
        if self.watchdog_usec:
            e["WATCHDOG_USEC"] = str(self.watchdog_usec)
        return e

    def _run(self) -> None:
        import socket
        while not self._stop:
            try:
                data = self._sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return
            n = NotifySocket.Notification(data.decode("utf-8", "replace"))
            with self._cond:
                self.messages.append(n)
                self._cond.notify_all()

    def snapshot(self) -> List["NotifySocket.Notification"]:
        with self._cond:
            return list(self.messages)

    def wait_for(self, pred: Callable[["NotifySocket.Notification"], bool], timeout: float,
                 start: int = 0) -> Optional["NotifySocket.Notification"]:
        """The first message at index >= start matching pred within timeout
        seconds (unscaled), else None. Messages stay in .messages."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for m in self.messages[start:]:
                    if pred(m):
                        return m
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self._cond.wait(min(left, 0.5))

    def expect(self, pred: Callable[["NotifySocket.Notification"], bool], timeout: float, what: str,
               start: int = 0) -> "NotifySocket.Notification":
        """Like wait_for, but timeout is scaled and a miss fails the test."""
        m = self.wait_for(pred, scaled(timeout), start)
        if m is None:
            raise AssertionError(f"timed out after {scaled(timeout):.1f}s waiting for {what}; "
                                 f"notifications so far: {self.snapshot()}")
        return m

    def index_of(self, m: "NotifySocket.Notification") -> int:
        with self._cond:
            return next(i for i, x in enumerate(self.messages) if x is m)

    def close(self) -> None:
        self._stop = True
        self._thread.join(2)
        self._sock.close()
        if self._dir:
            shutil.rmtree(self._dir, ignore_errors=True)

    def __enter__(self) -> "NotifySocket":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# --------------------------------------------------------------------------
# the daemon under test

class Daemon:
    """cansimd running in the background with its own state dir and log file.

    args may contain '{state_dir}', replaced by the daemon's state directory.
    The process also gets CANSIM_STATE_DIR=<state dir> in its environment and
    runs with the state dir as its working directory.
    """

    def __init__(self, binary: str, args: Iterable[str], name: str = "cansimd",
                 env: Optional[dict] = None, state_dir: Optional[str] = None):
        self.binary = binary
        self.name = name
        self._own_state = state_dir is None
        self.state_dir = state_dir or tempfile.mkdtemp(prefix=f"cansim-it-{name}-")
        self.args = [a.replace("{state_dir}", self.state_dir) for a in args]
        self.log_path = os.path.join(self.state_dir, f"{name}.log")
        self.env = dict(os.environ)
        self.env["CANSIM_STATE_DIR"] = self.state_dir
        if env:
            self.env.update(env)
        self.proc: Optional[subprocess.Popen] = None
        self.returncode: Optional[int] = None

    def start(self) -> "Daemon":
        if not self.binary or not os.access(self.binary, os.X_OK):
            raise Skip(f"cansimd binary not built ({self.binary or 'no target'})")
        log(f"starting {self.name}: {self.binary} {' '.join(self.args)}")
        self._log = open(self.log_path, "wb")
        self.proc = subprocess.Popen([self.binary, *self.args], stdin=subprocess.DEVNULL,
                                     stdout=self._log, stderr=subprocess.STDOUT,
                                     cwd=self.state_dir, env=self.env)
        return self

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def assert_alive(self) -> None:
        if not self.alive():
            rc = self.proc.returncode if self.proc else None
            raise AssertionError(f"{self.name} exited early with status {rc}")

    def send_signal(self, sig: int) -> None:
        if self.alive():
            self.proc.send_signal(sig)

    def stop(self, timeout: float = 10.0, sig: int = signal.SIGTERM) -> int:
        """Send sig (SIGTERM), wait up to timeout (scaled), SIGKILL after that.
        Returns the exit status (negative: killed by that signal)."""
        if self.proc is None:
            return self.returncode if self.returncode is not None else -1
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(scaled(timeout))
            except subprocess.TimeoutExpired:
                log(f"{self.name} did not exit {scaled(timeout):.0f}s after signal {sig}; SIGKILL")
                self.proc.kill()
                self.proc.wait()
        self.returncode = self.proc.returncode
        self._log.close()
        return self.returncode

    def wait(self, timeout: float) -> Optional[int]:
        """Wait for the daemon to exit by itself; None if still running."""
        try:
            return self.proc.wait(scaled(timeout))
        except subprocess.TimeoutExpired:
            return None

    def log_text(self) -> str:
        try:
            with open(self.log_path, "rb") as f:
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def dump_log(self, out=sys.stderr) -> None:
        print(f"----- {self.name} log ({self.log_path}) -----", file=out)
        print(self.log_text().rstrip(), file=out)
        print(f"----- end of {self.name} log -----", file=out, flush=True)

    def cleanup(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        if self._own_state and os.environ.get("CANSIM_IT_KEEP") != "1":
            shutil.rmtree(self.state_dir, ignore_errors=True)

    def __enter__(self) -> "Daemon":
        return self if self.proc else self.start()

    def __exit__(self, *exc) -> None:
        if exc[0] is not None and exc[0] is not Skip:
            self.dump_log()
        self.stop()


# --------------------------------------------------------------------------
# test entry point

class Context:
    def __init__(self, ns: argparse.Namespace):
        self.cansimd: str = ns.cansimd
        self.source_dir: str = ns.source_dir
        self.binary_dir: str = ns.binary_dir
        self.daemons: List[Daemon] = []
        self._tmp: Optional[str] = None

    @property
    def tmp(self) -> str:
        """A scratch folder for this test (generated profiles, configs)."""
        if self._tmp is None:
            self._tmp = tempfile.mkdtemp(prefix="cansim-it-")
        return self._tmp

    def source(self, *parts: str) -> str:
        return os.path.join(self.source_dir, *parts)

    def require_cansimd(self) -> str:
        if not self.cansimd or not os.access(self.cansimd, os.X_OK):
            raise Skip("cansimd is not built yet")
        return self.cansimd

    def daemon(self, *args: str, name: str = "cansimd", env: Optional[dict] = None) -> Daemon:
        """A Daemon for the built cansimd (not started)."""
        d = Daemon(self.require_cansimd(), args, name=name, env=env)
        self.daemons.append(d)
        return d

    def start_daemon(self, *args: str, name: str = "cansimd", env: Optional[dict] = None) -> Daemon:
        return self.daemon(*args, name=name, env=env).start()


def parse_args(argv: Optional[Sequence[str]] = None) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimd", default=os.environ.get("CANSIMD", ""))
    p.add_argument("--source-dir", default=os.environ.get(
        "CANSIM_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))))
    p.add_argument("--binary-dir", default=os.environ.get("CANSIM_BINARY_DIR", ""))
    return p.parse_args(argv)


PYTEST_EXIT = {0: "all tests passed", 1: "tests failed", 2: "interrupted", 3: "internal error",
               4: "usage error", 5: "no tests collected"}


def run_pytest(ctx: "Context", what: str, *args: str, timeout: float = 30.0) -> None:
    """`python3 -m pytest ARGS` as a user of the checkout runs it (from the
    source folder: profile names resolve to profiles/), with the cansim
    client from python/ and the built cansimd. Every test must run and
    pass: a skip fails, as do pytest's other exit statuses ("no tests
    collected" included). `timeout`: seconds, scaled for the VM."""
    env = dict(os.environ, CANSIMD=ctx.require_cansimd(), PYTHONPATH=ctx.source("python"),
               PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", *args]
    log(f"running {' '.join(cmd)}")
    r = subprocess.run(cmd, cwd=ctx.source_dir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=scaled(timeout))
    print(r.stdout.rstrip(), flush=True)
    status = PYTEST_EXIT.get(r.returncode, "unknown")
    if r.returncode != 0:
        raise AssertionError(f"pytest {what}: exit status {r.returncode} ({status})")
    if " skipped" in r.stdout or " passed" not in r.stdout:
        raise AssertionError(f"pytest {what}: every test must run and pass")
    log(f"{what}: pytest exit status 0 ({status})")


def main(test: Callable[[Context], None], argv: Optional[Sequence[str]] = None) -> None:
    """Run test(ctx); exit 0 pass, 1 fail (daemon logs printed), 77 skip."""
    ctx = Context(parse_args(argv))
    name = os.path.basename(sys.argv[0])
    t0 = time.monotonic()
    code = 0
    try:
        test(ctx)
        for d in ctx.daemons:
            if d.alive():
                rc = d.stop()
                if rc != 0:
                    raise AssertionError(f"{d.name} exited with status {rc} on SIGTERM")
        print(f"PASS {name} ({time.monotonic() - t0:.1f}s)", flush=True)
    except Skip as s:
        print(f"SKIP {name}: {s}", flush=True)
        code = SKIP_CODE
    except BaseException as e:  # noqa: BLE001 - report anything, incl. KeyboardInterrupt
        traceback.print_exc()
        print(f"FAIL {name}: {e}", file=sys.stderr, flush=True)
        for d in ctx.daemons:
            d.stop()
            d.dump_log()
        code = 1
    finally:
        for d in ctx.daemons:
            d.cleanup()
        if ctx._tmp:
            shutil.rmtree(ctx._tmp, ignore_errors=True)
    sys.exit(code)


# --------------------------------------------------------------------------
# device profile tests (test_profile_*.py): one node against a hand-written master

def single_node_daemon(ctx: Context, profile: str, bit_rate: int, name: str,
                       interface: str = "vcan0") -> Daemon:
    """A Daemon (not started) for a fleet of one node of `profile` (a path) on
    `interface` at bit_rate kbit/s; the fleet file lives in its state dir."""
    d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}")
    with open(os.path.join(d.state_dir, "fleet.yaml"), "w") as f:
        f.write(f"interfaces:\n"
                f"  {interface}: {{bit_rate: {bit_rate}}}\n"
                f"nodes:\n"
                f"  - {{profile: {profile}, interface: {interface}, name: {name}}}\n")
    return d


def restart_daemon(ctx: Context, d: Daemon, name: str = "again") -> Daemon:
    """A second daemon with d's arguments and state dir (what d stored), started.
    Stop d first."""
    again = Daemon(ctx.require_cansimd(), d.args, name=name, state_dir=d.state_dir)
    ctx.daemons.append(again)
    return again.start()


def lss_reply(bus: can.BusABC, cs: int, payload: Sequence[int] | bytes = b"",
              timeout: float = 2.0) -> can.Message:
    """Send an LSS request and return the slave's answer with the same command specifier."""
    lss(bus, cs, payload)
    return lss_expect(bus, cs, scaled(timeout))


def sdo_exchange(bus: can.BusABC, node: int, request: Sequence[int] | bytes,
                 what: str = "SDO answer") -> bytes:
    """One SDO request written by hand (zero-padded to 8 bytes) to 0x600 + node;
    returns the data of the answer on 0x580 + node, whatever it is (aborts too)."""
    drain(bus)
    send(bus, 0x600 + node, bytes(request).ljust(8, b"\x00"))
    return bytes(expect(bus, has_id(0x580 + node), scaled(2.0), what).data)


def tpdo_i32(bus: can.BusABC, node: int, seconds: float) -> tuple:
    """TPDO1 frames of node received during seconds (unscaled), each checked to
    carry one INTEGER32 (DLC 4), and their values: (frames, values)."""
    msgs = collect(bus, seconds, has_id(0x180 + node))
    for m in msgs:
        assert m.dlc == 4, fmt(m)
    return msgs, [struct.unpack("<i", bytes(m.data))[0] for m in msgs]


def gaps(msgs: Sequence[can.Message]) -> List[float]:
    """Seconds between consecutive frames (receive timestamps)."""
    return [b.timestamp - a.timestamp for a, b in zip(msgs, msgs[1:])]


def mean_gap(msgs: Sequence[can.Message]) -> float:
    g = gaps(msgs)
    return sum(g) / len(g)


# --------------------------------------------------------------------------
# the runtime control API (D-Bus, docs/control-api.md), with python3-dbus

CONTROL_BUS_NAME = "io.cansim.Cansimd1"
CONTROL_PATH = "/io/cansim/Cansimd1"
FLEET_INTERFACE = "io.cansim.Fleet1"
NODE_INTERFACE = "io.cansim.Node1"
ERROR_NOT_SUPPORTED = "io.cansim.Error.NotSupported"


def pdo_after_call(bus: can.BusABC, node: int, pdo: int, decode: Callable, ok: Callable[[float], bool],
                   what: str):
    """The value of the first TPDO `pdo` of `node` sent after the control call
    just answered for which ok(value) holds. cansimd puts what its nodes sent
    before a call on the wire before it answers, so frames the kernel stamped
    before now are older than the call. The sensors sample at 1 kHz, so one
    PDO within a sample period of the call may still carry the sample before
    it: one such PDO is allowed (the API's bound is one PDO period + 1 ms)."""
    answered = time.time()
    drain(bus)
    is_pdo = is_tpdo(node, pdo)
    first = decode(expect(bus, lambda m: is_pdo(m) and m.timestamp >= answered, 2, what))
    if ok(first):
        return first
    second = decode(expect(bus, is_pdo, 2, what + " (the second)"))
    log(f"{what}: one PDO within a sample of the call still had {first!r}, the next {second!r}")
    assert ok(second), f"{what}: {first!r} then {second!r}"
    return second


def write_control_fleet(ctx: "Context") -> str:
    """The control tests' fleet (two generic-404 "generic" at 0x10/0x11 and a
    DPS "dps" at 0x7F on vcan0, 250 kbit/s) as a fleet file; returns its path."""
    path = os.path.join(ctx.tmp, "fleet.yaml")
    with open(path, "w") as f:
        f.write(f"interfaces:\n"
                f"  vcan0: {{bit_rate: 250}}\n"
                f"nodes:\n"
                f"  - {{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan0, "
                f"node_id: 0x10, count: 2, name: generic}}\n"
                f"  - {{profile: {ctx.source('profiles', 'dps.yaml')}, interface: vcan0, name: dps, "
                f"bit_rate: 250}}\n")
    return path


def control_path_segment(s: str) -> str:
    """One object path segment escaped as sd_bus_path_encode() does: every
    character but [A-Za-z0-9], and a leading digit, becomes _xx (hex)."""
    if not s:
        return "_"
    out = []
    for i, c in enumerate(s):
        if (c.isascii() and c.isalpha()) or (c.isdigit() and c.isascii() and i > 0):
            out.append(c)
        else:
            out.extend(f"_{b:02x}" for b in c.encode())
    return "".join(out)


def control_node_path(interface: str, name: str, index: int) -> str:
    """The object path of the node with fleet key interface/name/index."""
    return "/".join([CONTROL_PATH, "node", control_path_segment(interface),
                     control_path_segment(name), control_path_segment(str(index))])


def dbus_plain(v):
    """A python3-dbus value as plain Python (Struct -> tuple, Array -> list,
    Byte -> int, Boolean -> bool, ...), for readable asserts and messages."""
    import dbus
    if isinstance(v, dbus.Boolean):
        return bool(v)
    if isinstance(v, (dbus.Byte, dbus.Int16, dbus.UInt16, dbus.Int32, dbus.UInt32,
                      dbus.Int64, dbus.UInt64)):
        return int(v)
    if isinstance(v, dbus.Double):
        return float(v)
    if isinstance(v, (dbus.String, dbus.ObjectPath, dbus.Signature)):
        return str(v)
    if isinstance(v, dbus.Struct):
        return tuple(dbus_plain(x) for x in v)
    if isinstance(v, dbus.Dictionary):
        return {dbus_plain(k): dbus_plain(x) for k, x in v.items()}
    if isinstance(v, (dbus.Array, list)):
        return [dbus_plain(x) for x in v]
    if isinstance(v, tuple):
        return tuple(dbus_plain(x) for x in v)
    return v


def dbus_error_of(fn: Callable[[], object]) -> Optional[str]:
    """Run fn; return the D-Bus error name it raised, or None if it succeeded."""
    import dbus
    try:
        fn()
    except dbus.DBusException as e:
        return e.get_dbus_name()
    return None


def expect_dbus_error(fn: Callable[[], object], name: str, what: str) -> str:
    """Run fn, which must fail with the D-Bus error `name`; returns its message."""
    import dbus
    try:
        result = fn()
    except dbus.DBusException as e:
        if e.get_dbus_name() != name:
            raise AssertionError(f"{what}: expected {name}, got {e.get_dbus_name()}: "
                                 f"{e.get_dbus_message()}") from None
        return e.get_dbus_message() or ""
    raise AssertionError(f"{what}: expected {name}, but the call succeeded ({dbus_plain(result)!r})")


def wait_for_path(path: str, timeout: float) -> None:
    """Wait until `path` exists (e.g. the daemon's control socket); timeout
    is scaled, a miss fails the test."""
    deadline = time.monotonic() + scaled(timeout)
    while not os.path.exists(path):
        if time.monotonic() > deadline:
            raise AssertionError(f"{path} did not appear within {scaled(timeout):.1f}s")
        time.sleep(0.05)


class ControlSignal:
    """A D-Bus signal received by a ControlClient: .member, .path,
    .interface, .args (plain Python values), .mono (time.monotonic() when it
    was dispatched), .time (time.time(), comparable with python-can stamps)."""

    def __init__(self, msg):
        self.member = str(msg.get_member())
        self.path = str(msg.get_path())
        self.interface = str(msg.get_interface())
        self.args = [dbus_plain(a) for a in msg.get_args_list()]
        self.mono = time.monotonic()
        self.time = time.time()

    def __repr__(self) -> str:
        return f"{self.member}{tuple(self.args)!r} on {self.path}"


class ControlNode:
    """io.cansim.Node1 of one node object (see ControlClient.node)."""

    def __init__(self, client: "ControlClient", path: str):
        self.client = client
        self.path = path

    def call(self, method: str, signature: str = "", *args):
        return self.client.call(self.path, NODE_INTERFACE, method, signature, *args)

    def get(self, prop: str):
        return self.client.get(self.path, NODE_INTERFACE, prop)

    def read(self, index: int, sub: int = 0):
        """Read (q index, y sub) -> v, as a plain value."""
        return self.call("Read", "qy", index, sub)

    def write(self, index: int, sub: int, value) -> None:
        """Write (q index, y sub, v value). Give value a dbus type
        (dbus.UInt16(200), dbus.Double(1.5), "text", dbus.ByteArray(b"..."))
        to choose the variant's type; a plain int goes as 'i'."""
        self.call("Write", "qyv", index, sub, value)

    def __repr__(self) -> str:
        return f"ControlNode({self.path})"


class ControlClient:
    """A python3-dbus client of cansimd's control API, synchronous.

        c = it.ControlClient.private(socket_path)     # the --control-socket
        c = it.ControlClient.bus(address)             # a bus (name io.cansim.Cansimd1)
        c.subscribe()                                 # the signals (Fleet1.Subscribe)
        nodes = c.fleet("ListNodes")                  # plain Python values
        n = c.node("vcan0/0x10")                      # GetNode -> ControlNode
        n.call("Nmt", "s", "start")
        n.write(0x1017, 0, dbus.UInt16(200))
        s = c.expect_signal("BootUp", 5, path=n.path, what="boot-up")

    Method calls block (timeout scaled); signals are collected while
    pump()/wait_signal() run the GLib main context (they queue in between).
    Errors raise dbus.DBusException; see dbus_error_of / expect_dbus_error.
    """

    def __init__(self, address: str, is_bus: bool = False, timeout: float = 10.0):
        import dbus
        import dbus.bus
        import dbus.connection
        from dbus.mainloop.glib import DBusGMainLoop
        self.address = address
        self.is_bus = is_bus
        self.timeout = scaled(timeout)
        loop = DBusGMainLoop(set_as_default=False)
        if is_bus:
            self.conn = dbus.bus.BusConnection(address, mainloop=loop)
        else:
            self.conn = dbus.connection.Connection(address, mainloop=loop)
        self.signals: List[ControlSignal] = []
        self.conn.add_message_filter(self._filter)
        if is_bus:  # a bus delivers only signals someone asked for
            self.conn.add_match_string_non_blocking(f"type='signal',sender='{CONTROL_BUS_NAME}'")

    @classmethod
    def private(cls, socket_path: str, timeout: float = 10.0) -> "ControlClient":
        return cls(f"unix:path={socket_path}", False, timeout)

    @classmethod
    def bus(cls, address: str, timeout: float = 10.0) -> "ControlClient":
        return cls(address, True, timeout)

    def _filter(self, conn, msg):
        import dbus.lowlevel
        if isinstance(msg, dbus.lowlevel.SignalMessage) and msg.get_interface() in (
                FLEET_INTERFACE, NODE_INTERFACE, "org.freedesktop.DBus.Properties"):
            self.signals.append(ControlSignal(msg))
        return dbus.lowlevel.HANDLER_RESULT_NOT_YET_HANDLED

    # -- calls
    def call(self, path: str, interface: str, method: str, signature: str = "", *args):
        r = self.conn.call_blocking(CONTROL_BUS_NAME, path, interface, method, signature, args,
                                    timeout=self.timeout)
        return dbus_plain(r)

    def fleet(self, method: str, signature: str = "", *args):
        return self.call(CONTROL_PATH, FLEET_INTERFACE, method, signature, *args)

    def get(self, path: str, interface: str, prop: str):
        return self.call(path, "org.freedesktop.DBus.Properties", "Get", "ss", interface, prop)

    def fleet_property(self, prop: str):
        return self.get(CONTROL_PATH, FLEET_INTERFACE, prop)

    def node(self, spec: str) -> ControlNode:
        """The node named spec (key, name, IFACE/ID: see docs/control-api.md)."""
        return ControlNode(self, self.fleet("GetNode", "s", spec))

    def subscribe(self) -> None:
        self.fleet("Subscribe")

    # -- signals
    def pump(self, seconds: float = 0.0) -> None:
        """Dispatch what arrived; with seconds > 0 keep doing so that long."""
        from gi.repository import GLib
        ctx = GLib.MainContext.default()
        deadline = time.monotonic() + seconds
        while True:
            while ctx.iteration(False):
                pass
            if time.monotonic() >= deadline:
                return
            time.sleep(0.005)

    def mark(self) -> int:
        """The index the next signal will get: pass it as start= to wait only
        for signals after this point."""
        self.pump()
        return len(self.signals)

    def wait_signal(self, member: str, timeout: float, path: Optional[str] = None,
                    pred: Optional[Callable[[ControlSignal], bool]] = None,
                    start: int = 0) -> Optional[ControlSignal]:
        """The first signal `member` (on `path`, matching pred) at index >=
        start within timeout seconds (unscaled), else None."""
        from gi.repository import GLib
        ctx = GLib.MainContext.default()
        deadline = time.monotonic() + timeout
        i = start
        while True:
            while ctx.iteration(False):
                pass
            for i in range(i, len(self.signals)):
                s = self.signals[i]
                if s.member == member and (path is None or s.path == path) and (pred is None or pred(s)):
                    return s
            i = len(self.signals)
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.005)

    def expect_signal(self, member: str, timeout: float, path: Optional[str] = None,
                      pred: Optional[Callable[[ControlSignal], bool]] = None,
                      start: int = 0, what: str = "") -> ControlSignal:
        """Like wait_signal, but timeout is scaled and a miss fails the test."""
        s = self.wait_signal(member, scaled(timeout), path, pred, start)
        if s is None:
            seen = [x for x in self.signals[start:]][-10:]
            raise AssertionError(f"timed out after {scaled(timeout):.1f}s waiting for signal "
                                 f"{member} ({what or path or 'any object'}); last signals: {seen}")
        return s

    def close(self) -> None:
        try:
            self.conn.close()
        except Exception:  # noqa: BLE001 - closing a dead connection
            pass

    def __enter__(self) -> "ControlClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
