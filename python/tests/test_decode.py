"""What the client makes of a node's frames, without a daemon: PDO entries
by their mapping (bit fields, signed types, scales, a frame shorter than
its mapping) and monitor lines in cansimctl monitor's words."""

import struct

from cansim._decode import MappedEntry, Monitor, NodeView, PdoMapping, decode_pdo, engineering
from cansim._wire import Frame

MAPPING = PdoMapping("TPDO2", 0x290, False, True, 1, (
    MappedEntry(0x7130, 1, 16, "AI input PV 1 (INTEGER16)", "INTEGER16", 0.01, "bar"),
    MappedEntry(0, 0, 4, "", "", 1.0, ""),                   # a dummy entry: skipped, its bits counted
    MappedEntry(0x2100, 1, 1, "Flag", "BOOLEAN", 1.0, ""),
    MappedEntry(0x2100, 2, 3, "Code", "UNSIGNED8", 1.0, ""),
    MappedEntry(0x6130, 1, 32, "AI input PV 1", "REAL32", 1.0, "kPa"),
))


def frame(can_id, data, channel="bench"):
    return Frame(1700000000.25, channel, can_id, False, False, bytes(data), len(data))


def test_entries_by_their_bits_types_and_scales():
    data = struct.pack("<h", -350) + bytes([0b1011_0000]) + struct.pack("<f", 250.5)
    values, units, error = decode_pdo(MAPPING, data)
    assert error is None
    assert values == {"AI input PV 1 (INTEGER16)": -3.5, "Flag": True, "Code": 0b101, "AI input PV 1": 250.5}
    assert units["AI input PV 1 (INTEGER16)"] == "bar" and units["AI input PV 1"] == "kPa" and units["Flag"] == ""


def test_a_short_frame_decodes_what_fits_and_says_so():
    values, _, error = decode_pdo(MAPPING, struct.pack("<h", 123) + b"\x00")
    assert list(values) == ["AI input PV 1 (INTEGER16)", "Flag", "Code"]
    assert error == "frame too short for the mapping (DLC 3)"


def test_scaled_values_keep_their_decimals():
    assert engineering(350, 0.01) == 3.5 and engineering(-7, 0.1) == -0.7 and engineering(5, 1.0) == 5
    assert engineering(3, 0.25) == 0.75  # not a power of ten: as it is


def test_monitor_lines():
    node = NodeView("bench/pt/0", "pt/0", "bench", 0x10, [MAPPING], {0x5030: "sensor open"})
    m = Monitor([node])
    tpdo = m.line(frame(0x290, struct.pack("<h", 350) + b"\x00" + struct.pack("<f", 1.0)))
    assert tpdo.endswith(" bench 290 pt/0 TPDO2 AI input PV 1 (INTEGER16) = 3.5 bar, Flag = False, Code = 0, "
                         "AI input PV 1 = 1 kPa"), tpdo
    assert m.line(frame(0x000, [0x81, 0x10])).endswith(" bench 000 pt/0 NMT reset-node, node-ID = 0x10")
    assert m.line(frame(0x000, [0x01, 0x00])).endswith(" bench 000 - NMT start, node-ID = all")
    assert m.line(frame(0x710, [0x00])).endswith(" bench 710 pt/0 boot-up")
    assert m.line(frame(0x710, [0x85])).endswith(" bench 710 pt/0 heartbeat operational, toggle = 1")
    assert m.line(frame(0x090, [0x30, 0x50, 0x21, 1, 2, 3, 4, 5])).endswith(
        " bench 090 pt/0 EMCY code = 0x5030, meaning = sensor open, register = 0x21, vendor = 01 02 03 04 05")
    assert m.line(frame(0x610, [0x2B, 0x17, 0x10, 0, 0xE8, 0x03, 0, 0])).endswith(
        " bench 610 pt/0 SDO download request 0x1017:00 = e8 03")
    assert m.line(frame(0x590, [0x80, 0x00, 0x20, 0, 0x00, 0x00, 0x02, 0x06])).endswith(
        " bench 590 pt/0 SDO abort 0x2000:00, code = 0x06020000")
    assert m.line(frame(0x080, [])).endswith(" bench 080 - SYNC")
    assert m.line(frame(0x123, [0xAB])).endswith(" bench 123 - raw data = ab")
    assert m.line(frame(0x710, [0x7F], channel="other")).endswith(" other 710 - raw data = 7f")  # not its bus
