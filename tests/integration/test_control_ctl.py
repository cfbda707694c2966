#!/usr/bin/env python3
"""cansimctl (src/ctl/, the command-line client of the control API) against a
running fleet: every verb, run as a subprocess on the private socket, its exit
status and its output (human and --json) checked, and what it did checked on
vcan0 with python-can, as a bench would see it.

Fleet: two generic-404 nodes (0x10, 0x11, entry "generic", count 2) and a
Honeywell DPS (0x7F, entry "dps") on vcan0 at 250 kbit/s; cansimd with
--control-socket {tmp}/control --bus none. cansimctl is taken from the
directory of the cansimd under test (the build dir); missing: skip (77).

  list / status        human table and --json fields
  watch NODE --json    in the background: a master SDO download -> an
                       ObjectWritten line (via sdo, the value); nmt start ->
                       NmtStateChanged
  nmt                  heartbeat state byte 05 / 04 on the wire
  set / --ramp / hold  next TPDO1 (REAL32 bar) within 0.02; the ramp moves
                       toward the target; hold freezes it
  model / restore-model, override / --off, record / --stop
  fault --for 1s       prints an id; EMCY 0x2201 from 0xFF, error reset ~1 s later
  fault / faults / cancel
  power-cycle --off    silence, boot-up 0x711 [00] >= 0.5 s later
  read / write         0x1018:4; 0x1017 = 200 -> heartbeat every 200 ms on the
                       wire, SDO upload by the test returns 200
  store / restore      stored heartbeat period survives an NMT reset; restored
                       defaults after the next one
  add / remove         boot-up of the new node; it falls silent
  reload, time, stats, and bad command lines (2 + usage) / refusals (1 + one line)
"""

# ctest-timeout: 240

import concurrent.futures
import json
import os
import struct
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

G0, G1, DPS, ADDED = 0x10, 0x11, 0x7F, 0x20
KEYS = {"vcan0/generic/0": G0, "vcan0/generic/1": G1, "vcan0/dps/0": DPS}


def from_node(node: int):
    """Any frame a node sends (its COB-IDs carry its node-ID in the low 7 bits)."""
    return lambda m: m.arbitration_id & 0x7F == node and m.arbitration_id >= 0x80


def tpdo1_bar(m) -> float:
    """generic-404 TPDO1: REAL32 PV 0x6130:01 (bar) + status 0x6150:01."""
    assert m.dlc == 5, f"generic-404 TPDO1 must be REAL32 + status (DLC 5): {it.fmt(m)}"
    return struct.unpack_from("<f", bytes(m.data))[0]


def collect_n(bus, pred, n: int, timeout: float) -> list:
    """Frames matching pred until there are n of them or timeout seconds
    (unscaled) have passed."""
    out = []
    deadline = time.monotonic() + timeout
    while len(out) < n:
        m = it.wait_for(bus, pred, deadline - time.monotonic())
        if m is None:
            break
        out.append(m)
    return out


def next_tpdo1(bus, node: int = G0):
    """The next TPDO1 of node sent after this call (older ones dropped: the
    daemon sent them before it handled the call cansimctl got its answer to)."""
    it.drain(bus)
    return it.expect(bus, it.is_tpdo(node, 1), 2, f"TPDO1 of node 0x{node:02X}")


# --------------------------------------------------------------------------
# running cansimctl

class Ctl:
    """Runs `cansimctl --socket SOCK [--json] ARGS...` and checks the exit
    status: 0 done; 1 refused: one line "cansimctl: reason" on stderr, nothing
    on stdout; 2 bad command line: the reason and the usage on stderr."""

    def __init__(self, binary: str, sock: str):
        self.binary = binary
        self.sock = sock
        self.calls = 0

    def argv(self, *args: str, json_out: bool = False) -> list:
        return [self.binary, "--socket", self.sock] + (["--json"] if json_out else []) + list(args)

    def run(self, *args: str, json_out: bool = False, rc: int = 0) -> subprocess.CompletedProcess:
        argv = self.argv(*args, json_out=json_out)
        p = subprocess.run(argv, capture_output=True, text=True, timeout=it.scaled(20), stdin=subprocess.DEVNULL)
        self.calls += 1
        what = f"cansimctl {' '.join(argv[3:])}"
        if p.returncode != rc:
            raise AssertionError(f"{what}: exit status {p.returncode}, expected {rc}\n"
                                 f"stdout: {p.stdout!r}\nstderr: {p.stderr!r}")
        if rc == 0:
            assert p.stderr == "", f"{what}: stderr {p.stderr!r}"
        elif rc == 1:
            lines = p.stderr.splitlines()
            assert len(lines) == 1 and lines[0].startswith("cansimctl: ") and len(lines[0]) > 12, \
                f"{what}: refused, but stderr is not one line with the reason: {p.stderr!r}"
            assert p.stdout == "", f"{what}: refused, but stdout {p.stdout!r}"
        elif rc == 2:
            assert p.stderr.startswith("cansimctl: ") and "\nusage: cansimctl " in p.stderr, \
                f"{what}: bad command line, but stderr lacks the reason and the usage: {p.stderr!r}"
            assert p.stdout == "", f"{what}: bad command line, but stdout {p.stdout!r}"
        return p

    def ok(self, *args: str) -> str:
        """Runs a verb that must succeed; returns its stdout."""
        return self.run(*args).stdout

    def json(self, *args: str):
        """Runs a verb with --json that must succeed; returns the parsed JSON (one document)."""
        out = self.run(*args, json_out=True).stdout
        assert out.endswith("\n") and out.count("\n") == 1, f"cansimctl --json {' '.join(args)}: {out!r}"
        return json.loads(out)

    def refused(self, *args: str) -> str:
        """Runs a command the daemon refuses (exit 1); returns the reason."""
        return self.run(*args, rc=1).stderr.strip()


WATCH_KEYS = {"time", "node", "kind", "fields"}


def flat(event: dict) -> dict:
    """A watch event {"time", "node", "kind", "fields": [{"name", "value"}]}
    as one dict: the fields by name beside kind, node and time."""
    out = {f["name"]: f["value"] for f in event["fields"]}
    out.update(kind=event["kind"], node=event["node"], time=event["time"])
    return out


class Watch:
    """`cansimctl --json watch NODE` in the background; a thread collects its
    lines (one JSON object each, in the vocabulary of docs/cansimctl.md:
    WATCH_KEYS; events holds them flat)."""

    def __init__(self, ctl: Ctl, node: str, err_path: str):
        self._err = open(err_path, "w")
        self.err_path = err_path
        self.proc = subprocess.Popen(ctl.argv("watch", node, json_out=True), stdin=subprocess.DEVNULL,
                                     stdout=subprocess.PIPE, stderr=self._err, text=True)
        self.lines = []
        self.events = []
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._read, name="watch", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            with self._cond:
                self.lines.append(line)
                try:
                    e = json.loads(line)
                    self.events.append(flat(e) if set(e) == WATCH_KEYS else {"unparsed": line})
                except ValueError:
                    self.events.append({"unparsed": line})
                self._cond.notify_all()

    def mark(self) -> int:
        with self._cond:
            return len(self.events)

    def wait(self, pred, timeout: float, start: int = 0):
        """The first event at index >= start matching pred within timeout (unscaled), else None."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for e in self.events[start:]:
                    if pred(e):
                        return e
                left = deadline - time.monotonic()
                if left <= 0 or self.proc.poll() is not None and not self._thread.is_alive():
                    return None
                self._cond.wait(min(left, 0.2))

    def expect(self, pred, timeout: float, what: str, start: int = 0):
        e = self.wait(pred, it.scaled(timeout), start)
        if e is None:
            raise AssertionError(f"cansimctl watch: no {what} within {it.scaled(timeout):.1f}s; "
                                 f"last lines: {self.lines[-8:]}; stderr: {self.stderr()!r}")
        return e

    def stderr(self) -> str:
        if not self._err.closed:
            self._err.flush()
        with open(self.err_path) as f:
            return f.read()

    def stop(self) -> int:
        return it.stop_process(self.proc, self._thread, self._err)


# --------------------------------------------------------------------------
# the checks, in order

def list_and_status(ctl: Ctl) -> None:
    out = ctl.ok("list").splitlines()
    assert out[0].split() == ["KEY", "NAME", "INTERFACE", "ID", "PROFILE", "PERSONALITY", "NMT"], out
    rows = {line.split()[0]: line.split() for line in out[1:]}
    assert set(rows) == set(KEYS), f"cansimctl list: {out}"
    assert rows["vcan0/generic/1"] == ["vcan0/generic/1", "generic", "vcan0", "0x11", "generic-404", "generic",
                                       "pre-operational"], rows["vcan0/generic/1"]
    assert rows["vcan0/dps/0"][3:6] == ["0x7f", "dps", "honeywell-dps"], rows["vcan0/dps/0"]
    nodes = ctl.json("list")
    by_key = {n["node"]: n for n in nodes}
    assert len(nodes) == 3 and set(by_key) == set(KEYS), nodes
    for key, nid in KEYS.items():
        n = by_key[key]
        iface, name, index = key.split("/")
        assert (n["node_id"], n["interface"], n["name"], n["nmt_state"]) == (nid, iface, name, "pre-operational"), n
        assert n["path"] == it.control_node_path(iface, name, int(index)), n
    assert (by_key["vcan0/generic/0"]["profile"], by_key["vcan0/generic/0"]["personality"]) == \
        ("generic-404", "generic"), by_key["vcan0/generic/0"]
    assert (by_key["vcan0/dps/0"]["profile"], by_key["vcan0/dps/0"]["personality"]) == \
        ("dps", "honeywell-dps"), by_key["vcan0/dps/0"]
    it.log(f"list: {len(out) - 1} rows; --json: {[(n['node'], hex(n['node_id']), n['nmt_state']) for n in nodes]}")

    text = ctl.ok("status", "generic/0").splitlines()
    assert text[0] == "vcan0/generic/0", text
    fields = {line.strip().split("  ")[0]: line.strip().split("  ", 1)[1].strip() for line in text[1:]}
    assert fields["node-ID"] == "0x10 (16)" and fields["NMT state"] == "pre-operational" and \
        fields["profile"] == "generic-404" and fields["power"] == "on, on the bus", fields
    assert fields["pressure"].endswith("status 0x00") and " bar reported, " in fields["pressure"], fields
    s = ctl.json("status", "dps")
    want = {"path": it.control_node_path("vcan0", "dps", 0), "node": "vcan0/dps/0", "name": "dps", "entry_index": 0,
            "profile": "dps", "personality": "honeywell-dps", "interface": "vcan0", "node_id": DPS,
            "nmt_state": "pre-operational", "powered": True, "on_bus": True, "overrides": [], "faults": [],
            "emcy_count": 0, "last_emcy": None, "recording": None, "temperature": None}
    assert {k: s.get(k) for k in want} == want, s
    assert set(s["pressure"]) == {"value", "true_value", "unit", "status", "counts"}, s["pressure"]
    assert s["pressure"]["unit"] and isinstance(s["pressure"]["true_value"], float) and \
        s["pressure"]["status"] == 0 and s["pressure"]["counts"] is None, s
    g = ctl.json("status", "vcan0/0x10")
    assert g["node"] == "vcan0/generic/0" and g["pressure"]["unit"] == "bar" and g["temperature"]["unit"] == "degC", g
    it.log(f"status: human {len(text)} lines; --json dps pressure {s['pressure']}, generic/0 by vcan0/0x10")


def start_watch(ctl: Ctl, bus, ctx: it.Context) -> Watch:
    """watch generic/0 --json; a master SDO download -> ObjectWritten via sdo.
    The watch subscribes some time after it starts: download until it prints."""
    w = Watch(ctl, "generic/0", os.path.join(ctx.tmp, "watch.err"))
    sdo = it.SdoClient(bus, G0)
    deadline = time.monotonic() + it.scaled(5)
    value, seen = 0xC0DE0000, None
    while seen is None and time.monotonic() < deadline:
        value += 1
        sdo.download_u32(0x2100, 1, value)
        seen = w.wait(lambda e, v=value: e.get("kind") == "ObjectWritten" and e.get("value") == v, 0.3)
        if w.proc.poll() is not None:
            raise AssertionError(f"cansimctl watch exited with {w.proc.returncode}: {w.stderr()!r}")
    if seen is None:
        raise AssertionError(f"cansimctl watch printed no ObjectWritten for master SDO downloads of 0x2100:01; "
                             f"lines: {w.lines[-8:]}; stderr: {w.stderr()!r}")
    assert seen["node"] == "vcan0/generic/0" and seen["index"] == 0x2100 and seen["sub"] == 1 and \
        seen["via"] == "sdo" and isinstance(seen["time"], float) and seen["time"] > 0, seen
    # One more, now that it listens: this exact one must show up.
    mark = w.mark()
    sdo.download_u32(0x2100, 1, 0xCAFEBABE)
    e = w.expect(lambda e: e.get("kind") == "ObjectWritten", 2, "ObjectWritten of 0x2100:01", mark)
    assert (e["index"], e["sub"], e["value"], e["via"]) == (0x2100, 1, 0xCAFEBABE, "sdo"), e
    it.log(f"watch generic/0 --json: master SDO download 0x2100:01 = 0xCAFEBABE -> {w.lines[-1].strip()}")
    return w


def nmt_checks(ctl: Ctl, bus, w: Watch) -> None:
    mark = w.mark()
    it.drain(bus)
    assert ctl.ok("nmt", "generic/0", "start") == ""
    hb = it.expect(bus, it.is_heartbeat(G0, it.STATE_OPERATIONAL), 3, "operational heartbeat 0x710 [05]")
    it.expect(bus, it.is_tpdo(G0, 1), 2, "TPDO1 of 0x10 after nmt start")
    e = w.expect(lambda e: e.get("kind") == "NmtStateChanged", 2, "NmtStateChanged", mark)
    assert (e["node"], e["old"], e["new"]) == ("vcan0/generic/0", "pre-operational", "operational"), e
    it.log(f"nmt generic/0 start: {it.fmt(hb)} on the wire; watch: {json.dumps(e)}")

    it.drain(bus)
    ctl.ok("nmt", "dps", "start")
    t = it.expect(bus, it.is_tpdo(DPS, 1), 3, "TPDO1 of the DPS after nmt dps start")
    it.log(f"nmt dps start: TPDO1 {it.fmt(t)}")


def measurement(ctl: Ctl, bus, ctx: it.Context) -> None:
    rec = os.path.join(ctx.tmp, "g0.csv")
    assert ctl.ok("record", "generic/0", rec) == ""
    assert ctl.json("status", "generic/0")["recording"] == rec

    # set: a step of the true value
    assert ctl.ok("set", "generic/0", "pressure", "3", "bar") == ""
    v = it.pdo_after_call(bus, G0, 1, tpdo1_bar, lambda x: abs(x - 3.0) <= 0.02, "TPDO1 after set 3 bar")
    p = ctl.json("status", "generic/0")["pressure"]
    assert p["unit"] == "bar" and abs(p["true_value"] - 3.0) < 1e-9, p
    it.log(f"set generic/0 pressure 3 bar: next TPDO1 {v:.4f} bar; status true {p['true_value']}")
    # Acting verbs answer with JSON: the node (its key) and ok.
    assert ctl.json("set", "generic/0", "pressure", "3", "bar") == {"node": "vcan0/generic/0", "ok": True}

    # set --ramp: 3 -> 8 bar over 10 s, watched for 1.5 s; then hold
    it.drain(bus)
    assert ctl.ok("set", "generic/0", "pressure", "8", "bar", "--ramp", "10s") == ""
    values = [tpdo1_bar(x) for x in it.collect(bus, 1.5, it.is_tpdo(G0, 1))]
    assert len(values) >= 4, f"{len(values)} TPDO1s in 1.5 s during the ramp"
    assert all(2.98 <= x <= 8.02 for x in values), f"ramp 3 -> 8 bar: {values}"
    assert all(b >= a - 0.01 for a, b in zip(values, values[1:])), f"the ramp must rise: {values}"
    assert values[-1] - values[0] >= 0.2, f"the ramp (0.5 bar/s) did not move in 1.5 s: {values}"
    it.log(f"set --ramp 10s to 8 bar: {len(values)} TPDO1s rising {values[0]:.3f} -> {values[-1]:.3f} bar")

    assert ctl.ok("hold", "generic/0", "pressure") == ""
    held = ctl.json("status", "generic/0")["pressure"]["true_value"]
    assert values[-1] - 0.02 <= held < 7.9, f"held at {held} after the ramp reached {values[-1]:.3f}"
    it.drain(bus)
    after = [tpdo1_bar(x) for x in it.collect(bus, 0.6, it.is_tpdo(G0, 1))]
    assert after and all(abs(x - held) <= 0.02 for x in after), f"TPDO1s after hold at {held:.4f}: {after}"
    again = ctl.json("status", "generic/0")["pressure"]["true_value"]
    assert again == held, f"true value {again} after hold at {held}"
    it.log(f"hold: true value stays {held:.4f} bar, {len(after)} TPDO1s {min(after):.4f}..{max(after):.4f}")

    # model: a constant 4 bar; restore-model: the profile's (5 bar + OU noise)
    # A term list starts with "- ": cansimctl takes it as a value, not an option.
    assert ctl.ok("model", "generic/0", "pressure", "- constant: 4 bar") == ""
    v = it.pdo_after_call(bus, G0, 1, tpdo1_bar, lambda x: abs(x - 4.0) <= 0.02, "TPDO1 after model '- constant: 4 bar'")
    it.log(f"model generic/0 pressure -- '- constant: 4 bar': next TPDO1 {v:.4f} bar")
    assert ctl.ok("model", "generic/0", "pressure", "constant: 4.5 bar") == ""
    v = it.pdo_after_call(bus, G0, 1, tpdo1_bar, lambda x: abs(x - 4.5) <= 0.02, "TPDO1 after model 'constant: 4.5 bar'")
    it.log(f"model generic/0 pressure 'constant: 4.5 bar' (one term): next TPDO1 {v:.4f} bar")
    assert ctl.ok("restore-model", "generic/0", "pressure") == ""
    v = it.pdo_after_call(bus, G0, 1, tpdo1_bar, lambda x: abs(x - 5.0) <= 0.5 and abs(x - 4.5) > 0.02,
                          "TPDO1 after restore-model (profile: 5 bar + OU)")
    it.log(f"restore-model: next TPDO1 {v:.4f} bar (profile: 5 bar, OU sigma 0.1 bar)")

    # override: the exact float on the wire, whatever the sensor says
    assert ctl.ok("override", "generic/0", "pressure", "7.5", "bar") == ""
    want = struct.pack("<f", 7.5)
    first = next_tpdo1(bus)
    frames = [first] + it.collect(bus, 0.4, it.is_tpdo(G0, 1))
    for x in frames:
        assert bytes(x.data[:4]) == want, f"TPDO1 under override 7.5 bar: {it.fmt(x)}, want {want.hex()}"
    s = ctl.json("status", "generic/0")
    assert len(s["overrides"]) == 1 and s["overrides"][0] == {"channel": "pressure", "value": 7.5, "unit": "bar"}, s
    assert abs(s["pressure"]["value"] - 7.5) < 1e-6 and abs(s["pressure"]["true_value"] - 5.0) <= 0.5, s["pressure"]
    it.log(f"override 7.5 bar: {len(frames)} TPDO1s carry exactly {want.hex()}; status overrides {s['overrides']}")
    assert ctl.ok("override", "generic/0", "--off") == ""  # no channel: every channel
    m = next_tpdo1(bus)
    v = tpdo1_bar(m)
    s = ctl.json("status", "generic/0")
    assert bytes(m.data[:4]) != want and abs(v - s["pressure"]["true_value"]) <= 0.05, \
        f"TPDO1 after override --off: {it.fmt(m)} = {v:.4f}, true value {s['pressure']['true_value']}"
    assert s["overrides"] == [], s
    it.log(f"override --off: TPDO1 {v:.4f} bar (true {s['pressure']['true_value']:.4f})")

    # record --stop: the file has rows
    assert ctl.ok("record", "generic/0", "--stop") == ""
    assert ctl.json("status", "generic/0")["recording"] is None
    with open(rec) as f:
        lines = [x for x in f.read().splitlines() if x.strip()]
    assert len(lines) >= 5 and "," in lines[0], f"recording {rec}: {lines[:5]}"
    n = len(lines)
    time.sleep(0.3)
    with open(rec) as f:
        assert len([x for x in f.read().splitlines() if x.strip()]) == n, "the recording grows after record --stop"
    it.log(f"record / record --stop: {rec} has {n} lines, header {lines[0]!r}, e.g. {lines[len(lines) // 2]!r}")


def faults(ctl: Ctl, bus) -> None:
    # fault --for 1s: EMCY 0x2201 on 0xFF now, the error reset ~1 s later
    it.drain(bus)
    t0 = time.time()
    out = ctl.ok("fault", "dps", "open", "--for", "1s")
    assert out.strip().isdigit() and out.endswith("\n") and out.count("\n") == 1, f"fault printed {out!r}"
    fid = int(out)
    emcy = it.expect(bus, it.is_emcy(DPS), 2, "EMCY of the open sensor on 0xFF")
    code, reg, _ = it.emcy_fields(emcy)
    assert emcy.arbitration_id == 0xFF and code == 0x2201 and reg & 0x01, f"EMCY: {it.fmt(emcy)}"
    reset = it.expect(bus, it.is_emcy(DPS), 3, "error reset EMCY after --for 1s")
    assert it.emcy_fields(reset)[0] == 0x0000, f"expected the error reset: {it.fmt(reset)}"
    # The fault starts when cansimd handles the call (after t0) and lasts 1 s:
    # the reset cannot come earlier than 1 s after t0; the EMCYs are ~1 s apart.
    gap = reset.timestamp - emcy.timestamp
    assert reset.timestamp - t0 >= 1.0 - 0.002, f"error reset {reset.timestamp - t0:.3f}s after the command started"
    assert 0.8 <= gap <= 1.0 + it.scaled(0.3), f"error reset {gap:.3f}s after the EMCY (fault --for 1s)"
    it.log(f"fault dps open --for 1s: id {fid}; {it.fmt(emcy)} {emcy.timestamp - t0:.3f}s after the command "
           f"started, then {it.fmt(reset)} {gap:.3f}s later")

    # fault until cancelled; faults; cancel
    it.drain(bus)
    fid2 = int(ctl.ok("fault", "dps", "open"))
    assert fid2 != fid, f"the same fault id {fid} twice"
    emcy = it.expect(bus, it.is_emcy(DPS), 2, "EMCY of the second open fault")
    assert it.emcy_fields(emcy)[0] == 0x2201, it.fmt(emcy)
    rows = ctl.json("faults", "dps")
    mine = [r for r in rows if r["id"] == fid2]
    assert len(mine) == 1 and mine[0]["kind"] == "open" and mine[0]["channel"] == "pressure" and \
        mine[0]["active"] is True and mine[0]["duration"] is None and isinstance(mine[0]["start"], float), rows
    assert not [r for r in rows if r["id"] == fid], f"the ended fault {fid} is still listed: {rows}"
    table = ctl.ok("faults", "dps").splitlines()
    assert table[0].split()[:4] == ["ID", "KIND", "CHANNEL", "ACTIVE"], table
    assert any(r.split()[:4] == [str(fid2), "open", "pressure", "yes"] for r in table[1:]), table
    s = ctl.json("status", "dps")
    assert {"id": fid2, "kind": "open", "active": True} in s["faults"] and s["emcy_count"] >= 3 and \
        s["last_emcy"]["code"] == 0x2201, s
    it.log(f"fault dps open: id {fid2}, {it.fmt(emcy)}; faults: {table[1:]}; --json {mine}")
    it.drain(bus)
    assert ctl.ok("cancel", "dps", str(fid2)) == ""
    reset = it.expect(bus, it.is_emcy(DPS), 2, "error reset EMCY after cancel")
    assert it.emcy_fields(reset)[0] == 0x0000, it.fmt(reset)
    assert ctl.json("faults", "dps") == []
    reason = ctl.refused("cancel", "dps", str(fid2))
    it.log(f"cancel dps {fid2}: {it.fmt(reset)}; faults empty; cancel again: exit 1 ({reason})")


def power_cycle(ctl: Ctl, bus) -> None:
    it.drain(bus)
    t0 = time.time()
    assert ctl.ok("power-cycle", "generic/1", "--off", "500ms") == ""
    t_ret = time.time()
    frames, boot = [], None
    deadline = time.monotonic() + 0.5 + it.scaled(2.0)
    while boot is None and time.monotonic() < deadline:
        m = it.wait_for(bus, from_node(G1), deadline - time.monotonic())
        if m is None:
            break
        if it.is_bootup(G1)(m):
            boot = m
        else:
            frames.append(m)
    assert boot is not None, "no boot-up 0x711 [00] after power-cycle --off 500ms"
    late = [f for f in frames if f.timestamp >= t_ret]
    assert not late, f"0x11 sent while powered off: {[it.fmt(f) for f in late]}"
    off = boot.timestamp - t0
    assert off >= 0.5 - 0.002, f"boot-up {off:.3f}s after power-cycle --off 500ms started"
    st = ctl.json("status", "generic/1")
    assert st["powered"] is True and st["nmt_state"] == "pre-operational", st
    it.log(f"power-cycle generic/1 --off 500ms: silent, {it.fmt(boot)} {off:.3f}s after the command started "
           f"(cansimctl took {t_ret - t0:.3f}s)")

    # nmt start / stop: the heartbeat's state byte
    it.drain(bus)
    ctl.ok("nmt", "generic/1", "start")
    hb = it.expect(bus, it.is_heartbeat(G1, it.STATE_OPERATIONAL), 3, "heartbeat 0x711 [05]")
    it.drain(bus)
    ctl.ok("nmt", "generic/1", "stop")
    hb2 = it.expect(bus, it.is_heartbeat(G1, it.STATE_STOPPED), 3, "heartbeat 0x711 [04]")
    it.expect_none(bus, it.is_tpdo(G1, 1), 0.3, "TPDO1 of the stopped 0x11")
    assert ctl.json("status", "generic/1")["nmt_state"] == "stopped"
    it.log(f"nmt generic/1 start: {it.fmt(hb)}; nmt generic/1 stop: {it.fmt(hb2)}, no TPDO1")


def objects(ctl: Ctl, bus, d: it.Daemon, w: Watch) -> None:
    sdo = it.SdoClient(bus, G0)
    assert ctl.ok("read", "generic/0", "0x1018:4") == "1 (0x1)\n"
    r = ctl.json("read", "generic/0", "0x1018:4")
    assert {k: r[k] for k in ("node", "index", "sub", "type", "value", "unit", "raw", "counts")} == \
        {"node": "vcan0/generic/0", "index": 0x1018, "sub": 4, "type": "UNSIGNED32", "value": 1, "unit": None,
         "raw": 1, "counts": None} and r["name"], r
    assert sdo.upload_u32(0x1018, 4) == 1
    assert ctl.ok("read", "generic/0", "0x1008").strip() == "cansimd generic-404 pressure transmitter"
    period0 = ctl.json("read", "generic/0", "1017h")["value"]
    assert period0 == 1000, f"0x1017 = {period0}"
    it.log(f"read generic/0 0x1018:4: '1 (0x1)', --json {r}; 0x1008 and 1017h ({period0}) too")

    mark = w.mark()
    assert ctl.ok("write", "generic/0", "0x1017", "200") == ""
    it.drain(bus)
    window = it.scaled(1.0) + 1.5
    beats = collect_n(bus, it.is_heartbeat(G0), 7, window)
    assert len(beats) >= 5, f"{len(beats)} heartbeats of 0x10 in {window:.1f}s after 0x1017 = 200"
    mean = it.mean_gap(beats)
    assert 0.15 < mean < 0.2 + 0.05 * it.SCALE, f"mean heartbeat gap {mean:.3f}s after write 0x1017 200"
    assert sdo.upload_u16(0x1017) == 200, "SDO upload of 0x1017 after cansimctl write"
    assert ctl.ok("read", "generic/0", "0x1017") == "200 (0xc8)\n"
    it.log(f"write generic/0 0x1017 200: heartbeat every {mean * 1000:.0f} ms on the wire; "
           f"the master's SDO upload reads 200")

    # store: the stored period survives a reset node; restore: defaults at the next one
    params = os.path.join(d.state_dir, "vcan0@generic@0.params")
    before = os.stat(params).st_mtime_ns if os.path.exists(params) else None
    assert ctl.ok("store", "generic/0") == ""
    assert os.path.exists(params) and os.stat(params).st_mtime_ns != before, f"{params} not written by store"
    ctl.ok("write", "generic/0", "0x1017", "700")
    it.drain(bus)
    ctl.ok("nmt", "generic/0", "reset")
    it.expect(bus, it.is_bootup(G0), 3, "boot-up 0x710 after nmt reset")
    assert sdo.upload_u16(0x1017) == 200, "0x1017 after store (200), write 700, reset node"
    it.log("store generic/0, write 700, nmt reset: boot-up, the master reads the stored 200")
    assert ctl.ok("restore", "generic/0") == ""
    assert sdo.upload_u16(0x1017) == 200, "restore is effective at the next reset only"
    it.drain(bus)
    ctl.ok("nmt", "generic/0", "reset")
    it.expect(bus, it.is_bootup(G0), 3, "boot-up 0x710 after restore + nmt reset")
    assert sdo.upload_u16(0x1017) == period0, f"0x1017 after restore + reset node (default {period0})"
    it.log(f"restore generic/0, nmt reset: the master reads the default {period0}")
    local = [e for e in w.events[mark:] if e.get("kind") == "ObjectWritten"]
    assert not local, f"watch printed ObjectWritten for cansimctl's local writes: {local}"
    states = [(e["old"], e["new"]) for e in w.events[mark:] if e.get("kind") == "NmtStateChanged"]
    assert ("operational", "initialising") in states and states[-1][1] == "pre-operational", states
    it.log(f"watch: NmtStateChanged {states}; no ObjectWritten for local writes")


def add_remove_reload(ctl: Ctl, bus, ctx: it.Context) -> None:
    frag = os.path.join(ctx.tmp, "extra.yaml")
    with open(frag, "w") as f:
        f.write(f"{{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan0, "
                f"node_id: 0x20, name: added}}\n")
    it.drain(bus)
    out = ctl.ok("add", frag)
    assert out == "vcan0/added/0\n", f"add printed {out!r}"
    boot = it.expect(bus, it.is_bootup(ADDED), 3, "boot-up 0x720 [00] of the added node")
    assert len(ctl.json("list")) == 4
    it.log(f"add {os.path.basename(frag)}: printed {out.strip()!r}, {it.fmt(boot)} on the wire")
    reason = ctl.refused("add", frag)
    it.log(f"add of the same fragment again: exit 1 ({reason})")

    ctl.ok("write", "added", "0x1017", "100")
    ctl.ok("nmt", "added", "start")
    talk = collect_n(bus, from_node(ADDED), 5, it.scaled(0.4) + 1.0)
    assert len(talk) >= 5, f"{len(talk)} frames of 0x20 after its start"
    assert ctl.ok("remove", "added") == ""
    it.drain(bus)
    it.expect_none(bus, from_node(ADDED), 1.0, "frame of the removed node 0x20")
    reason = ctl.refused("status", "added")
    assert "added" in reason, reason
    it.log(f"remove added: silent for 1 s ({len(talk)} frames before); status added: exit 1 ({reason})")

    before = ctl.json("list")
    it.drain(bus)
    assert ctl.ok("reload") == ""
    after = ctl.json("list")
    assert sorted((n["node"], n["node_id"], n["profile"]) for n in after) == \
        sorted((n["node"], n["node_id"], n["profile"]) for n in before) and len(after) == 3, (before, after)
    assert {n["node"]: n["nmt_state"] for n in after} == {n["node"]: n["nmt_state"] for n in before}, (before, after)
    it.expect_none(bus, lambda m: m.arbitration_id - 0x700 in KEYS.values() and bytes(m.data) == b"\0", 0.5,
                   "boot-up after a reload of the unchanged file")
    it.log(f"reload: exit 0, the same fleet {[(n['node'], n['nmt_state']) for n in after]}, no boot-up")


def time_and_stats(ctl: Ctl, t_start: float) -> None:
    out = ctl.ok("time")
    assert out.endswith(" s\n"), out
    t1 = float(out.split()[0])
    j = ctl.json("time")
    assert set(j) == {"time"} and isinstance(j["time"], float), j
    assert t1 < j["time"] <= time.monotonic() - t_start + 1.0, (t1, j, time.monotonic() - t_start)
    it.log(f"time: {out.strip()!r}, --json {j}")

    table, bus_table = (part.splitlines() for part in ctl.ok("stats").split("\n\n"))
    # (column 7, GetBusStatistics' "frames not sent", is not checked by name:
    # cansimctl calls it LOCAL / local_deliveries)
    head = table[0].split()
    # One set of load figures, the bus table's (carried never above 100 %).
    assert head[:6] == ["INTERFACE", "UP", "KBIT/S", "IN", "OUT", "DROPPED"] and len(head) == 7, table
    row = table[1].split()
    assert len(table) == 2 and row[:3] == ["vcan0", "yes", "250"] and row[6] == "0", table
    st = ctl.json("stats")
    assert len(st) == 1 and st[0]["interface"] == "vcan0" and st[0]["up"] is True and \
        st[0]["bit_rate_kbit"] == 250, st
    assert st[0]["frames_out"] > 100 and st[0]["frames_in"] > 0, st
    assert 0 < st[0]["offered_load"] < 1, st
    # The bus model (vcan: timed by default), its state and figures.
    assert bus_table[0].split()[:3] == ["INTERFACE", "MODEL", "STATE"] and \
        bus_table[1].split()[:3] == ["vcan0", "timed", "error-active"], bus_table
    assert st[0]["bus_model"] == "timed" and st[0]["controller_state"] == "error-active", st
    assert 0 < st[0]["carried_load_10s"] < 1 and st[0]["queue_capacity"] == 1024 and st[0]["queue_dropped"] == 0, st
    assert st[0]["measured_load"] == st[0]["carried_load_10s"] and st[0]["slip_max_us"] >= st[0]["slip_p99_us"] >= 0, st
    it.log(f"stats: {table[1]!r} / {bus_table[1]!r}; --json {st[0]}")


def bad_lines(ctl: Ctl) -> None:
    """Independent of each other: run at once (a cansimctl start costs ~0.5 s in the VM)."""
    # Usage-level: the parser's, and words the daemon does not know (a unit, a fault kind).
    usage = [("bogus",), (), ("set", "generic/0", "pressure"), ("nmt", "generic/0", "start", "extra"),
             ("power-cycle", "generic/1", "--off"), ("list", "--frobnicate"),
             ("set", "generic/0", "pressure", "3", "furlong"), ("set", "generic/0", "pressure", "3", "degC"),
             ("fault", "dps", "melted")]
    refused = [(("status", "nope"), "nope"),
               (("set", "vcan0/0x42", "pressure", "3", "bar"), "0x42"),
               (("status", "generic"), "generic"),
               (("read", "generic/0", "0x2fff"), "0x2FFF"),
               (("write", "generic/0", "0x1017", "70000"), "range")]
    with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
        usage_runs = [pool.submit(ctl.run, *args, rc=2) for args in usage]
        refused_runs = [pool.submit(ctl.refused, *args) for args, _ in refused]
        for args, f in zip(usage, usage_runs):
            it.log(f"cansimctl {' '.join(args)}: exit 2, {f.result().stderr.splitlines()[0]!r} + usage")
        for (args, needle), f in zip(refused, refused_runs):
            reason = f.result()
            assert needle.lower() in reason.lower(), f"cansimctl {' '.join(args)}: reason {reason!r} lacks {needle!r}"
            it.log(f"cansimctl {' '.join(args)}: exit 1, {reason!r}")


# --------------------------------------------------------------------------

def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    cansimd = ctx.require_cansimd()
    binary = os.path.join(os.path.dirname(cansimd), "cansimctl")
    if not os.access(binary, os.X_OK):
        it.log(f"cansimctl not built ({binary} missing): skipping")
        it.skip(f"cansimctl not built next to cansimd ({binary})")
    sock = os.path.join(ctx.tmp, "control")
    ctl = Ctl(binary, sock)
    fleet_file = it.write_control_fleet(ctx)
    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        t_start = time.monotonic()
        d = ctx.start_daemon("--config", fleet_file, "--control-socket", sock, "--bus", "none",
                             "--state-dir", "{state_dir}")
        booted = set()
        deadline = time.monotonic() + it.scaled(10)
        while booted != set(KEYS.values()) and time.monotonic() < deadline:
            m = it.wait_for(bus, lambda x: x.arbitration_id - 0x700 in KEYS.values() and bytes(x.data) == b"\0",
                            deadline - time.monotonic())
            if m is not None:
                booted.add(m.arbitration_id - 0x700)
        assert booted == set(KEYS.values()), f"boot-ups seen: {sorted(map(hex, booted))}"
        it.wait_for_path(sock, 5)
        it.log(f"3 boot-ups seen; cansimctl {binary} --socket {sock}")

        list_and_status(ctl)
        w = start_watch(ctl, bus, ctx)
        try:
            nmt_checks(ctl, bus, w)
            measurement(ctl, bus, ctx)
            faults(ctl, bus)
            power_cycle(ctl, bus)
            objects(ctl, bus, d, w)
        finally:
            rc = w.stop()
        assert rc == 0, f"cansimctl watch exited {rc} on SIGTERM; stderr {w.stderr()!r}"
        assert w.stderr() == "", f"cansimctl watch stderr: {w.stderr()!r}"
        bad = [x for x in w.events if "unparsed" in x or x.get("node") != "vcan0/generic/0"]
        assert not bad, f"watch generic/0 printed lines that are not JSON events of generic/0: {bad[:5]}"
        it.log(f"watch: {len(w.events)} JSON lines, exit 0 on SIGTERM")

        add_remove_reload(ctl, bus, ctx)
        time_and_stats(ctl, t_start)
        bad_lines(ctl)
        d.assert_alive()
        it.log(f"{ctl.calls} cansimctl runs")
    assert d.stop() == 0, "exit status after SIGTERM"


it.main(test)
