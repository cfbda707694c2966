#!/usr/bin/python3
"""How long the control API's abuse holds cansimd's loop, by the loop's own
figures (Fleet1.LongestLoopPass: the longest pass over the last 10 s, wall
clock; LongestLoopPassCpu: the most CPU time a pass used), on this host (no CAN interface needed: the nodes run, their frames count as not
sent).

usage: bench/loop_hold_probe.py [--cansimd PATH] [--nodes N] [--runs N]

Starts cansimd with N generic-404 nodes (heartbeat 200 ms) and its private
socket, waits until the loop is quiet, then per attack and run prints the
longest pass seen while it ran, and the longest round trip of a second
client's property reads (every 10 ms) meanwhile:

  AddNodes of 100 MiB, GetNode of 100 MiB (answered TooLarge),
  two clients sending 120 MiB at once,
  64 authenticated idle peers + 64 raw sockets reconnecting at the handshake
  limit (as uid 65534 when run as root) while cansimctl list is timed.
"""

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time

from jeepney import DBusAddress, new_method_call
from jeepney.io.blocking import open_dbus_connection
from jeepney.low_level import HeaderFields

ROOT = "/io/cansim/Cansimd1"
FLEET = "io.cansim.Fleet1"
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Client:
    def __init__(self, sock: str):
        self.conn = open_dbus_connection(f"unix:path={sock}", auth_timeout=10)

    def call(self, member: str, sig=None, args=(), iface=FLEET, timeout=120):
        msg = new_method_call(DBusAddress(ROOT, bus_name="io.cansim.Cansimd1", interface=iface), member, sig, args)
        return self.conn.send_and_get_reply(msg, timeout=timeout)

    def longest_pass_ms(self, cpu: bool = False) -> float:
        prop = "LongestLoopPassCpu" if cpu else "LongestLoopPass"
        reply = self.call("Get", "ss", (FLEET, prop), iface="org.freedesktop.DBus.Properties")
        return reply.body[0][1] / 1000.0

    def close(self):
        self.conn.close()


def error_name(reply) -> str:
    return reply.header.fields.get(HeaderFields.error_name, "")


POLLER = """
import sys, threading, time
from jeepney import DBusAddress, new_method_call
from jeepney.io.blocking import open_dbus_connection
conn = open_dbus_connection(f'unix:path={sys.argv[1]}', auth_timeout=10)
addr = DBusAddress('/io/cansim/Cansimd1', bus_name='io.cansim.Cansimd1', interface='org.freedesktop.DBus.Properties')
worst = [0.0]
def poll():
    while True:
        t0 = time.monotonic()
        conn.send_and_get_reply(new_method_call(addr, 'Get', 'ss', ('io.cansim.Fleet1', 'NodeCount')), timeout=60)
        worst[0] = max(worst[0], time.monotonic() - t0)
        time.sleep(0.01)
threading.Thread(target=poll, daemon=True).start()
for line in sys.stdin:
    print(f'{worst[0] * 1000:.1f}', flush=True)
    worst[0] = 0.0
"""


class Poller:
    """A second client, a process of its own, reading NodeCount every 10 ms:
    its longest round trip while an attack runs (what a bench's calls wait;
    a cross-check of the loop's own figure)."""

    def __init__(self, sock: str):
        self.proc = subprocess.Popen([sys.executable, "-c", POLLER, sock], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True)

    def take(self) -> float:
        self.proc.stdin.write("take\n")
        self.proc.stdin.flush()
        return float(self.proc.stdout.readline())

    def close(self):
        self.proc.kill()
        self.proc.wait()


def wait_quiet(probe: Client, bound_ms: float = 5.0, timeout: float = 12.0) -> float:
    deadline = time.monotonic() + timeout
    while (ms := probe.longest_pass_ms()) > bound_ms and time.monotonic() < deadline:
        time.sleep(0.5)
    return ms


def giant(sock: str, member: str, mib: int) -> str:
    c = Client(sock)
    try:
        return error_name(c.call(member, "s", ("x" * (mib << 20),)))
    finally:
        c.close()


def two_at_once(sock: str) -> str:
    names = []
    threads = [threading.Thread(target=lambda: names.append(giant(sock, "AddNodes", 120))) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return ", ".join(names)


HOG = """
import socket, sys, threading, time
from jeepney.io.blocking import open_dbus_connection
sock = sys.argv[1]
idle = []
for _ in range(64):
    try:
        idle.append(open_dbus_connection(f'unix:path={sock}', auth_timeout=5))
    except Exception:
        pass
print(len(idle), flush=True)
def raw():
    while True:
        s = socket.socket(socket.AF_UNIX)
        try:
            s.connect(sock)
            s.recv(1)
        except OSError:
            time.sleep(0.05)
        s.close()
for _ in range(64):
    threading.Thread(target=raw, daemon=True).start()
time.sleep(3600)
"""


def locked_out(sock: str, cansimctl: str) -> str:
    as_other = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"] if os.geteuid() == 0 else []
    hog = subprocess.Popen(as_other + [sys.executable, "-c", HOG, sock], stdout=subprocess.PIPE, text=True)
    try:
        held = int(hog.stdout.readline() or 0)
        time.sleep(1)
        waits = []
        for _ in range(5):
            t0 = time.monotonic()
            r = subprocess.run([cansimctl, "--socket", sock, "list"], capture_output=True, text=True, timeout=60)
            waits.append((time.monotonic() - t0) * 1000)
            if r.returncode != 0:
                return f"{held} idle peers held; cansimctl list refused: {r.stderr.strip()}"
            time.sleep(0.3)
    finally:
        hog.kill()
        hog.wait()
    return f"{held} idle peers held, 64 raw reconnecting; cansimctl list served 5/5, {min(waits):.0f}-{max(waits):.0f} ms"


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimd", default=os.path.join(REPO, "build", "cansimd"))
    p.add_argument("--nodes", type=int, default=100)
    p.add_argument("--runs", type=int, default=3)
    a = p.parse_args()
    cansimctl = os.path.join(os.path.dirname(a.cansimd), "cansimctl")
    work = tempfile.mkdtemp(prefix="cansim-probe-")
    os.chmod(work, 0o755)
    profile = os.path.join(work, "hb200.yaml")
    with open(os.path.join(REPO, "profiles", "generic-404.yaml")) as src, open(profile, "w") as dst:
        dst.write(src.read().replace("access: rw, default: 1000,", "access: rw, default: 200,", 1))
    fleet = os.path.join(work, "fleet.yaml")
    with open(fleet, "w") as f:
        f.write(f"nodes:\n  - {{profile: {profile}, interface: cansimprobe0, node_id: 1, count: {a.nodes}, "
                f"name: g}}\n")
    sock = os.path.join(work, "control")
    log = open(os.path.join(work, "cansimd.log"), "w")
    daemon = subprocess.Popen([a.cansimd, "--config", fleet, "--control-socket", sock, "--bus", "none",
                               "--state-dir", os.path.join(work, "state")], stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 20
        while not os.path.exists(sock):
            assert time.monotonic() < deadline and daemon.poll() is None, "cansimd did not start"
            time.sleep(0.1)
        os.chmod(sock, 0o666)
        probe = Client(sock)
        poller = Poller(sock)
        attacks = [("AddNodes of 100 MiB", lambda: giant(sock, "AddNodes", 100)),
                   ("GetNode of 100 MiB", lambda: giant(sock, "GetNode", 100)),
                   ("2 clients x 120 MiB at once", lambda: two_at_once(sock)),
                   ("64 idle + 64 reconnecting peers", lambda: locked_out(sock, cansimctl))]
        print(f"cansimd {a.cansimd}, {a.nodes} nodes, heartbeat 200 ms; longest loop pass (LongestLoopPass):")
        for name, attack in attacks:
            for run in range(a.runs):
                quiet = wait_quiet(probe)
                poller.take()
                t0 = time.monotonic()
                answer = attack()
                spent = time.monotonic() - t0
                print(f"  {name}, run {run + 1}: {probe.longest_pass_ms():.1f} ms ({probe.longest_pass_ms(True):.1f} ms "
                      f"CPU), a concurrent call's worst round trip {poller.take():.1f} ms (quiet before: {quiet:.1f} "
                      f"ms; {spent:.1f} s; {answer})", flush=True)
        poller.close()
        probe.close()
    finally:
        daemon.terminate()
        daemon.wait(timeout=20)


if __name__ == "__main__":
    main()
