"""Helpers for tests on a socketcand bus (docs/socketcand.md): cansimd with a
fleet whose buses it serves over TCP, started with --address-file and waited
for (READY=1 on a notify socket), python-can's socketcand client on it, and a
raw protocol client for what python-can does not send.

    import cansim_socketcand as sc

    def test(ctx):
        with sc.SocketcandDaemon(ctx, FLEET) as d:
            with d.bus("bench") as master:      # can.Bus(interface="socketcand", ...)
                ...
"""

from __future__ import annotations

import os
import socket
import subprocess
import time
from typing import Dict, List, Optional, Tuple

import can

import cansim_it as it


class SocketcandDaemon:
    """cansimd on `fleet_yaml` (its socketcand buses at listen: 127.0.0.1:0),
    private control socket and address file in its state dir, no D-Bus bus."""

    def __init__(self, ctx: it.Context, fleet_yaml: str, extra_args: Tuple[str, ...] = ()):
        self.ctx = ctx
        self.notify = it.NotifySocket()
        self.daemon = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}",
                                 "--control-socket", "{state_dir}/control", "--bus", "none",
                                 "--address-file", "{state_dir}/addresses", *extra_args,
                                 env=self.notify.env())
        with open(os.path.join(self.daemon.state_dir, "fleet.yaml"), "w") as f:
            f.write(fleet_yaml)
        os.symlink(ctx.source("profiles"), os.path.join(self.daemon.state_dir, "profiles"))
        self.addresses: Dict[str, Tuple[str, int]] = {}

    @property
    def control_socket(self) -> str:
        return os.path.join(self.daemon.state_dir, "control")

    @property
    def address_file(self) -> str:
        return os.path.join(self.daemon.state_dir, "addresses")

    def start(self) -> "SocketcandDaemon":
        self.daemon.start()
        self.notify.expect(lambda m: m.get("READY") == "1", 20, "READY=1")
        with open(self.address_file) as f:
            for line in f:
                name, host, port = line.split()
                self.addresses[name] = (host, int(port))
        return self

    def bus(self, name: str) -> can.BusABC:
        host, port = self.addresses[name]
        return can.Bus(interface="socketcand", host=host, port=port, channel=name)

    def raw(self, name: str, rcvbuf: int = 0) -> "RawClient":
        return RawClient(*self.addresses[name], rcvbuf=rcvbuf)

    def cansimctl(self, *args: str, timeout: float = 20) -> subprocess.CompletedProcess:
        ctl = os.environ.get("CANSIMCTL") or os.path.join(self.ctx.binary_dir, "cansimctl")
        return subprocess.run([ctl, "--socket", self.control_socket, *args], capture_output=True, text=True,
                              timeout=it.scaled(timeout))

    def __enter__(self) -> "SocketcandDaemon":
        return self.start()

    def __exit__(self, *exc) -> None:
        if exc[0] is not None and exc[0] is not it.Skip:
            self.daemon.dump_log()
        self.daemon.stop()
        self.notify.close()


class RawClient:
    """The socketcand protocol by hand on a blocking socket."""

    def __init__(self, host: str, port: int, rcvbuf: int = 0):
        self.sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
        if rcvbuf:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        self.sock.connect((host, port))
        self.buffer = b""

    def send(self, text: str) -> None:
        self.sock.sendall(text.encode("ascii"))

    def read_until(self, marker: str, timeout: float = 5.0) -> str:
        """Everything received up to and including `marker` (scaled timeout);
        "" at the end of the stream."""
        deadline = time.monotonic() + it.scaled(timeout)
        want = marker.encode("ascii")
        while want not in self.buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"timed out waiting for {marker!r}; got {self.buffer!r}")
            self.sock.settimeout(left)
            chunk = self.sock.recv(65536)
            if not chunk:
                out, self.buffer = self.buffer, b""
                return out.decode("ascii", "replace") + "<EOF>"
            self.buffer += chunk
        cut = self.buffer.index(want) + len(want)
        out, self.buffer = self.buffer[:cut], self.buffer[cut:]
        return out.decode("ascii", "replace")

    def handshake(self, bus: str) -> None:
        assert self.read_until("< hi >") == "< hi >"
        self.send(f"< open {bus} >")
        assert self.read_until("< ok >") == "< ok >"
        self.send("< rawmode >")
        assert self.read_until("< ok >") == "< ok >"

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> "RawClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def frames_of(bus: can.BusABC, seconds: float, ids: Optional[set] = None) -> List[can.Message]:
    """Frames bus received within `seconds` (unscaled), those in `ids` only when given."""
    return it.collect(bus, seconds, None if ids is None else (lambda m: m.arbitration_id in ids))
