#!/usr/bin/python3
"""cansimd --export-dbc read back by a DBC reader written elsewhere (Debian's
python3-canmatrix), for every shipped profile, against what the profile's own
CiA 306 description says (cansimd --export-eds --node-id N, read here with
configparser): every valid TPDO and RPDO is a message with the PDO's CAN-ID
and length, one signal per mapped object in frame order (start bit, length,
little-endian, signedness and IEEE float from the object's DataType, the
factor 10^-digits of a CiA 404 integer process value from 0x6132, the unit
from the 0x6131 code; a device whose PV is counts, its 0x6131 informational
(the SMC): factor and offset from its own scaling, 0x6126 gain, 0x6127
offset, 0x3124 input offset and the profile's sensor range over its ADC's
field_full_scale counts), and the node's heartbeat and EMCY messages are
there, the EMCY codes with the profile's names.
No CAN needed: registered as a unit-tier test (ctest name dbc_export).

usage: check_dbc_export.py --cansimd PATH --source-dir DIR
Exit 0 pass, 1 fail, 77 skip (no canmatrix, no cansimd).
"""

from __future__ import annotations

import argparse
import configparser
import io
import os
import subprocess
import sys

SKIP = 77
PROFILES = ["cmp", "dps", "gems9000", "generic-404", "p92c", "smc"]
NODE_ID = 5
# CiA 303-2 unit codes (0x6131 bits 23-16) and prefixes (bits 31-24, a signed power of ten).
UNITS = {0x05: "K", 0x22: "Pa", 0x2D: "degC", 0x4E: "bar", 0xAB: "psi", 0xAC: "degF"}
PREFIXES = {0: "", 3: "k", -3: "m", 6: "M", 2: "h", 1: "da", -1: "d", -2: "c"}
SIGNED = {0x02, 0x03, 0x04, 0x10, 0x12, 0x13, 0x14, 0x15}
REAL = {0x08: 32, 0x11: 64}
PV_INDICES = {0x6130, 0x7130, 0x8130, 0x9130}


def number(text: str, node_id: int = NODE_ID) -> int:
    text = text.strip()
    if "$NODEID" in text.upper():
        rest = text.upper().replace("$NODEID", "").replace("+", " ").split()
        return node_id + sum(int(t, 0) for t in rest)
    return int(text, 0)


class Eds:
    """A CiA 306 EDS or DCF read with configparser; values of a DCF are its
    ParameterValue (what the node holds), $NODEID terms resolved for node_id."""

    def __init__(self, text: str, node_id: int = NODE_ID):
        self.node_id = node_id
        self.ini = configparser.ConfigParser(strict=False, interpolation=None)
        self.ini.optionxform = str
        self.ini.read_string(text)

    def section(self, index: int, sub: int):
        for name in (f"{index:04X}sub{sub:X}", f"{index:04X}sub{sub}", f"{index:04X}" if sub == 0 else ""):
            if name and self.ini.has_section(name):
                return self.ini[name]
        return None

    def value(self, index: int, sub: int):
        s = self.section(index, sub)
        if s is None:
            return None
        return number(s.get("ParameterValue", s.get("DefaultValue", "0")), self.node_id)

    def data_type(self, index: int, sub: int) -> int:
        return int(self.section(index, sub)["DataType"], 0)


def unit_of(eds: Eds, channel: int) -> str | None:
    code = eds.value(0x6131, channel)
    if code is None:
        return None  # no unit object: the profile's fixed unit, not in the EDS
    prefix = (code >> 24) & 0xFF
    prefix = prefix - 256 if prefix >= 128 else prefix
    base = UNITS.get((code >> 16) & 0xFF)
    return None if base is None or prefix not in PREFIXES else PREFIXES[prefix] + base


def real(eds: Eds, index: int, sub: int) -> float:
    s = eds.section(index, sub)
    return float(s.get("ParameterValue", s.get("DefaultValue", "0")))


def quantity(text: str) -> tuple[float, str]:
    value, unit = text.split()
    return float(value), unit


def count_scaling(doc: dict, eds: Eds, sub: int) -> tuple[float, float] | None:
    """(factor, offset) turning the PV of channel `sub` into its unit when the
    device reports counts: a profile whose 0x6131 is informational (no effect
    on the calculation) and whose sensor spans field_full_scale counts over
    its range: PV = gain x (FV - input offset) + offset, FV = (x - lo) / (hi - lo) x counts."""
    if not (((doc.get("vendor") or {}).get("cia404") or {}).get("unit_informational")):
        return None
    sensor = (doc.get("sensor") or {}).get({1: "pressure", 2: "temperature"}[sub]) or {}
    counts = (sensor.get("adc") or {}).get("field_full_scale")
    if not counts:
        return None
    (lo, unit), (hi, unit_hi) = quantity(sensor["range"][0]), quantity(sensor["range"][1])
    assert unit == unit_hi == unit_of(eds, sub), f"the sensor range of channel {sub} is not in its 0x6131 unit"
    gain, pv1, input_offset = real(eds, 0x6126, sub), real(eds, 0x6127, sub), eds.value(0x3124, sub) or 0
    per_count = (hi - lo) / counts
    factor = per_count / gain
    offset = lo + input_offset * per_count - factor * pv1
    if abs(factor - 1) < 1e-5 and abs(offset) < 1e-5 * (hi - lo):
        return None  # the PV is in its unit
    return factor, offset


def expected_pdos(eds: Eds):
    """(transmit, number, can_id, bits, [(index, sub, start, bits, type)]) of each PDO whose COB-ID is valid."""
    out = []
    for comm, mapping, transmit in ((0x1800, 0x1A00, True), (0x1400, 0x1600, False)):
        for n in range(512):
            cob = eds.value(comm + n, 1)
            if cob is None:
                continue
            count = eds.value(mapping + n, 0) or 0
            entries, start = [], 0
            for k in range(1, count + 1):
                raw = eds.value(mapping + n, k)
                index, sub, bits = raw >> 16, (raw >> 8) & 0xFF, raw & 0xFF
                entries.append((index, sub, start, bits, eds.data_type(index, sub) if index > 7 else None))
                start += bits
            if cob & 0x80000000 or not entries:
                continue
            can_id = cob & (0x1FFFFFFF if cob & 0x20000000 else 0x7FF)
            out.append((transmit, n + 1, can_id, start, entries))
    return out


def check_profile(cansimd: str, profile: str, canmatrix_formats, errors: list) -> int:
    def fail(what: str) -> None:
        errors.append(f"{profile}: {what}")

    run = lambda *a: subprocess.run([cansimd, *a], capture_output=True, text=True, check=True).stdout  # noqa: E731
    dbc_text = run("--export-dbc", profile, "--node-id", str(NODE_ID))
    eds = Eds(run("--export-eds", profile, "--node-id", str(NODE_ID)))
    import yaml
    with open(os.path.join("profiles", profile + ".yaml")) as f:
        doc = yaml.safe_load(f)
    db = canmatrix_formats.loads_flat(dbc_text, import_type="dbc")
    frames = {f.arbitration_id.id: f for f in db.frames}
    checked = 0
    for transmit, n, can_id, bits, entries in expected_pdos(eds):
        name = f"{'T' if transmit else 'R'}PDO{n}"
        frame = frames.get(can_id)
        if frame is None:
            fail(f"{name} (CAN-ID 0x{can_id:03X}) is not in the DBC")
            continue
        if frame.size != (bits + 7) // 8:
            fail(f"{name}: DLC {frame.size}, mapping has {bits} bits")
        mapped = [e for e in entries if e[0] > 7]  # dummy entries carry no signal
        if len(frame.signals) != len(mapped):
            fail(f"{name}: {len(frame.signals)} signals for {len(mapped)} mapped objects")
            continue
        for sig, (index, sub, start, length, dtype) in zip(sorted(frame.signals, key=lambda s: s.start_bit), mapped):
            where = f"{name} 0x{index:04X}:{sub:02X} ({sig.name})"
            if not sig.comment.startswith(f"0x{index:04X}:{sub:02X} "):
                fail(f"{where}: comment {sig.comment!r} names another object")
            if sig.start_bit != start or sig.size != length or not sig.is_little_endian:
                fail(f"{where}: {sig.start_bit}|{sig.size} little-endian={sig.is_little_endian}, "
                     f"expected {start}|{length} little-endian")
            if (dtype in REAL) != bool(sig.is_float):
                fail(f"{where}: is_float {sig.is_float} for DataType 0x{dtype:04X}")
            if dtype not in REAL and (dtype in SIGNED) != bool(sig.is_signed):
                fail(f"{where}: is_signed {sig.is_signed} for DataType 0x{dtype:04X}")
            factor, offset = 1.0, 0.0
            if index in PV_INDICES and dtype not in REAL:
                digits = eds.value(0x6132, sub)
                factor = 10.0 ** -(digits or 0)
            counts = count_scaling(doc, eds, sub) if index in PV_INDICES else None
            if counts:
                factor, offset = factor * counts[0], counts[1]
            if abs(float(sig.factor) - factor) > 1e-9 * max(1.0, abs(factor)) or \
                    abs(float(sig.offset) - offset) > 1e-9 * max(1.0, abs(offset)):
                fail(f"{where}: factor {sig.factor} offset {sig.offset}, expected {factor} and {offset}")
            if counts and "counts" not in sig.comment:
                fail(f"{where}: comment {sig.comment!r} does not say the device sends counts")
            unit = unit_of(eds, sub) if index in PV_INDICES else ""
            if unit is not None and sig.unit != unit:
                fail(f"{where}: unit {sig.unit!r}, expected {unit!r}")
            checked += 1
    heartbeat = frames.get(0x700 + NODE_ID)
    if heartbeat is None or [s.name for s in heartbeat.signals][:1] != ["NMT_state"]:
        fail(f"no heartbeat message 0x{0x700 + NODE_ID:03X} with NMT_state")
    emcy_id = (eds.value(0x1014, 0) or 0x80 + NODE_ID) & 0x7FF  # 0x1014 absent: the predefined set
    if emcy_id not in frames or frames[emcy_id].size != 8:
        fail(f"no 8-byte EMCY message 0x{emcy_id:03X}")
    else:
        # The EMCY codes as the profile (its manual) names them, as the code signal's value table.
        named = {int(str(k), 0) if isinstance(k, str) else k: v for k, v in (doc.get("emcy") or {}).items()}
        table = {int(k): v for k, v in frames[emcy_id].signal_by_name("error_code").values.items()}
        missing = {c: t for c, t in named.items() if c != 0 and table.get(c) != t}
        if missing:
            fail(f"EMCY value table {table} lacks the profile's {missing}")
        # ... and the codes the node's CiA 301 services send (its options say which; 0: none).
        options = doc.get("options") or {}
        for option, default in (("error_passive_emcy", 0x8120), ("bus_off_recovery_emcy", 0x8140),
                                ("can_overrun_emcy", 0x8110)):
            code = options.get(option, default)
            if code and code not in table:
                fail(f"EMCY value table {table} lacks {option}'s 0x{code:04X}")
    if 0x080 not in frames or 0x000 not in frames:
        fail("no SYNC / NMT message")
    return checked


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimd", default=os.environ.get("CANSIMD", ""))
    p.add_argument("--source-dir", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    ns = p.parse_args()
    if not ns.cansimd or not os.access(ns.cansimd, os.X_OK):
        print("SKIP: cansimd is not built")
        return SKIP
    try:
        stderr, sys.stderr = sys.stderr, io.StringIO()  # canmatrix names the formats it lacks on import
        import canmatrix.formats
    except ImportError:
        print("SKIP: no python3-canmatrix (apt-get install python3-canmatrix)")
        return SKIP
    finally:
        sys.stderr = stderr
    os.chdir(ns.source_dir)
    errors: list = []
    for profile in PROFILES:
        n = check_profile(ns.cansimd, profile, canmatrix.formats, errors)
        print(f"{profile}: {n} PDO signals checked")
        if n == 0:
            errors.append(f"{profile}: no PDO signal checked")
    for e in errors:
        print("FAIL", e)
    print("PASS" if not errors else f"{len(errors)} failure(s)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
