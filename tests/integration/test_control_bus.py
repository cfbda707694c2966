#!/usr/bin/env python3
"""The control API on a message bus (docs/control-api.md), with the bus's
access policy and the private socket's permissions tested as they would be
on a real system.

System bus: a private dbus-daemon with a system-like configuration (Debian's
system.conf default policy: connect yes, method calls and name ownership
denied unless a system.d file punches a hole) whose system.d/ holds the
repository's dbus/io.cansim.Cansimd1.conf verbatim, plus a copy in which the
group "cansim" is replaced by "users" (so a group member can be tested on a
machine without the cansim group). cansimd runs with --bus system and
DBUS_SYSTEM_BUS_ADDRESS pointing at that daemon (sd_bus_open_system: not a
trusted bus, so sd-bus's own privilege check is exercised too):

  - root (this test) owns nothing, calls ListNodes / GetNode / Read / Nmt and
    property Get, receives NmtStateChanged after Subscribe;
  - uid 65534 without groups (setpriv --reuid=65534 --regid=65534
    --clear-groups) is refused by the bus policy: AccessDenied for method
    calls, Introspect, Get and RequestName of io.cansim.Cansimd1, and cannot
    open the private socket (mode 0660, owned by root: EACCES);
  - uid 65534 in group "users" (the policy's group rule) may call ListNodes,
    Read, Nmt, Get, Introspect (the methods are SD_BUS_VTABLE_UNPRIVILEGED:
    sd-bus does not refuse a non-root caller), may not own the name, and
    still cannot open the private socket;
  - a second cansimd with --bus system cannot take the name and exits non-zero.

User bus: `dbus-run-session -- cansimd --bus user --control-socket none`
(sd_bus_open_user: trusted, so no privilege check happens there; see above),
a call through that session bus works.

No CAN traffic is needed (the nodes run off the bus when vcan0 is missing).
"""

# ctest-timeout: 180

import json
import os
import select
import shutil
import stat
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402


NOBODY = 65534
TEST_GROUP = "users"  # stands in for "cansim" in the derived policy copy
ACCESS_DENIED = "org.freedesktop.DBus.Error.AccessDenied"

SYSTEM_CONF = """<!DOCTYPE busconfig PUBLIC "-//freedesktop//DTD D-Bus Bus Configuration 1.0//EN"
 "http://www.freedesktop.org/standards/dbus/1.0/busconfig.dtd">
<!-- A private system-like bus for it_control_bus: Debian's system.conf default policy. -->
<busconfig>
  <type>system</type>
  <auth>EXTERNAL</auth>
  <listen>unix:path={socket}</listen>
  <policy context="default">
    <allow user="*"/>
    <deny own="*"/>
    <deny send_type="method_call"/>
    <allow send_type="signal"/>
    <allow send_requested_reply="true" send_type="method_return"/>
    <allow send_requested_reply="true" send_type="error"/>
    <allow receive_type="method_call"/>
    <allow receive_type="method_return"/>
    <allow receive_type="error"/>
    <allow receive_type="signal"/>
    <allow send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus"/>
    <allow send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus.Introspectable"/>
    <allow send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus.Properties"/>
    <deny send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus"
          send_member="UpdateActivationEnvironment"/>
  </policy>
  <includedir>system.d</includedir>
</busconfig>
"""

# Run as another uid: every call it can make, and the private socket.
PROBE = r"""
import errno, json, socket, sys
import dbus, dbus.bus
address, sock, node = sys.argv[1:4]
out = {}
def attempt(name, fn):
    try:
        fn()
        out[name] = "ok"
    except dbus.DBusException as e:
        out[name] = e.get_dbus_name()
c = dbus.bus.BusConnection(address)
N, P, F, I = "io.cansim.Cansimd1", "/io/cansim/Cansimd1", "io.cansim.Fleet1", "io.cansim.Node1"
attempt("ListNodes", lambda: c.call_blocking(N, P, F, "ListNodes", "", ()))
attempt("GetNode", lambda: c.call_blocking(N, P, F, "GetNode", "s", ("vcan0/0x10",)))
attempt("Read", lambda: c.call_blocking(N, node, I, "Read", "qy", (0x1017, 0)))
attempt("Nmt", lambda: c.call_blocking(N, node, I, "Nmt", "s", ("start",)))
attempt("Get", lambda: c.call_blocking(N, P, "org.freedesktop.DBus.Properties", "Get", "ss", (F, "Version")))
attempt("Introspect", lambda: c.call_blocking(N, P, "org.freedesktop.DBus.Introspectable", "Introspect", "", ()))
def own():
    r = c.request_name(N, dbus.bus.NAME_FLAG_DO_NOT_QUEUE)
    if r != dbus.bus.REQUEST_NAME_REPLY_PRIMARY_OWNER:
        raise dbus.DBusException("request_name answered %d" % r, name="test.NotOwner")
attempt("RequestName", own)
s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
try:
    s.connect(sock)
    out["socket"] = "connected"
except OSError as e:
    out["socket"] = errno.errorcode.get(e.errno, str(e.errno))
print(json.dumps(out))
"""


class BusDaemon:
    """dbus-daemon --config-file=CONF --nofork --print-address, ours to stop."""

    def __init__(self, conf: str):
        self.proc = subprocess.Popen(["dbus-daemon", f"--config-file={conf}", "--nofork", "--print-address=1"],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
        ready, _, _ = select.select([self.proc.stdout], [], [], it.scaled(10))
        line = self.proc.stdout.readline().decode().strip() if ready else ""
        if not line:
            self.stop()
            raise AssertionError(f"dbus-daemon printed no address: {self.proc.stderr.read().decode()}")
        self.address = line
        it.log(f"dbus-daemon (pid {self.proc.pid}) at {self.address}")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(it.scaled(5))
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def check_idle(d: it.Daemon, pid: int, what: str) -> None:
    """cansimd with two nodes, started, must idle: it must not spin on a bus
    connection. Measured over 1 s once its log says the fleet is up."""
    deadline = time.monotonic() + it.scaled(10)
    while "fleet: " not in d.log_text():
        assert time.monotonic() < deadline, f"{what}: cansimd did not start its fleet"
        time.sleep(0.05)
    time.sleep(0.2)
    c0, t0 = cpu_seconds(pid), time.monotonic()
    time.sleep(1.0)
    share = (cpu_seconds(pid) - c0) / (time.monotonic() - t0)
    it.log(f"{what}: cansimd used {share:.0%} of a CPU over 1 s")
    assert share < 0.25, (f"{what}: cansimd uses {share:.0%} of a CPU with two idle nodes (a busy loop on "
                          f"the bus connection: its calls are never answered)")


def fleet_file(ctx: it.Context) -> str:
    path = os.path.join(ctx.tmp, "fleet.yaml")
    with open(path, "w") as f:
        f.write(f"interfaces:\n  vcan0: {{bit_rate: 250}}\n"
                f"nodes:\n  - {{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan0, "
                f"node_id: 0x10, count: 2, name: generic}}\n")
    return path


def probe(address: str, sock: str, node: str, groups: list) -> dict:
    """PROBE run as uid/gid 65534 with the given supplementary groups."""
    cmd = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}"]
    cmd += [f"--groups={','.join(map(str, groups))}"] if groups else ["--clear-groups"]
    cmd += ["--", sys.executable, "-c", PROBE, address, sock, node]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=it.scaled(30),
                       env={"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": "/",
                            "PYTHONDONTWRITEBYTECODE": "1"})
    if r.returncode != 0:
        raise AssertionError(f"probe as uid {NOBODY} groups {groups} failed ({r.returncode}): {r.stderr}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def system_bus(ctx: it.Context) -> None:
    import grp
    tmp = os.path.join(ctx.tmp, "system")
    os.makedirs(os.path.join(tmp, "system.d"))
    # Other uids must reach the sockets: only their own modes may keep them out.
    for d in (ctx.tmp, tmp):
        os.chmod(d, 0o755)
    policy = ctx.source("dbus", "io.cansim.Cansimd1.conf")
    shutil.copy(policy, os.path.join(tmp, "system.d", "io.cansim.Cansimd1.conf"))
    text = open(policy).read()
    assert text.count('group="cansim"') == 1, "dbus/io.cansim.Cansimd1.conf: expected one <policy group=\"cansim\">"
    with open(os.path.join(tmp, "system.d", "zz-it-test-group.conf"), "w") as f:
        f.write(text.replace('group="cansim"', f'group="{TEST_GROUP}"'))
    users_gid = grp.getgrnam(TEST_GROUP).gr_gid
    bus_socket = os.path.join(tmp, "system_bus_socket")
    conf = os.path.join(tmp, "system.conf")
    with open(conf, "w") as f:
        f.write(SYSTEM_CONF.format(socket=bus_socket))

    bus = BusDaemon(conf)
    try:
        sock = os.path.join(ctx.tmp, "control")
        env = {"DBUS_SYSTEM_BUS_ADDRESS": bus.address}
        d = ctx.start_daemon("--config", fleet_file(ctx), "--bus", "system", "--control-socket", sock,
                             "--state-dir", "{state_dir}", env=env, name="cansimd-system")
        it.wait_for_path(sock, 5)
        with it.ControlClient.bus(bus.address) as root:
            deadline = time.monotonic() + it.scaled(5)
            while not root.conn.name_has_owner(it.CONTROL_BUS_NAME):
                assert time.monotonic() < deadline, "io.cansim.Cansimd1 has no owner on the system bus"
                time.sleep(0.05)
            owner = root.conn.get_name_owner(it.CONTROL_BUS_NAME)
            it.log(f"io.cansim.Cansimd1 owned by {owner}")
            check_idle(d, d.proc.pid, "--bus system")
            root.subscribe()
            keys = sorted(n[1] for n in root.fleet("ListNodes"))
            assert keys == ["vcan0/generic/0", "vcan0/generic/1"], keys
            g1 = root.node("vcan0/0x11")
            assert g1.path == it.control_node_path("vcan0", "generic", 1)
            assert g1.read(0x1017, 0) == 1000
            mark = root.mark()
            g1.call("Nmt", "s", "start")
            s = root.expect_signal("NmtStateChanged", 3, path=g1.path, start=mark, what="NmtStateChanged on the bus")
            assert s.args[1:] == ["pre-operational", "operational"], s
            assert root.fleet_property("NodeCount") == 2
            it.log(f"root on the system bus: ListNodes {keys}, Read, Nmt start -> {s}")

            st = os.stat(sock)
            assert stat.S_ISSOCK(st.st_mode) and stat.S_IMODE(st.st_mode) == 0o660 and st.st_uid == 0, \
                f"private socket {oct(st.st_mode)} uid {st.st_uid}"
            with it.ControlClient.private(sock) as private:
                assert len(private.fleet("ListNodes")) == 2
            it.log(f"private socket {sock}: mode 0660, uid 0, root may use it beside the bus")

            g0 = it.control_node_path("vcan0", "generic", 0)
            other = probe(bus.address, sock, g0, [])
            it.log(f"uid {NOBODY}, no groups: {other}")
            want = {k: ACCESS_DENIED for k in ["ListNodes", "GetNode", "Read", "Nmt", "Get", "Introspect",
                                               "RequestName"]}
            want["socket"] = "EACCES"
            assert other == want, f"uid {NOBODY} without groups: {other}, expected {want}"
            assert root.node("vcan0/0x10").get("NmtState") == "pre-operational", "a refused Nmt changed the node"

            if os.stat(sock).st_gid == users_gid:
                raise AssertionError(f"the private socket belongs to group {TEST_GROUP}: cannot test the group case")
            member = probe(bus.address, sock, g0, [users_gid])
            it.log(f"uid {NOBODY} in group {TEST_GROUP}: {member}")
            want = {k: "ok" for k in ["ListNodes", "GetNode", "Read", "Nmt", "Get", "Introspect"]}
            want.update(RequestName=ACCESS_DENIED, socket="EACCES")
            assert member == want, f"uid {NOBODY} in the policy's group: {member}, expected {want}"
            assert root.node("vcan0/0x10").get("NmtState") == "operational", "the group member's Nmt start"

            # The name is taken: a second daemon cannot serve it and says so.
            d2 = ctx.start_daemon("--config", fleet_file(ctx), "--bus", "system", "--control-socket", "none",
                                  "--state-dir", "{state_dir}", env=env, name="cansimd-second")
            rc = d2.wait(10)
            assert rc not in (None, 0), f"a second cansimd --bus system: exit status {rc}"
            assert "io.cansim.Cansimd1" in d2.log_text(), d2.log_text()
            line = [x for x in d2.log_text().splitlines() if "Cansimd1" in x][0]
            it.log(f"second cansimd --bus system: exit {rc}: {line.strip()}")
            assert root.conn.get_name_owner(it.CONTROL_BUS_NAME) == owner, "the name changed hands"
            d.assert_alive()
        assert d.stop() == 0, "cansimd --bus system: exit status after SIGTERM"
    finally:
        bus.stop()


def user_bus(ctx: it.Context) -> None:
    addr_file = os.path.join(ctx.tmp, "session-address")
    pid_file = os.path.join(ctx.tmp, "cansimd-user.pid")
    cansimd = ctx.require_cansimd()
    script = (f'echo "$DBUS_SESSION_BUS_ADDRESS" > {addr_file}.tmp && mv {addr_file}.tmp {addr_file} && '
              f'echo $$ > {pid_file} && exec {cansimd} --config {fleet_file(ctx)} --bus user '
              f'--control-socket none --state-dir "$CANSIM_STATE_DIR"')
    run = shutil.which("dbus-run-session")
    assert run, "dbus-run-session not found (Debian package dbus-daemon)"
    env = {k: "" for k in ["DBUS_SESSION_BUS_ADDRESS", "DBUS_SYSTEM_BUS_ADDRESS"]}
    session = it.Daemon(run, ["--", "sh", "-c", script], name="dbus-run-session", env=env)
    ctx.daemons.append(session)
    session.start()
    it.wait_for_path(pid_file, 10)
    it.wait_for_path(addr_file, 1)
    address = open(addr_file).read().strip()
    pid = int(open(pid_file).read().strip())
    try:
        check_idle(session, pid, "--bus user")
        with it.ControlClient.bus(address) as c:
            deadline = time.monotonic() + it.scaled(5)
            while not c.conn.name_has_owner(it.CONTROL_BUS_NAME):
                assert time.monotonic() < deadline, "io.cansim.Cansimd1 has no owner on the session bus"
                time.sleep(0.05)
            nodes = c.fleet("ListNodes")
            assert len(nodes) == 2, nodes
            assert c.node("generic/0").read(0x1018, 1) == 0x00CA5D00
            it.log(f"user bus {address}: io.cansim.Cansimd1 answers ListNodes ({len(nodes)} nodes), Read")
    finally:
        os.kill(pid, 15)  # cansimd itself (exec'd by the shell); dbus-run-session then ends
    rc = session.wait(10)
    assert rc == 0, f"dbus-run-session (cansimd --bus user) exit status {rc}"
    it.log("cansimd --bus user: SIGTERM -> exit 0, dbus-run-session exit 0")


def test(ctx: it.Context) -> None:
    if os.geteuid() != 0:
        it.skip("needs root (setpriv to another uid; the VM runs as root)")
    for tool in ["dbus-daemon", "setpriv"]:
        if shutil.which(tool) is None:
            raise AssertionError(f"{tool} not found (scripts/install-deps)")
    system_bus(ctx)
    user_bus(ctx)


it.main(test)
