#!/usr/bin/env python3
"""The control API under abuse (docs/limits.md): a 100-node fleet (generic-404,
heartbeat 200 ms) runs while a careless or hostile client attacks the private
socket, and candump records every heartbeat. No attack may hold the loop: for
each attack, every node's heartbeat gap around it stays within the period +
slack (the attacks held the loop for seconds to minutes before). Each attack
also gets the answer docs/limits.md documents:

 1. ArmFault with 32,000 parameters; AddNodes of 4 MB of '[' and of a
    50,000-key vendor map; SetModel nested 2,000 deep -> io.cansim.Error.TooLarge.
 2. AddNodes naming a secret file outside the profile folders, /etc/shadow,
    /proc/self/maps -> Config naming the path, never a byte of the file; a
    text file in the fleet's folder -> its path alone.
 3. StartRecording to a FIFO, to /dev/zero, into the state folder -> Refused at once.
 4. 64 idle clients: a 65th (cansimctl) is told why; after they leave it is served.
 5. A subscriber that never reads while NMT broadcasts make 200 signals each:
    dropped with a journal line, the daemon's memory bounded.
 6. A connect/close flood: cansimctl calls meanwhile succeed, the journal gets
    a few lines, not one per connection.
 7. 40 AddNodes / RemoveNode cycles: the daemon's memory stays flat (1,000
    in the unit tier: tests/unit/limits_test.cpp).

Round two:
 8. Forged error frames on vcan0 from uid 65534 (bus-off, TX-passive, a storm
    of random ones): the bus stays error-active, no EMCY, one journal line.
 9. AddNodes of 100 MiB, GetNode of 16 MiB, two clients sending 48 MiB at once:
    TooLarge, and the loop's own figure (Fleet1.LongestLoopPass) stays small.
10. A FIFO, then a symbolic link out of the folder, at <node>.params.tmp:
    Store neither blocks nor writes through it; a hard link to a state file
    is refused as a recording target; a `csv:` table outside the profile
    folders is refused without its size.
11. 64 idle authenticated peers and 64 raw sockets reconnecting at the
    handshake limit, all of uid 65534: root's cansimctl and another uid's are
    served meanwhile.
"""

# ctest-timeout: 360

import os
import re
import socket
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

import dbus  # noqa: E402  (python3-dbus)
from jeepney import DBusAddress, new_method_call  # noqa: E402  (python3-jeepney)
from jeepney.io.blocking import open_dbus_connection  # noqa: E402
from jeepney.low_level import HeaderFields  # noqa: E402

NODES = 100
PERIOD = 0.2          # s, the heartbeat of every node
SLACK = 0.25 * it.SCALE  # the VM's scheduling (TCG); an attack held the loop for seconds
REFERENCE = 0x7F      # cangen's frames (0x77F every 50 ms): what the VM itself let through
REFERENCE_PERIOD = 0.05
E = "io.cansim.Error."
SECRET = "SECRET-6d1f"


class Heartbeats:
    """candump of every heartbeat (0x701..0x764) with kernel time stamps, into
    a socket buffer of 8 MB (the VM starves candump at times); -d reports any
    frame the socket dropped all the same, which would fake a gap."""

    def __init__(self, path: str):
        self.path = path
        self.out = open(path, "w")
        self.proc = subprocess.Popen(["candump", "-L", "-d", "-r", str(8 << 20), "vcan0,700:780"], stdout=self.out,
                                     stderr=subprocess.STDOUT)
        # A process of its own beside the daemon: when the host stalls the
        # whole VM (it does under load), its frames pause as the heartbeats do.
        self.reference = subprocess.Popen(["cangen", "vcan0", "-g", str(int(REFERENCE_PERIOD * 1000)),
                                           "-I", f"{0x700 + REFERENCE:X}", "-L", "0"], stdout=subprocess.DEVNULL)

    def stop(self) -> dict:
        time.sleep(PERIOD * 2)
        for p in (self.reference, self.proc):
            p.terminate()
            p.wait()
        self.out.close()
        beats = {}
        with open(self.path) as f:
            for line in f:
                assert "DROPPED" not in line.upper(), f"candump lost frames: {line.strip()}"
                m = re.match(r"\((\d+\.\d+)\) vcan0 7([0-9A-F]{2})#", line)
                if m and (1 <= int(m.group(2), 16) <= NODES or int(m.group(2), 16) == REFERENCE):  # not added nodes
                    beats.setdefault(int(m.group(2), 16), []).append(float(m.group(1)))
        return beats


def worst_gap(times: list, start: float, end: float) -> float:
    """The longest gap between two of `times` that overlaps [start, end]."""
    return max((b - a for a, b in zip(times, times[1:]) if b >= start and a <= end), default=0.0)


def rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        return int(next(line for line in f if line.startswith("VmRSS")).split()[1])


class Raw:
    """jeepney calls on their own connection (reads only when asked to)."""

    def __init__(self, sock: str):
        self.conn = open_dbus_connection(f"unix:path={sock}", auth_timeout=it.scaled(2))

    def call(self, path: str, iface: str, member: str, sig=None, args=()):
        addr = DBusAddress(path, bus_name=it.CONTROL_BUS_NAME, interface=iface)
        return self.conn.send_and_get_reply(new_method_call(addr, member, sig, args), timeout=it.scaled(30))

    def send(self, path: str, iface: str, member: str) -> None:
        addr = DBusAddress(path, bus_name=it.CONTROL_BUS_NAME, interface=iface)
        self.conn.send(new_method_call(addr, member))

    def close(self) -> None:
        self.conn.close()


def ctl(ctx: it.Context, sock: str, *args: str) -> subprocess.CompletedProcess:
    binary = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    return subprocess.run([binary, "--socket", sock, *args], capture_output=True, text=True,
                          timeout=it.scaled(20), stdin=subprocess.DEVNULL)


# --------------------------------------------------------------------------
# the attacks: each returns a line for the log

def too_large(c: it.ControlClient, node: it.ControlNode) -> str:
    params = dbus.Dictionary({f"k{i}": "1" for i in range(32000)}, signature="ss")
    msg = it.expect_dbus_error(lambda: node.call("ArmFault", "sa{ss}", "open", params), E + "TooLarge",
                               "ArmFault with 32,000 parameters")
    assert "more than 32 parameters" in msg, msg
    it.expect_dbus_error(lambda: c.fleet("AddNodes", "s", "[" * (4 << 20)), E + "TooLarge", "AddNodes of 4 MB of '['")
    vendor = ("{profile: generic-404, interface: vcan0, node_id: 0x70, name: v, vendor: {"
              + ", ".join(f"k{i}: 1" for i in range(50000)) + "}}")
    it.expect_dbus_error(lambda: c.fleet("AddNodes", "s", vendor), E + "TooLarge", "AddNodes of a 50,000-key vendor map")
    it.expect_dbus_error(lambda: node.call("SetModel", "ss", "pressure", "[" * 2000), E + "TooLarge",
                         "SetModel nested 2,000 deep")
    assert c.fleet_property("NodeCount") == NODES
    return "ArmFault 32,000 parameters, AddNodes 4 MB '[' / 50,000 vendor keys, SetModel 2,000 deep: TooLarge"


def disclosure(c: it.ControlClient, ctx: it.Context, fleet_dir: str) -> str:
    outside = os.path.join(ctx.tmp, "elsewhere")
    os.makedirs(outside, exist_ok=True)
    with open(os.path.join(outside, "secret.txt"), "w") as f:
        f.write(f"line1 {SECRET} line2\n")
    with open(os.path.join(fleet_dir, "notes.txt"), "w") as f:
        f.write(f"{SECRET}\n")
    answers = []
    for path in [os.path.join(outside, "secret.txt"), "/etc/shadow", "/proc/self/maps",
                 os.path.join(fleet_dir, "notes.txt")]:
        msg = it.expect_dbus_error(
            lambda: c.fleet("AddNodes", "s", f"{{profile: {path}, interface: vcan0, node_id: 0x70}}"),
            E + "Config", f"AddNodes of {path}")
        assert SECRET not in msg and "root:" not in msg and "r-xp" not in msg, f"{path}: {msg}"
        assert path in msg, f"{path}: the answer does not name the file: {msg}"
        answers.append(msg)
    assert "in the profile folders" in answers[0], answers[0]
    assert "not a valid profile" in answers[3], answers[3]
    return f"AddNodes of files: path only ({answers[0][:80]}...; {answers[3][:60]}...)"


def recording(node: it.ControlNode, ctx: it.Context, state_dir: str) -> str:
    fifo = os.path.join(ctx.tmp, "fifo")
    os.mkfifo(fifo)
    for path, why in [(fifo, "not a regular file"), ("/dev/zero", "not a regular file"),
                      (os.path.join(state_dir, "vcan0@g@0.params"), "state folder")]:
        t0 = time.monotonic()
        msg = it.expect_dbus_error(lambda: node.call("StartRecording", "s", path), E + "Refused",
                                   f"StartRecording {path}")
        assert why in msg, f"{path}: {msg}"
        assert time.monotonic() - t0 < it.scaled(1), f"StartRecording {path} took {time.monotonic() - t0:.1f} s"
    assert not os.path.exists(os.path.join(state_dir, "vcan0@g@0.params"))
    return "StartRecording to a FIFO, /dev/zero, the state folder: Refused at once"


def idle_clients(ctx: it.Context, sock: str) -> str:
    idle = [Raw(sock) for _ in range(63)]  # with the test's own client: 64, the default --max-clients
    r = ctl(ctx, sock, "list")
    assert r.returncode == 1 and "at most 64 control clients" in r.stderr and "--max-clients" in r.stderr, (
        f"cansimctl with 64 clients connected: exit {r.returncode}, {r.stderr!r}")
    for c in idle:
        c.close()
    deadline = time.monotonic() + it.scaled(3)
    while ctl(ctx, sock, "list").returncode != 0:
        assert time.monotonic() < deadline, "cansimctl not served after the idle clients left"
        time.sleep(0.1)
    return f"64 idle clients: cansimctl told {r.stderr.strip()!r}"


def slow_subscriber(sock: str, d: it.Daemon, bus) -> str:
    sleeper = Raw(sock)
    sleeper.call(it.CONTROL_PATH, it.FLEET_INTERFACE, "Subscribe")
    before = rss_kib(d.proc.pid)
    deadline = time.monotonic() + it.scaled(6)
    sent = 0
    while "dropped: reads too slowly" not in d.log_text():
        assert time.monotonic() < deadline, f"a subscriber that never reads was not dropped ({sent} NMT broadcasts)"
        it.send(bus, 0x000, [0x01 if sent % 2 else 0x80, 0x00])  # every node: start / pre-operational
        sent += 1
        time.sleep(0.01)
    grown = rss_kib(d.proc.pid) - before
    sleeper.close()
    assert grown < 32 * 1024, f"the daemon grew by {grown} KiB for one subscriber that never reads"
    it.send(bus, 0x000, [0x80, 0x00])
    return f"subscriber that never reads: dropped after {sent} NMT broadcasts (~{sent * 2 * NODES} signals), RSS +{grown} KiB"


def flood(ctx: it.Context, sock: str, d: it.Daemon) -> str:
    stop = threading.Event()
    count = [0]

    def connect_close():
        while not stop.is_set():
            s = socket.socket(socket.AF_UNIX)
            try:
                s.connect(sock)
            except OSError:
                pass
            s.close()
            count[0] += 1

    lines = len(d.log_text().splitlines())
    th = threading.Thread(target=connect_close)
    th.start()
    try:
        results = [ctl(ctx, sock, "status", "g/0") for _ in range(3)]
    finally:
        stop.set()
        th.join()
    failed = [r.stderr for r in results if r.returncode != 0]
    assert not failed, f"cansimctl status during a connect flood: {failed}"
    new = len(d.log_text().splitlines()) - lines
    assert new <= 3, f"{new} log lines for {count[0]} connections:\n" + "\n".join(d.log_text().splitlines()[-5:])
    return f"connect/close flood: {count[0]} connections, 3 cansimctl status ok, {new} log line(s)"


def add_remove(c: it.ControlClient, d: it.Daemon, profile: str) -> str:
    def cycles(n: int) -> None:
        for _ in range(n):
            c.fleet("AddNodes", "s", f"{{profile: {profile}, interface: vcan0, node_id: 0x70, name: cycle}}")
            c.fleet("RemoveNode", "s", "vcan0/cycle/0")
    # Two windows of 40: a leak grows the daemon in each. A loaded host can
    # grow it once (signals queued for a slow client, within their bound,
    # kept by malloc), as in one CI run: +1,512 KiB, then nothing.
    cycles(10)
    grown = []
    for _ in range(2):
        before = rss_kib(d.proc.pid)
        cycles(40)
        grown.append(rss_kib(d.proc.pid) - before)
    assert min(grown) < 1024, \
        f"each 40 AddNodes / RemoveNode cycles grew the daemon: by {grown} KiB (66 KB a cycle before)"
    return f"2 x 40 AddNodes / RemoveNode cycles: RSS +{grown[0]} KiB, +{grown[1]} KiB"


def quiet_loop(c: it.ControlClient) -> int:
    """Waits (bounded) until the loop's longest pass over the last 10 s is
    short, so that what an attack shows is the attack's; returns it (µs)."""
    deadline = time.monotonic() + 12
    while (longest := int(c.fleet_property("LongestLoopPass"))) > 50_000 * it.SCALE:
        assert time.monotonic() < deadline, f"the loop does not settle: {longest} µs"
        time.sleep(0.5)
    return longest


def forged_error_frames(c: it.ControlClient, d: it.Daemon) -> str:
    """Any local user may write error frames on a vcan: they are no controller state."""
    storm = ("import os, random, socket, struct\n"
             "s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)\n"
             "s.bind(('vcan0',))\n"
             "rnd = random.Random(33)\n"
             "for i in range(2000):\n"
             "    s.send(struct.pack('=IB3x8s', 0x20000000 | rnd.randrange(1 << 29), 8, rnd.randbytes(8)))\n")
    as_nobody = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
    node = c.node("g/0")
    emcys = node.get("EmcyCount")
    for frame in ["20000040#0000000000000000", "20000004#0020000000000000"]:  # bus-off; controller: TX passive
        subprocess.run(as_nobody + ["cansend", "vcan0", frame], check=True, timeout=it.scaled(10))
    subprocess.run(as_nobody + [sys.executable, "-c", storm], check=True, timeout=it.scaled(30))
    states = c.fleet_property("BusStates")
    assert states["vcan0"] == "error-active", f"forged error frames changed vcan0's state: {dict(states)}"
    assert node.get("EmcyCount") == emcys, "a forged error frame made a node send EMCY"
    deadline = time.monotonic() + it.scaled(3)
    while "error frame(s) from the wire ignored" not in d.log_text():
        assert time.monotonic() < deadline, "no journal line for the ignored error frames"
        time.sleep(0.1)
    lines = [ln for ln in d.log_text().splitlines() if "error frame" in ln or "CAN controller" in ln]
    assert len(lines) <= 2, "error frames logged line by line:\n" + "\n".join(lines[:10])
    return f"2,002 forged error frames from uid 65534: vcan0 {states['vcan0']}, journal: {lines[0].strip()[-110:]}"


def giant_messages(c: it.ControlClient, sock: str, passes: dict) -> str:
    """What sd-bus would read and check whole (100 MiB: 1.1-1.2 s of loop in
    this VM before): answered TooLarge by the private socket's gate, unread.
    The loop's own longest pass meanwhile is checked at the end, less what
    the VM stalled (the guest's clock runs on while the host holds it)."""
    settled = quiet_loop(c)
    for member, mib in (("AddNodes", 100), ("GetNode", 16)):
        raw = Raw(sock)
        reply = raw.call(it.CONTROL_PATH, it.FLEET_INTERFACE, member, "s", ("x" * (mib << 20),))
        raw.close()
        name = reply.header.fields.get(HeaderFields.error_name)
        assert name == E + "TooLarge", f"{member} of {mib} MiB: {name} {reply.body}"
    answers = []

    def send(mib: int):
        raw = Raw(sock)
        answers.append(raw.call(it.CONTROL_PATH, it.FLEET_INTERFACE, "AddNodes", "s", ("y" * (mib << 20),)))
        raw.close()

    threads = [threading.Thread(target=send, args=(48,)) for _ in range(2)]  # 120 MiB each natively
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    names = [a.header.fields.get(HeaderFields.error_name) for a in answers]
    assert names == [E + "TooLarge"] * 2, f"two clients of 48 MiB at once: {names}"
    passes["giant messages"] = longest = int(c.fleet_property("LongestLoopPass"))
    cpu = int(c.fleet_property("LongestLoopPassCpu"))
    assert cpu <= 50_000 * it.SCALE, f"a pass used {cpu / 1000:.0f} ms of CPU during the giant messages"
    return (f"AddNodes of 100 MiB, GetNode of 16 MiB, 2 x 48 MiB at once: TooLarge; longest loop pass "
            f"{longest / 1000:.1f} ms, {cpu / 1000:.1f} ms of CPU (settled before: {settled / 1000:.1f} ms)")


def state_folder(c: it.ControlClient, node: it.ControlNode, ctx: it.Context, state_dir: str) -> str:
    params = os.path.join(state_dir, "vcan0@g@0.params")
    tmp = params + ".tmp"
    os.mkfifo(tmp)
    t0 = time.monotonic()
    node.call("Store", "y", 1)  # the FIFO held the loop until a reader came (more than 12 s)
    fifo_s = time.monotonic() - t0
    assert fifo_s < it.scaled(1), f"Store beside a FIFO took {fifo_s:.1f} s"
    assert os.path.isfile(params) and not os.path.islink(params), "no regular .params after Store"
    outside = os.path.join(ctx.tmp, "outside.txt")
    with open(outside, "w") as f:
        f.write("keep\n")
    os.symlink(outside, tmp)
    node.call("Store", "y", 1)
    assert not os.path.islink(params), ".params became a link (out of the state folder)"
    with open(outside) as f:
        assert f.read() == "keep\n", "Store wrote through a link at .params.tmp"
    second = os.path.join(ctx.tmp, "second-name.csv")
    os.link(params, second)
    msg = it.expect_dbus_error(lambda: node.call("StartRecording", "s", second), E + "Refused",
                               "StartRecording to a hard link of a state file")
    assert "more than one name" in msg, msg
    os.unlink(second)
    secret = os.path.join(ctx.tmp, "elsewhere", "table.csv")
    os.makedirs(os.path.dirname(secret), exist_ok=True)
    with open(secret, "w") as f:
        f.write("0,1\n1,2\n")
    os.chmod(secret, 0o600)
    for path in (secret, "/etc/shadow", os.path.join(ctx.tmp, "missing.csv")):
        msg = it.expect_dbus_error(
            lambda: node.call("SetModel", "ss", "pressure", f"table: {{csv: {path}, value_unit: bar}}"),
            E + "InvalidArgument", f"SetModel of a table {path}")
        assert "expected a file in the profile folders" in msg and "bytes" not in msg, f"{path}: {msg}"
    return (f"FIFO / link at .params.tmp: Store in {fifo_s * 1000:.0f} ms, nothing written through; hard link "
            f"refused; csv: outside the profile folders refused ({msg[-70:]})")


def locked_out(ctx: it.Context, sock: str) -> str:
    """uid 65534 holds what one user may (48 of 64) with idle peers, and
    keeps 64 raw sockets reconnecting at the 3 s handshake limit."""
    os.chmod(os.path.dirname(sock), 0o755)
    os.chmod(sock, 0o666)
    hog = ("import socket, sys, threading, time\n"
           "from jeepney.io.blocking import open_dbus_connection\n"
           "sock = sys.argv[1]\n"
           "idle = []\n"
           "for _ in range(64):\n"
           "    try:\n"
           "        idle.append(open_dbus_connection(f'unix:path={sock}', auth_timeout=5))\n"
           "    except Exception:\n"
           "        pass\n"
           "print(len(idle), flush=True)\n"
           "def raw():\n"
           "    while True:\n"
           "        s = socket.socket(socket.AF_UNIX)\n"
           "        try:\n"
           "            s.connect(sock)\n"
           "            s.recv(1)\n"  # until the daemon closes it
           "        except OSError:\n"
           "            time.sleep(0.05)\n"
           "        s.close()\n"
           "for _ in range(64):\n"
           "    threading.Thread(target=raw, daemon=True).start()\n"
           "time.sleep(3600)\n")
    # At nice 19: what is tested is the slots the hog takes, not the CPU
    # (on a slow TCG guest, beside its 64 reconnecting threads, root's
    # cansimctl once did not finish its handshake within the 3 s).
    p = subprocess.Popen(["nice", "-n", "19", "setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
                          sys.executable, "-c", hog, sock], stdout=subprocess.PIPE, text=True)
    try:
        held = int(p.stdout.readline() or 0)
        time.sleep(it.scaled(1))
        served = 0
        t0 = time.monotonic()
        for i in range(10):
            who = [] if i % 2 == 0 else ["setpriv", "--reuid=1000", "--regid=1000", "--clear-groups"]
            binary = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
            r = subprocess.run(who + [binary, "--socket", sock, "list"], capture_output=True, text=True,
                               timeout=it.scaled(20), stdin=subprocess.DEVNULL)
            assert r.returncode == 0, f"{'uid 1000' if who else 'root'} locked out: {r.stderr.strip()}"
            served += 1
            time.sleep(0.5)
        spent = time.monotonic() - t0
    finally:
        p.kill()
        p.wait()
    return (f"uid 65534 holding {held} authenticated idle peers (48 taken) + 64 raw reconnectors: "
            f"{served} of 10 cansimctl list (root, uid 1000) served over {spent:.0f} s")


# --------------------------------------------------------------------------

def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    fleet_dir = os.path.join(ctx.tmp, "fleet")
    os.makedirs(fleet_dir)
    profile = os.path.join(fleet_dir, "hb200.yaml")
    with open(ctx.source("profiles", "generic-404.yaml")) as src, open(profile, "w") as dst:
        text = src.read()
        hb = "{index: 0x1017, name: Producer heartbeat time, type: UNSIGNED16, access: rw, default: 1000,"
        assert hb in text, "generic-404's 0x1017 row changed: update this test"
        dst.write(text.replace(hb, hb.replace("default: 1000", f"default: {int(PERIOD * 1000)}")))
    fleet_file = os.path.join(fleet_dir, "fleet.yaml")
    with open(fleet_file, "w") as f:
        # The ideal bus: each heartbeat is written at its deadline, so a gap is the
        # loop's. On the loop-paced timed bus a loaded VM's late wake-ups cost the
        # bus capacity (docs/bus-model.md, Limits): 1,500 frames/s offered, 0x764
        # starved behind the backlog for seconds while no pass was long.
        f.write(f"interfaces: {{vcan0: {{bit_rate: 250, bus_model: ideal}}}}\n"
                f"nodes:\n  - {{profile: {profile}, interface: vcan0, node_id: 1, count: {NODES}, name: g}}\n")
    sock = os.path.join(ctx.tmp, "control")
    beats = Heartbeats(os.path.join(ctx.tmp, "heartbeats.log"))
    windows = []
    passes = {}  # attack -> the loop's longest pass (µs) it saw
    try:  # candump and cangen must not outlive a failed attack (the test would hang to its timeout)
        with it.open_bus("vcan0") as bus:
            d = ctx.start_daemon("--config", fleet_file, "--control-socket", sock, "--bus", "none",
                                 "--state-dir", "{state_dir}")
            it.wait_for_path(sock, 10)
            time.sleep(it.scaled(0.5))
            with it.ControlClient.private(sock, timeout=30) as c:
                assert c.fleet_property("NodeCount") == NODES
                node = c.node("g/0")
                attacks = [("giant messages", lambda: giant_messages(c, sock, passes)),
                           ("forged error frames", lambda: forged_error_frames(c, d)),
                           ("locked out", lambda: locked_out(ctx, sock)),
                           ("too large", lambda: too_large(c, node)),
                           ("file disclosure", lambda: disclosure(c, ctx, fleet_dir)),
                           ("recording", lambda: recording(node, ctx, d.state_dir)),
                           ("state folder", lambda: state_folder(c, node, ctx, d.state_dir)),
                           ("idle clients", lambda: idle_clients(ctx, sock)),
                           ("slow subscriber", lambda: slow_subscriber(sock, d, bus)),
                           ("connect flood", lambda: flood(ctx, sock, d)),
                           ("add / remove", lambda: add_remove(c, d, profile))]
                for name, attack in attacks:
                    t0 = time.time()
                    it.log(attack())
                    windows.append((name, t0, time.time()))
                    d.assert_alive()
            assert d.stop() == 0, "exit status after SIGTERM"
    finally:
        heard = beats.stop()
    reference = heard.pop(REFERENCE, [])
    assert len(heard) == NODES and reference, f"heartbeats of {len(heard)} nodes recorded, expected {NODES}"
    for name, t0, t1 in windows:
        gap, n = max((worst_gap(times, t0, t1), node) for node, times in heard.items())
        # What the VM stalled (the reference's longest gap beyond its period) is not the daemon's.
        stall = max(0.0, worst_gap(reference, t0, t1) - REFERENCE_PERIOD)
        it.log(f"{name}: {t1 - t0:.1f} s, longest heartbeat gap {gap * 1000:.0f} ms (node 0x{n:02X}), "
               f"the VM stalled {stall * 1000:.0f} ms")
        assert gap - stall <= PERIOD + SLACK, (f"{name}: node 0x{n:02X} kept silent {gap:.2f} s (heartbeat {PERIOD} s, "
                                               f"VM stall {stall:.2f} s): the attack held the loop")
        if name in passes:
            held = passes[name] / 1e6
            it.log(f"{name}: the loop's longest pass {held * 1000:.0f} ms, less the VM's stall "
                   f"{max(0.0, held - stall) * 1000:.0f} ms")
            assert held - stall <= 0.05 * it.SCALE, f"{name}: a pass of {held:.2f} s (VM stall {stall:.2f} s)"


it.main(test)
