#!/usr/bin/env python3
"""cansimd as a system service, under systemd as PID 1 (scripts/vm/run
--systemd): the Debian package installed with dpkg -i, then both units run as
a bench PC would run them. Run by scripts/test-all's tier "systemd":

    scripts/vm/run --systemd --cwd REPO -- python3 tests/systemd/test_service.py --deb PATH

Checked, in order:
 1. dpkg -i: user and group cansim (sysusers.d), units, D-Bus policy,
    profiles; nothing enabled or started by the installation;
    `systemd-analyze security --offline=yes` of both installed units <= 2.0,
    and of the loaded units once running.
 2. cansimd.service (the shipped example fleet, /etc/cansimd/cansimd.yaml) and
    cansimd@bench.service (/etc/cansimd/bench.yaml): `systemctl start`
    returns at READY=1 with every boot-up frame on the bus, STATUS= counts
    the nodes, the daemon runs as user cansim; enable puts cansimd.service
    in multi-user.target.
 3. The control API: root on the system bus (io.cansim.Cansimd1) and on both
    private sockets; a uid in group cansim too; a uid outside it is refused by
    the bus policy and by the sockets' mode.
 4. Stored parameters: 0x1017 written and saved (SDO 0x1010:1 "save" from the
    bus; cansimctl store for the instance) land in /var/lib/cansimd/...,
    owned by cansim, mode 0600 (UMask=0077).
 5. The journal: `journalctl -u UNIT CANSIM_NODE=KEY` gives that node's
    lines only (its "parameters stored" among them), CANSIM_IFACE= an
    interface's; each cansimctl action one line with CANSIM_CALLER_UID=.
 6. systemctl reload (SIGHUP) with a node added to the config: its boot-up,
    no other node restarts, same main PID.
 7. The watchdog: SIGSTOP on both main PIDs; systemd kills and restarts them
    (journal: "Watchdog timeout", result 'watchdog'), the fleets boot again
    with their stored 0x1017.
 8. Stopping cansimd.service leaves the instance's socket alone; systemctl
    stop leaves both buses silent and the stored parameters on disk.
 9. dpkg --purge removes the units and /var/lib/cansimd.

The test shortens WatchdogSec= to 10 s and the abort timeout to 5 s with a
drop-in (the shipped 30 s + 10 s would add half a minute); nothing else of the
units is changed. Times are generous: TCG is slow and coarse.
"""

import argparse
import json
import os
import re
import shlex
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "integration", "lib"))
import cansim_it as it  # noqa: E402

MAIN = "cansimd.service"
BENCH = "cansimd@bench.service"
UNITS = (MAIN, BENCH)
NOBODY = 65534
SAVE = 0x65766173  # "save"
EXPOSURE_MAX = 2.0

# The shipped example fleet's nodes on vcan0 (config/cansimd.yaml).
MAIN_VCAN0 = [0x10, 0x11, 0x12, 0x01, 0x7F, 0x20]
BENCH_YAML = """interfaces:
  vcan1: {bit_rate: 250}
nodes:
  - {profile: generic-404, interface: vcan1, node_id: 0x40, count: 2, name: b}
"""
WATCHDOG_DROPIN = """[Service]
WatchdogSec=10s
TimeoutAbortSec=5s
"""

t_start = time.monotonic()


def step(msg: str) -> None:
    it.log(f"[{time.monotonic() - t_start:6.1f}s] {msg}")


def run(*cmd: str, ok: bool = True, user=None, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run cmd (as uid 65534 with the given supplementary gids when user is a
    list); with ok=True a non-zero exit fails the test."""
    argv = list(cmd)
    if user is not None:
        groups = [f"--groups={','.join(map(str, user))}"] if user else ["--clear-groups"]
        argv = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", *groups, "--", *argv]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    if ok and r.returncode != 0:
        raise AssertionError(f"{shlex.join(argv)}: exit {r.returncode}\n{r.stdout}{r.stderr}")
    return r


def prop(unit: str, name: str) -> str:
    return run("systemctl", "show", "-P", name, unit).stdout.strip()


def journal(*matches: str) -> list:
    out = run("journalctl", "--no-pager", "-o", "json", *matches).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def messages(entries: list) -> list:
    return [e.get("MESSAGE", "") for e in entries]


def exposure(*args: str) -> float:
    out = run("systemd-analyze", "security", "--no-pager", *args).stdout
    m = re.search(r"Overall exposure level for \S+: ([0-9.]+)", out)
    assert m, f"systemd-analyze security {args}: no exposure level in\n{out}"
    return float(m.group(1))


def boot_ups(bus, ids: list, timeout: float, what: str) -> None:
    """Every node of ids sends its boot-up (in any order) within timeout (scaled)."""
    want = set(ids)
    deadline = time.monotonic() + it.scaled(timeout)
    while want and time.monotonic() < deadline:
        m = it.wait_for(bus, lambda m: m.arbitration_id - 0x700 in want and bytes(m.data) == b"\x00",
                        deadline - time.monotonic())
        if m is not None:
            want.discard(m.arbitration_id - 0x700)
    assert not want, f"{what}: no boot-up from node(s) {', '.join(f'0x{n:02X}' for n in sorted(want))}"


def write_file(path: str, text: str) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


def install(deb: str) -> None:
    # man-db's index rebuild (a dpkg trigger) reads every man page over 9p:
    # minutes under TCG. The guest's overlay only.
    if os.path.exists("/var/lib/man-db/auto-update"):
        os.unlink("/var/lib/man-db/auto-update")
    step(f"dpkg -i {os.path.basename(deb)}")
    run("dpkg", "-i", deb, timeout=300)
    run("getent", "passwd", "cansim")
    gid = int(run("getent", "group", "cansim").stdout.split(":")[2])
    for f in ["/usr/bin/cansimd", "/usr/bin/cansimctl", "/lib/systemd/system/cansimd.service",
              "/lib/systemd/system/cansimd@.service", "/usr/lib/sysusers.d/cansimd.conf",
              "/usr/share/dbus-1/system.d/io.cansim.Cansimd1.conf", "/etc/cansimd/cansimd.yaml",
              "/usr/share/cansimd/profiles/generic-404.yaml", "/usr/share/man/man8/cansimd.8.gz",
              "/usr/share/bash-completion/completions/cansimctl"]:
        assert os.path.exists(f), f"{f} not installed"
    assert "/etc/cansimd/cansimd.yaml" in run("dpkg-query", "-W", "-f=${Conffiles}", "cansimd").stdout
    for u in UNITS:
        assert prop(u, "ActiveState") == "inactive", f"{u} runs after dpkg -i"
    assert run("systemctl", "is-enabled", MAIN, ok=False).stdout.strip() == "disabled"
    step(f"user and group cansim (gid {gid}), files and conffile in place, nothing started or enabled")

    for path in ["/lib/systemd/system/cansimd.service", "/lib/systemd/system/cansimd@.service"]:
        e = exposure("--offline=yes", path)
        step(f"systemd-analyze security --offline=yes {path}: {e}")
        assert e <= EXPOSURE_MAX, f"{path}: exposure {e} > {EXPOSURE_MAX}"

    for u in ("cansimd.service", "cansimd@.service"):
        write_file(f"/etc/systemd/system/{u}.d/50-test-watchdog.conf", WATCHDOG_DROPIN)
    write_file("/etc/cansimd/bench.yaml", BENCH_YAML)
    run("systemctl", "daemon-reload")


def start(bus0, bus1) -> dict:
    run("systemctl", "enable", MAIN)
    assert MAIN in prop("multi-user.target", "Wants").split(), "enable: multi-user.target does not want cansimd"
    it.drain(bus0)
    it.drain(bus1)
    step("systemctl start cansimd (the shipped example fleet)")
    run("systemctl", "start", MAIN)
    # Type=notify: start returns after READY=1, which follows the boot-ups.
    boot_ups(bus0, MAIN_VCAN0, 2, "cansimd.service on vcan0")
    step(f"READY: boot-ups of {len(MAIN_VCAN0)} nodes on vcan0; STATUS={prop(MAIN, 'StatusText')}")
    assert re.match(r"9 node\(s\), 2/2 interface\(s\) up", prop(MAIN, "StatusText")), prop(MAIN, "StatusText")
    it.expect(bus0, it.is_heartbeat(0x10), 3, "heartbeats of node 0x10")

    step("systemctl start cansimd@bench (/etc/cansimd/bench.yaml on vcan1)")
    run("systemctl", "start", BENCH)
    boot_ups(bus1, [0x40, 0x41], 2, "cansimd@bench on vcan1")
    assert re.match(r"2 node\(s\), 1/1 interface\(s\) up", prop(BENCH, "StatusText")), prop(BENCH, "StatusText")
    pids = {}
    for u in UNITS:
        assert prop(u, "ActiveState") == "active"
        pids[u] = int(prop(u, "MainPID"))
        with open(f"/proc/{pids[u]}/status") as f:
            uid = next(line.split()[1] for line in f if line.startswith("Uid:"))
        user = run("getent", "passwd", uid).stdout.split(":")[0]
        assert user == "cansim", f"{u} runs as {user} (uid {uid})"
        e = exposure(u)
        assert e <= EXPOSURE_MAX, f"{u} (loaded, with the test's drop-in): exposure {e}"
    step(f"both running as user cansim (main PIDs {pids[MAIN]}, {pids[BENCH]}); loaded units' exposure <= 2.0")
    return pids


def control_api(gid: int) -> None:
    ctl = "cansimctl"
    sockets = {MAIN: "/run/cansimd/control", BENCH: "/run/cansimd/bench/control"}
    for u, s in sockets.items():
        assert os.path.exists(s), f"{u}: no control socket {s}"
    nodes = json.loads(run(ctl, "--system", "--json", "list").stdout)
    assert len(nodes) == 9, nodes
    assert len(json.loads(run(ctl, "--socket", sockets[BENCH], "--json", "list").stdout)) == 2
    assert run(ctl, "read", "generic/0", "0x1018:1").returncode == 0  # default address: /run/cansimd/control
    step("root: cansimctl on the system bus (9 nodes), the private sockets of both units")

    for args in (["--system", "list"], ["list"], ["--socket", sockets[BENCH], "list"]):
        run(ctl, *args, user=[gid])
    step("a uid in group cansim: the same three calls work")

    # dbus-daemon's AccessDenied: "Rejected send message, N matched rules; ..."
    refused = run(ctl, "--system", "list", user=[], ok=False)
    assert refused.returncode == 1 and "Rejected send message" in refused.stderr, \
        f"system bus, uid outside cansim: exit {refused.returncode}: {refused.stderr}"
    for s in sockets.values():
        r = run(ctl, "--socket", s, "list", user=[], ok=False)
        assert r.returncode == 1 and "ermission denied" in r.stderr, f"{s}, uid outside cansim: {r.stderr}"
    step(f"a uid outside cansim: refused by the bus policy ({refused.stderr.strip()[:60]}...) and by both sockets")


def python_client(gid: int) -> None:
    """The package's Python module, plugin, EDS files and tools, used as a
    bench user would: a uid in group cansim connects to the running service."""
    where = run("/usr/bin/python3", "-c", "import cansim; print(cansim.__file__)", user=[gid]).stdout.strip()
    assert where == "/usr/lib/python3/dist-packages/cansim/__init__.py", where
    code = ("import cansim\n"
            "with cansim.connect() as sim:\n"  # the default address: /run/cansimd/control
            "    node = sim.node('generic/0')\n"
            "    node.pressure.set(4.5, 'bar')\n"
            "    print(len(sim.nodes()), node.pressure.true_value, node.pressure.unit)\n")
    assert run("/usr/bin/python3", "-c", code, user=[gid]).stdout.split() == ["9", "4.5", "bar"]
    assert "--cansim-config=PATH" in run("/usr/bin/python3", "-m", "pytest", "--help").stdout
    eds = sorted(os.listdir("/usr/share/cansimd/eds"))
    assert eds == [f"{p}.eds" for p in ("actuator-401", "cmp", "dps", "gems9000", "generic-404", "p92c", "smc")], eds
    assert os.path.exists("/usr/share/cansimd/profiles/actuator-401.yaml")
    for tool in ("decode.py", "plot-recording"):
        assert os.access(f"/usr/share/cansimd/scripts/{tool}", os.X_OK), tool
    assert os.path.exists("/usr/share/doc/cansimd/examples/hil_bench_test.py")
    for f in ("README.md", "fleet.yaml", "controller.py", "test_closed_loop.py"):
        assert os.path.exists(f"/usr/share/doc/cansimd/examples/closed_loop/{f}"), f
    step("python3 -c 'import cansim' from dist-packages; cansim.connect() as a uid in group cansim: 9 nodes, "
         "set 4.5 bar; the pytest plugin, 7 EDS files, decode.py, plot-recording and the examples installed")


def store(bus0) -> None:
    sdo = it.SdoClient(bus0, 0x10)
    sdo.download_u16(0x1017, 0, 500)
    sdo.download_u32(0x1010, 1, SAVE)
    run("cansimctl", "--socket", "/run/cansimd/bench/control", "write", "b/0", "0x1017", "700")
    run("cansimctl", "--socket", "/run/cansimd/bench/control", "store", "b/0")
    for path in ["/var/lib/cansimd/vcan0@generic@0.params", "/var/lib/cansimd/bench/vcan1@b@0.params"]:
        st = os.stat(path)
        owner = run("stat", "-c", "%U:%G", path).stdout.strip()
        assert owner == "cansim:cansim" and (st.st_mode & 0o777) == 0o600, f"{path}: {owner} {oct(st.st_mode)}"
    step("stored: 0x1017 = 500 ms on vcan0/generic/0 (SDO save), 700 ms on vcan1/b/0 (cansimctl store); "
         "files cansim:cansim 0600")


def journal_fields() -> None:
    for unit, key, other in [(MAIN, "vcan0/generic/0", "vcan0/dps/0"), (BENCH, "vcan1/b/0", "vcan1/b/1")]:
        mine = journal("-u", unit, f"CANSIM_NODE={key}")
        assert mine, f"journalctl -u {unit} CANSIM_NODE={key}: nothing"
        assert all(e.get("CANSIM_NODE") == key for e in mine), [e.get("CANSIM_NODE") for e in mine]
        assert any("parameters stored" in m for m in messages(mine)), messages(mine)
        assert not journal("-u", unit, f"CANSIM_NODE={other}"), f"{other} has lines although nothing happened to it"
        step(f"journalctl -u {unit} CANSIM_NODE={key}: {messages(mine)}")
    # Every control action: one line with its node, the caller's uid and the outcome (store() did these).
    actions = journal("-u", BENCH, "CANSIM_NODE=vcan1/b/0", "CANSIM_CALLER_UID=0")
    assert [m for m in messages(actions) if m.startswith("control: vcan1/b/0: ")] == [
        "control: vcan1/b/0: Write 0x1017:00 700 by uid 0: done",
        "control: vcan1/b/0: Store 1 by uid 0: done"], messages(actions)
    assert all(e.get("CANSIM_IFACE") == "vcan1" for e in actions), actions
    step(f"journalctl -u {BENCH} CANSIM_NODE=vcan1/b/0 CANSIM_CALLER_UID=0: {messages(actions)}")
    vcan1 = journal("-u", MAIN, "CANSIM_IFACE=vcan1")
    assert vcan1 and all(e.get("CANSIM_IFACE") == "vcan1" for e in vcan1)
    assert any(m.startswith("vcan1: open") for m in messages(vcan1)), messages(vcan1)
    step(f"journalctl -u {MAIN} CANSIM_IFACE=vcan1: {len(vcan1)} line(s), e.g. {messages(vcan1)[0]!r}")


def reload(bus0, bus1, pids: dict) -> None:
    with open("/etc/cansimd/cansimd.yaml", "a") as f:
        f.write("  - {profile: generic-404, interface: vcan0, node_id: 0x30, name: added}\n")
    with open("/etc/cansimd/bench.yaml", "a") as f:
        f.write("  - {profile: generic-404, interface: vcan1, node_id: 0x42, name: c}\n")
    it.drain(bus0)
    it.drain(bus1)
    step("config changed (a node added to each fleet): systemctl reload both")
    run("systemctl", "reload", *UNITS)
    old0 = set(MAIN_VCAN0)
    m = it.expect(bus0, lambda m: bytes(m.data) == b"\x00" and m.arbitration_id - 0x700 in old0 | {0x30}, 5,
                  "boot-up of node 0x30 on vcan0")
    assert m.arbitration_id == 0x730, f"reload restarted a node that did not change: {it.fmt(m)}"
    m = it.expect(bus1, lambda m: bytes(m.data) == b"\x00" and m.arbitration_id in (0x740, 0x741, 0x742), 5,
                  "boot-up of node 0x42 on vcan1")
    assert m.arbitration_id == 0x742, f"reload restarted a node that did not change: {it.fmt(m)}"
    for u in UNITS:
        assert int(prop(u, "MainPID")) == pids[u], f"{u}: reload changed the main PID"
    deadline = time.monotonic() + it.scaled(5)
    while "10 node(s)" not in prop(MAIN, "StatusText"):
        assert time.monotonic() < deadline, f"STATUS= after the reload: {prop(MAIN, 'StatusText')}"
        time.sleep(0.2)
    assert any("1 started" in m for m in messages(journal("-u", MAIN, "-g", "^fleet: 10 node")))
    step(f"reloaded: only the new nodes booted, same PIDs; STATUS={prop(MAIN, 'StatusText')}")


def watchdog(bus0, bus1, pids: dict) -> dict:
    it.drain(bus0)
    it.drain(bus1)
    for u in UNITS:
        os.kill(pids[u], 19)  # SIGSTOP: the loop stops, its WATCHDOG=1 pings too
    step("SIGSTOP on both main PIDs; waiting for systemd's watchdog")
    new = {}
    deadline = time.monotonic() + 120
    while len(new) < len(UNITS):
        assert time.monotonic() < deadline, {u: (prop(u, "ActiveState"), prop(u, "NRestarts")) for u in UNITS}
        for u in UNITS:
            if u not in new and int(prop(u, "NRestarts")) >= 1 and prop(u, "ActiveState") == "active":
                new[u] = int(prop(u, "MainPID"))
        time.sleep(0.5)
    for u in UNITS:
        assert new[u] != pids[u]
        text = "\n".join(messages(journal("-u", u)))
        for why in ["Watchdog timeout", "Failed with result 'watchdog'", "Scheduled restart job"]:
            assert why in text, f"{u}: journal lacks {why!r}"
    step(f"both killed ('Watchdog timeout', result 'watchdog') and restarted: PIDs {new[MAIN]}, {new[BENCH]}")
    boot_ups(bus0, MAIN_VCAN0 + [0x30], 5, "cansimd.service after the watchdog restart")
    boot_ups(bus1, [0x40, 0x41, 0x42], 5, "cansimd@bench after the watchdog restart")
    assert it.SdoClient(bus0, 0x10).upload_u16(0x1017) == 500
    r = run("cansimctl", "--socket", "/run/cansimd/bench/control", "--json", "read", "b/0", "0x1017")
    assert "700" in r.stdout, r.stdout
    step("the fleets booted again with their stored heartbeat times (500 ms, 700 ms)")
    return new


def stop(bus0, bus1) -> None:
    run("systemctl", "stop", MAIN)
    assert prop(MAIN, "Result") == "success" and prop(MAIN, "ExecMainStatus") == "0"
    assert os.path.exists("/run/cansimd/bench/control"), "stopping cansimd.service removed the instance's socket"
    run("cansimctl", "--socket", "/run/cansimd/bench/control", "list")
    step("cansimd.service stopped (exit 0); cansimd@bench's socket still answers")
    run("systemctl", "stop", BENCH)
    it.drain(bus0)
    it.drain(bus1)
    heard = it.collect(bus0, 2.0) + it.collect(bus1, 2.0)
    assert not heard, f"frames after systemctl stop: {[it.fmt(m) for m in heard[:5]]}"
    for path in ["/var/lib/cansimd/vcan0@generic@0.params", "/var/lib/cansimd/bench/vcan1@b@0.params"]:
        assert os.path.exists(path), f"{path} gone after stop"
    assert any("stopping" in m for m in messages(journal("-u", BENCH, "-g", "stopping")))
    step("both stopped: vcan0 and vcan1 silent for 2 s each, stored parameters still in /var/lib/cansimd")


def purge() -> None:
    run("dpkg", "--purge", "cansimd", timeout=300)
    for f in ["/usr/bin/cansimd", "/lib/systemd/system/cansimd.service", "/var/lib/cansimd",
              "/etc/systemd/system/multi-user.target.wants/cansimd.service"]:
        assert not os.path.lexists(f), f"{f} left after dpkg --purge"
    step("dpkg --purge: binaries, units, enablement link and /var/lib/cansimd gone (user cansim kept)")


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--deb", required=True)
    a = p.parse_args()
    try:
        with open("/proc/1/comm") as f:
            assert f.read().strip() == "systemd", "PID 1 is not systemd (run inside scripts/vm/run --systemd)"
        install(os.path.abspath(a.deb))
        gid = int(run("getent", "group", "cansim").stdout.split(":")[2])
        with it.open_bus("vcan0") as bus0, it.open_bus("vcan1") as bus1:
            pids = start(bus0, bus1)
            control_api(gid)
            python_client(gid)
            store(bus0)
            journal_fields()
            reload(bus0, bus1, pids)
            watchdog(bus0, bus1, pids)
            stop(bus0, bus1)
        purge()
    except BaseException as e:  # noqa: BLE001
        import traceback
        traceback.print_exc()
        for u in UNITS:
            print(f"---- journalctl -u {u} (last 40) ----", file=sys.stderr)
            print(run("journalctl", "--no-pager", "-n", "40", "-u", u, ok=False).stdout, file=sys.stderr)
        print(f"FAIL test_service.py after {time.monotonic() - t_start:.0f}s: {e}", file=sys.stderr, flush=True)
        return 1
    print(f"PASS test_service.py ({time.monotonic() - t_start:.1f}s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
