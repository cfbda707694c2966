#!/usr/bin/env python3
"""The bus seen as values, on the wire: `cansimctl monitor`, `cansimd
--export-dbc` and `cansimctl top` against a running fleet, each checked
against `cansimctl status` (what the daemon says its nodes report).

Fleet (lib: write_control_fleet): two generic-404 (0x10, 0x11) and a DPS
(0x7F) on vcan0, and an ADZ SMC (0x20) added with `cansimctl add`: it reports
field counts (0..20000 over 0..5 bar), its 0x6131 informational. The
reported values are fixed with `cansimctl override` (generic/0 3.456 bar,
generic/1 21.35 degC, dps 49.664 psi, smc 2.5 bar = 10000 counts), the nodes
started, SYNCs sent (generic's TPDO2 is synchronous), and for about 2 s:

  candump -L vcan0            the frames, decoded afterwards through the DBC of
                              `cansimd --export-dbc` by python3-canmatrix (a
                              DBC reader written elsewhere): each value equals
                              `status`'s reported value within one quantisation
                              step (REAL32: its float; INTEGER16: 0.01 bar;
                              INTEGER32: 0.001 psi)
  cansimctl --json monitor    one JSON object per frame with exactly the keys
                              of docs/cansimctl.md (time, wall_time, interface,
                              id, extended, rtr, dlc, data, node, kind, fields:
                              name, index, sub, value, unit, raw, counts): the
                              same values with their units (the SMC's in bar,
                              its counts beside them), the raw data,
                              the same values canmatrix decodes from the same
                              frames; heartbeats; SDO lines naming the object.
                              generic/1's TPDO1 is remapped by SDO to the
                              temperature PV meanwhile: the monitor follows
                              (PdoMappingChanged) and decodes it in degC.
  cansimctl top --once        one row per node: its pressure / temperature as
                              status reports it (the SMC in bar, with its
                              counts), its NMT state, frames/s.
  cansimd --export-dbc smc    read by canmatrix: the SMC's PV signal decodes its
                              counts as bar (factor and offset of its scaling).
  cansimctl nmt vcan0/0x10-0x11 start   a group target, one result per node; a
                              node added on a missing interface: status says
                              off the bus.

  cansimctl dcf NODE          each node's DCF (current mapping), read with
                              configparser, decodes the same candump (what
                              python-canopen would do with the exported EDS;
                              python3-canopen is not in Debian 12).
"""

# ctest-timeout: 180

import io
import json
import os
import struct
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402
from check_dbc_export import REAL, SIGNED, Eds, expected_pdos  # noqa: E402  the EDS reading of dbc_export

G0, G1, DPS, SMC = 0x10, 0x11, 0x7F, 0x20
JSON_KEYS = {"time", "wall_time", "interface", "id", "extended", "rtr", "dlc", "data", "node", "kind", "fields"}
FIELD_KEYS = {"name", "index", "sub", "value", "unit", "raw", "counts"}


class Ctl:
    def __init__(self, binary: str, sock: str):
        self.argv = [binary, "--socket", sock]

    def run(self, *args: str) -> str:
        p = subprocess.run(self.argv + list(args), capture_output=True, text=True, timeout=it.scaled(20),
                           stdin=subprocess.DEVNULL)
        assert p.returncode == 0 and p.stderr == "", f"cansimctl {' '.join(args)}: {p.returncode} {p.stderr!r}"
        return p.stdout

    def json(self, *args: str):
        return json.loads(self.run("--json", *args))


class Background:
    """A process whose stdout lines a thread collects."""

    def __init__(self, argv, err_path: str):
        self._err = open(err_path, "w")
        self.err_path = err_path
        self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=self._err,
                                     text=True)
        self.lines = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_lines(self, n: int, timeout: float) -> None:
        deadline = time.monotonic() + it.scaled(timeout)
        while len(self.lines) < n and time.monotonic() < deadline and self.proc.poll() is None:
            time.sleep(0.05)
        assert len(self.lines) >= n, f"{self.proc.args[:3]}: {len(self.lines)} lines; stderr {self.stderr()!r}"

    def stderr(self) -> str:
        self._err.flush()
        with open(self.err_path) as f:
            return f.read()

    def stop(self) -> int:
        return it.stop_process(self.proc, self._thread, self._err)


def load_canmatrix():
    stderr, sys.stderr = sys.stderr, io.StringIO()  # it names the formats it lacks on import
    try:
        import canmatrix
        import canmatrix.formats
        return canmatrix
    except ImportError:
        it.skip("no python3-canmatrix")
    finally:
        sys.stderr = stderr


def candump_frames(path: str):
    """(time, id, data) of each line of a 'candump -L' log."""
    out = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if len(parts) < 3 or "#" not in parts[2]:
                continue
            can_id, data = parts[2].split("#", 1)
            if data.startswith("R"):
                continue
            out.append((float(parts[0].strip("()")), int(can_id, 16), bytes.fromhex(data)))
    return out


def eds_decode(frames, dcf_text: str, node_id: int) -> dict:
    """The last value of each object mapped into a TPDO of the node, decoded
    from the frames with nothing but the node's DCF (cansimctl dcf): COB-IDs,
    mappings and data types from its ParameterValues, integer process values
    scaled by 0x6132. (index, sub) -> value."""
    eds = Eds(dcf_text, node_id)
    out = {}
    for transmit, _, can_id, bits, entries in expected_pdos(eds):
        if not transmit:
            continue
        for _, fid, data in frames:
            if fid != can_id or len(data) * 8 < bits:
                continue
            raw = int.from_bytes(data, "little")
            for index, sub, start, length, dtype in entries:
                v = (raw >> start) & ((1 << length) - 1)
                if dtype in REAL:
                    v = struct.unpack("<f" if length == 32 else "<d", v.to_bytes(length // 8, "little"))[0]
                else:
                    if dtype in SIGNED and v >> (length - 1):
                        v -= 1 << length
                    if index in (0x6130, 0x7130, 0x8130, 0x9130):
                        v = v / 10 ** (eds.value(0x6132, sub) or 0)
                out[(index, sub)] = v
    return out


def close(a: float, b: float, step: float) -> bool:
    return abs(a - b) <= step * 1.0001


def remap_tpdo1_to_temperature(bus) -> None:
    """CiA 301 §7.5.2.36: invalidate, clear, map 0x6130:02 (REAL32), count 1, valid."""
    sdo = it.SdoClient(bus, G1)
    sdo.download(0x1800, 1, struct.pack("<I", 0x80000000 | (0x180 + G1)))
    sdo.download(0x1A00, 0, b"\x00")
    sdo.download(0x1A00, 1, struct.pack("<I", 0x61300220))
    sdo.download(0x1A00, 0, b"\x01")
    sdo.download(0x1800, 1, struct.pack("<I", 0x180 + G1))


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    canmatrix = load_canmatrix()
    ctl_bin = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    if not os.access(ctl_bin, os.X_OK):
        it.skip(f"cansimctl not built ({ctl_bin})")
    fleet = it.write_control_fleet(ctx)
    dbc_path = os.path.join(ctx.tmp, "fleet.dbc")
    subprocess.run([ctx.cansimd, "--export-dbc", fleet, "--output", dbc_path], check=True, cwd=ctx.tmp)
    smc_dbc = subprocess.run([ctx.cansimd, "--export-dbc", ctx.source("profiles", "smc.yaml"), "--node-id", str(SMC)],
                             check=True, cwd=ctx.tmp, capture_output=True, text=True).stdout
    smc_fragment = os.path.join(ctx.tmp, "smc.yaml")
    with open(smc_fragment, "w") as f:
        f.write(f"{{profile: {ctx.source('profiles', 'smc.yaml')}, interface: vcan0, name: smc, bit_rate: 250}}\n")
    sock = os.path.join(ctx.tmp, "control")
    d = ctx.start_daemon("--config", fleet, "--state-dir", "{state_dir}", "--control-socket", sock, "--bus", "none")
    ctl = Ctl(ctl_bin, sock)
    dump_path = os.path.join(ctx.tmp, "candump.log")
    with it.open_bus("vcan0") as bus:
        it.expect(bus, it.is_bootup(DPS), 10, "boot-up of the DPS")
        it.wait_for_path(sock, 5)
        monitor = Background(ctl.argv + ["--json", "monitor"], os.path.join(ctx.tmp, "monitor.err"))
        only_dps = Background(ctl.argv + ["--json", "monitor", "vcan0", "--node", "dps"],
                              os.path.join(ctx.tmp, "monitor-dps.err"))
        dump = subprocess.Popen(["candump", "-L", "vcan0"], stdout=open(dump_path, "w"), stderr=subprocess.DEVNULL)
        monitor.wait_lines(1, 5)  # subscribed and listening: it printed a heartbeat
        ctl.run("add", smc_fragment)
        it.expect(bus, it.is_bootup(SMC), 10, "boot-up of the SMC")
        ctl.run("override", "smc", "pressure", "2.5", "bar")
        ctl.run("override", "generic/0", "pressure", "3.456", "bar")
        ctl.run("override", "generic/1", "temperature", "21.35", "degC")
        ctl.run("override", "dps", "pressure", "49.664", "psi")
        group = ctl.run("nmt", "vcan0/0x10-0x11", "start")  # a group target: one line per node
        assert group.split() == ["NODE", "RESULT", "vcan0/generic/0", "ok", "vcan0/generic/1", "ok"], group
        it.expect(bus, lambda m: m.arbitration_id == 0x700 + G1 and bytes(m.data) == b"\x05", 3,
                  "generic/1's heartbeat: operational")
        it.nmt(bus, 0x01)
        for _ in range(5):
            time.sleep(0.2)
            it.send(bus, 0x080)  # SYNC: generic's TPDO2 (INTEGER16 PVs) is synchronous
        remap_tpdo1_to_temperature(bus)
        it.expect(bus, it.is_tpdo(G1, 1), 2, "generic/1's remapped TPDO1")
        time.sleep(0.5)
        dump.terminate()
        dump.wait(5)
        it.expect(bus, it.is_tpdo(SMC, 1), 3, "the SMC's TPDO1")
        time.sleep(0.3)
        status = {n: ctl.json("status", n) for n in ("generic/0", "generic/1", "dps", "smc")}
        dcfs = {n: ctl.run("dcf", n) for n in ("generic/0", "generic/1", "dps")}
        top = ctl.run("top", "--once")
        # A node on an interface the kernel does not have is off the bus.
        fragment = os.path.join(ctx.tmp, "lost.yaml")
        with open(fragment, "w") as f:
            f.write(f"{{profile: {ctx.source('profiles', 'dps.yaml')}, interface: vcan9, name: lost, bit_rate: 250}}\n")
        ctl.run("add", fragment)
        lost_status, lost_json = ctl.run("status", "lost"), ctl.json("status", "lost")
    assert monitor.stop() == 0, f"monitor: {monitor.stderr()!r}"
    assert only_dps.stop() == 0, f"monitor --node dps: {only_dps.stderr()!r}"
    dps_lines = [json.loads(line) for line in only_dps.lines]
    assert dps_lines and {e["node"] for e in dps_lines} == {"vcan0/dps/0"}, \
        f"monitor --node dps: {len(dps_lines)} lines, nodes {sorted({str(e['node']) for e in dps_lines})}"
    assert d.stop() == 0

    reported = {
        ("vcan0/generic/0", "pressure"): status["generic/0"]["pressure"]["value"],
        ("vcan0/generic/1", "temperature"): status["generic/1"]["temperature"]["value"],
        ("vcan0/dps/0", "pressure"): status["dps"]["pressure"]["value"],
        ("vcan0/smc/0", "pressure"): status["smc"]["pressure"]["value"],
    }
    it.log(f"status reports {reported}")
    assert status["generic/0"]["pressure"]["unit"] == "bar" and status["dps"]["pressure"]["unit"] == "psi", status
    # The SMC: its counts named as counts, what they mean in bar.
    smc = status["smc"]["pressure"]
    assert smc["unit"] == "bar" and close(smc["value"], 2.5, 1e-4) and close(smc["counts"], 10000, 1), smc
    assert status["generic/0"]["pressure"]["counts"] is None, status["generic/0"]["pressure"]

    # ---- the DBC, read by canmatrix, decodes the candump of the fleet
    db = canmatrix.formats.loadp_flat(dbc_path)
    frames = candump_frames(dump_path)
    decoded = {}  # (message, signal) -> [values]
    for _, can_id, data in frames:
        f = db.frame_by_id(canmatrix.ArbitrationId(can_id))
        if f is None or len(data) < f.size or f.name.startswith("generic_1_TPDO1"):  # remapped at run time
            continue
        for name, v in f.decode(data).items():
            decoded.setdefault((f.name, name), []).append(float(v.phys_value))
    checks = [
        ("generic_0_TPDO1", "AI_input_PV_1", ("vcan0/generic/0", "pressure"), 1e-6),    # REAL32
        ("generic_0_TPDO2", "AI_input_PV_1_INTEGER16", ("vcan0/generic/0", "pressure"), 0.01),
        ("generic_1_TPDO2", "AI_input_PV_2_INTEGER16", ("vcan0/generic/1", "temperature"), 0.1),
        ("dps_TPDO1", "AI_input_process_value_INTEGER32", ("vcan0/dps/0", "pressure"), 0.001),
    ]
    for message, signal, what, step in checks:
        values = decoded.get((message, signal))
        assert values, f"no {message}.{signal} in the candump ({len(frames)} frames)"
        assert close(values[-1], reported[what], step), \
            f"DBC: {message}.{signal} = {values[-1]}, status reports {reported[what]} (step {step})"
    it.log(f"DBC via canmatrix: {len(frames)} frames; " +
           ", ".join(f"{m}.{s}={decoded[(m, s)][-1]}" for m, s, _, _ in checks))
    # The SMC's DBC: its PV signal turns the counts of its TPDO1 into bar.
    smc_db = canmatrix.formats.loads_flat(smc_dbc, import_type="dbc")
    smc_tpdo = smc_db.frame_by_id(canmatrix.ArbitrationId(0x180 + SMC))
    pv = smc_tpdo.signals[0]
    smc_frames = [data for _, can_id, data in frames if can_id == 0x180 + SMC]
    assert smc_frames and pv.unit == "bar", (len(smc_frames), pv.unit)
    smc_bar = float(smc_tpdo.decode(smc_frames[-1])[pv.name].phys_value)
    assert close(smc_bar, 2.5, 1e-4), f"DBC: the SMC's {pv.name} = {smc_bar} bar, status reports {smc}"
    it.log(f"the SMC's DBC: {pv.name} factor {pv.factor} offset {pv.offset} -> {smc_bar} {pv.unit}")

    # ---- decoded with nothing but each node's DCF (python-canopen's way, which Debian 12 lacks)
    after_remap = [f for f in frames if f[0] >= frames[-1][0] - 0.3]  # generic/1's TPDO1 maps 0x6130:02 by now
    by_eds = {
        "generic/0": eds_decode(frames, dcfs["generic/0"], G0),
        "generic/1": eds_decode(after_remap, dcfs["generic/1"], G1),
        "dps": eds_decode(frames, dcfs["dps"], DPS),
    }
    for node, index, sub, what, step in [
            ("generic/0", 0x6130, 1, ("vcan0/generic/0", "pressure"), 1e-6),
            ("generic/0", 0x7130, 1, ("vcan0/generic/0", "pressure"), 0.01),
            ("generic/1", 0x6130, 2, ("vcan0/generic/1", "temperature"), 1e-5),
            ("dps", 0x6130, 1, ("vcan0/dps/0", "pressure"), 0.001)]:
        v = by_eds[node].get((index, sub))
        assert v is not None and close(v, reported[what], step), \
            f"DCF decoding: {node} 0x{index:04X}:{sub} = {v}, status reports {reported[what]}"
    it.log(f"decoded with each node's DCF: {by_eds}")

    # ---- the monitor's JSON lines
    lines = [json.loads(line) for line in monitor.lines]
    for e in lines:
        assert set(e) == JSON_KEYS, f"monitor JSON keys {sorted(e)}: {e}"
        assert e["interface"] == "vcan0" and len(e["data"]) == 2 * (0 if e["rtr"] else e["dlc"]), e
        assert e["time"] is not None and abs(e["wall_time"] - time.time()) < it.scaled(600), e
        for f in e["fields"]:
            assert set(f) == FIELD_KEYS, f"monitor field keys {sorted(f)}: {e}"
    smc_pv = [f for e in lines if e["node"] == "vcan0/smc/0" and e["kind"] == "TPDO1" for f in e["fields"]
              if (f["index"], f["sub"]) == (0x6130, 1)]
    assert smc_pv and smc_pv[-1]["unit"] == "bar" and close(smc_pv[-1]["value"], 2.5, 1e-4) and \
        close(smc_pv[-1]["counts"], 10000, 1), f"monitor: the SMC's TPDO1 PV {smc_pv[-1:]}"
    kinds = {e["kind"] for e in lines}
    assert {"heartbeat", "NMT", "SYNC", "SDO", "TPDO1", "TPDO2"} <= kinds, kinds

    def values_of(node, kind, index, sub):
        return [(f["value"], f["unit"]) for e in lines if e["node"] == node and e["kind"] == kind
                for f in e["fields"] if (f["index"], f["sub"]) == (index, sub)]

    expect = [
        ("vcan0/generic/0", "TPDO1", 0x6130, 1, "bar", ("vcan0/generic/0", "pressure"), 1e-6),
        ("vcan0/generic/0", "TPDO2", 0x7130, 1, "bar", ("vcan0/generic/0", "pressure"), 0.01),
        ("vcan0/generic/1", "TPDO2", 0x7130, 2, "degC", ("vcan0/generic/1", "temperature"), 0.1),
        ("vcan0/dps/0", "TPDO1", 0x6130, 1, "psi", ("vcan0/dps/0", "pressure"), 0.001),
    ]
    for node, kind, index, sub, unit, what, step in expect:
        seen = values_of(node, kind, index, sub)
        assert seen, f"monitor: no {kind} 0x{index:04X}:{sub} of {node}"
        value, got_unit = seen[-1]
        assert got_unit == unit and close(value, reported[what], step), \
            f"monitor: {node} {kind} 0x{index:04X}:{sub} = {value} {got_unit}, status {reported[what]} {unit}"
    # The same frames, the same values as canmatrix's.
    mon = [v for v, _ in values_of("vcan0/generic/0", "TPDO2", 0x7130, 1)]
    dbc = decoded[("generic_0_TPDO2", "AI_input_PV_1_INTEGER16")]
    assert sorted(set(mon)) == sorted(set(dbc)), f"monitor {sorted(set(mon))} vs canmatrix {sorted(set(dbc))}"
    # The remap is followed: generic/1's TPDO1 now carries the temperature PV in degC.
    remapped = values_of("vcan0/generic/1", "TPDO1", 0x6130, 2)
    assert remapped and remapped[-1][1] == "degC" and \
        close(remapped[-1][0], reported[("vcan0/generic/1", "temperature")], 1e-5), \
        f"monitor after the remap: generic/1 TPDO1 0x6130:02 = {remapped[-3:]}"
    sdo = [e for e in lines if e["kind"] == "SDO" and any(f["index"] == 0x1A00 for f in e["fields"])]
    assert sdo and any(f["name"].startswith("TPDO1 mapping") for e in sdo for f in e["fields"]), sdo[:2]
    it.log(f"monitor: {len(lines)} lines, kinds {sorted(kinds)}; generic/1 TPDO1 after the remap: {remapped[-1]}")

    # ---- top --once: one row per node with status's values
    rows = {line.split()[0]: line for line in top.splitlines()[1:] if line.strip()}
    it.log("top --once:\n" + top)
    for key in ("vcan0/generic/0", "vcan0/generic/1", "vcan0/dps/0"):
        assert key in rows, f"top: no row for {key}: {top}"
    for key, pressure in (("vcan0/generic/0", "3.456 / "), ("vcan0/dps/0", "49.664 / ")):
        cells = rows[key].split()
        assert cells[2] == "operational" and pressure in rows[key], f"top: {key}: {rows[key]!r}"
        assert float(cells[-1]) > 0, f"top: {key} sends no frames? {rows[key]!r}"
    assert "21.35 degC" in rows["vcan0/generic/1"], f"top: {rows['vcan0/generic/1']!r}"
    assert "2.5 / " in rows["vcan0/smc/0"] and "(10 000 counts)" in rows["vcan0/smc/0"], f"top: {rows['vcan0/smc/0']!r}"
    assert "off the bus" in lost_status and lost_json["on_bus"] is False, (lost_status, lost_json)


it.main(test)
