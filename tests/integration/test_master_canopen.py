#!/usr/bin/env python3
"""An independent master: every shipped profile driven by the npm `canopen`
stack (on the npm `socketcan` binding), tests/master/master_check.js.

cansimd runs one node per profile on vcan0 at 250 kbit/s (distinct
node-IDs) plus two LSS-unconfigured generic-404 nodes (node-ID 255,
different serials). This script parses each profile (python3-yaml) into the
plan the master needs -- the object list (index, sub, type, access), the
options that decide what the device offers (block transfer, expedited only,
the documented quirks), the TPDO mappings -- and runs the JS master, which
prints one line per check with what it saw:

  read every readable object by SDO (expedited and segmented), reads of wo
  objects; writes refused on ro/const objects (0x06010002); segmented and
  block download/upload of the long objects with and without CRC, both ways,
  and a block upload of a short object (or the documented refusal where the
  device has no block transfer); NMT commands and the heartbeat states they
  produce; the master's heartbeat consumer (no timeout while the nodes run,
  a timeout while they are powered off); EMCY on a fault armed with
  cansimctl; TPDOs decoded from the profile's mapping; the EDS cansimd
  exports of each profile, loaded by the package's own EDS reader, lists
  exactly the plan's objects with the same data types and access (so the
  reads check the sizes the EDS announces); LSS fastscan of the
  unconfigured pair, inquire, configure node-ID + store, boot-up on the new
  ID, reset node.

Documented device deviations (docs/devices/*.md) are SKIP lines naming the
doc, not failures. Needs node + tests/master/node_modules (scripts/install-deps
runs `npm ci --prefix tests/master`)."""
# ctest-timeout: 240

import json
import os
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

# profile file -> (node-ID on the test bus, fleet name, fault that raises an EMCY, doc).
# The generic personality has no sensor EMCY: its EMCY is the core's bus-off
# recovery (0x8140, then the error reset), kept shorter than the heartbeat
# consumer time.
PROFILES = {
    "generic-404": (0x10, "generic", "bus_off", "README.md (generic-404)"),
    "dps": (0x7F, "dps", "open", "docs/devices/dps.md"),
    "p92c": (0x01, "p92c", "open", "docs/devices/p92c.md"),
    "gems9000": (0x0A, "gems", "open", "docs/devices/gems9000.md"),
    "smc": (0x20, "smc", "open", "docs/devices/smc.md"),
    "cmp": (0x05, "cmp", "over_temperature", "docs/devices/cmp.md"),
}
LSS_SERIALS = (0x1001, 0x1002)
LSS_NEW_IDS = (0x30, 0x31)
HB_MS = 200
MASTER_ID = 0x7E

TYPE_BITS = {"BOOLEAN": 8, "INTEGER8": 8, "UNSIGNED8": 8, "INTEGER16": 16, "UNSIGNED16": 16,
             "INTEGER32": 32, "UNSIGNED32": 32, "REAL32": 32, "INTEGER64": 64,
             "UNSIGNED64": 64, "REAL64": 64}
LONG_TYPES = ("VISIBLE_STRING", "OCTET_STRING", "DOMAIN")


def value_of(v, node_id: int):
    """A profile default: numbers in any base, sums with $NODEID."""
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, (int, float)):
        return v
    s = str(v).replace(" ", "")
    if "$NODEID" in s:
        return sum(node_id if t == "$NODEID" else int(t, 0) for t in s.split("+"))
    return int(s, 0)


def subs_of(row) -> list:
    s = row.get("sub", 0)
    if isinstance(s, str) and ".." in s:
        a, b = s.split("..")
        return list(range(int(a, 0), int(b, 0) + 1))
    return [int(s) if not isinstance(s, str) else int(s, 0)]


def default_bytes(row) -> bytes:
    d = row.get("default", "")
    t = row["type"]
    if t == "VISIBLE_STRING":
        return str(d).encode("latin-1")
    if t in ("OCTET_STRING", "DOMAIN"):
        return bytes.fromhex(str(d).replace(" ", "").replace(":", ""))
    return b""


def abort_map(opts: dict) -> dict:
    m = {}
    for pair in str(opts.get("sdo_abort_map", "") or "").split(","):
        if "=" in pair:
            a, b = pair.split("=")
            m[int(a, 0)] = int(b, 0)
    return m


def plan_node(ctx: it.Context, key: str) -> dict:
    import yaml
    node_id, name, fault, doc = PROFILES[key]
    with open(ctx.source("profiles", f"{key}.yaml")) as f:
        prof = yaml.safe_load(f)
    opts = prof.get("options") or {}
    amap = abort_map(opts)
    objects = []
    by_key = {}
    for row in prof["objects"]:
        for sub in subs_of(row):
            t = row["type"]
            o = {"index": int(row["index"]), "sub": sub, "type": t, "access": row["access"]}
            if t in LONG_TYPES:
                d = default_bytes(row)
                o["max_length"] = int(row.get("max_length", len(d)))
                o["default_bytes"] = d.hex()
                o["long"] = o["max_length"] > 4
            objects.append(o)
            by_key[(o["index"], sub)] = (o, row)

    def default(index, sub):
        o, row = by_key[(index, sub)]
        return value_of(row.get("default", 0), node_id)

    tpdos = []
    for n in range(4):
        if (0x1800 + n, 1) not in by_key or (0x1A00 + n, 0) not in by_key:
            continue
        cob = default(0x1800 + n, 1)
        ttype = default(0x1800 + n, 2) if (0x1800 + n, 2) in by_key else 255
        count = default(0x1A00 + n, 0)
        if cob & 0x80000000 or not (ttype <= 240 or ttype >= 254) or count == 0:
            continue
        mapping = []
        for s in range(1, count + 1):
            m = default(0x1A00 + n, s)
            idx, sub, bits = m >> 16, (m >> 8) & 0xFF, m & 0xFF
            t = by_key[(idx, sub)][0]["type"] if (idx, sub) in by_key else {8: "UNSIGNED8", 16: "UNSIGNED16", 32: "UNSIGNED32"}[bits]
            mapping.append({"index": idx, "sub": sub, "bits": bits, "type": t})
        tpdos.append({"cob_id": cob & 0x7FF, "type": ttype, "mapping": mapping})

    refusal = int(opts.get("sdo_refusal_abort", 0x05040001))
    refusal = amap.get(refusal, refusal)
    long_abort = int(opts.get("sdo_long_upload_abort", 0x05040001))
    long_abort = amap.get(long_abort, long_abort)
    long_readable = [o for o in objects if o.get("long") and o["access"] != "wo"]
    return {
        "profile": key, "name": name, "id": node_id, "doc": doc, "fault": fault,
        "fault_for": "300ms" if fault == "bus_off" else "1s",
        # SMC: 0x1001 bit 0 and the sensor error are latched until power-off
        "emcy_reset": key != "smc",
        "emcy_reset_doc": "docs/devices/smc.md: EMCY 0x5030, 0x1001 bit 0 latched until power-off" if key == "smc" else "",
        "hb_ms": HB_MS, "hb_default": False,
        "objects": objects,
        "tpdos": tpdos,
        "expect_segmented": bool(long_readable) and not opts.get("sdo_expedited_only", False)
                            and opts.get("sdo_segmented_upload", True),
        "big_endian_note": "0x6130/0x7130/0x9130 big-endian in TPDOs, docs/devices/smc.md" if key == "smc" else "",
        "options": {
            "sdo_block_transfer": opts.get("sdo_block_transfer", True),
            "sdo_expedited_only": opts.get("sdo_expedited_only", False),
            "sdo_upload_response_0x60": opts.get("sdo_upload_response_0x60", False),
            "size_indicated": opts.get("sdo_upload_size_indicated", True),
            "tpdo_dlc_always_8": opts.get("tpdo_dlc_always_8", False),
            "refusal_abort": refusal,
            # uploads of objects > 4 bytes refused on expedited-only devices (documented)
            "long_upload_abort": long_abort if (opts.get("sdo_expedited_only", False)
                                                or not opts.get("sdo_segmented_upload", True)) else None,
            "segmented_download_indices": str(opts.get("sdo_segmented_download_indices", "") or ""),
        },
    }


def lss_plan(ctx: it.Context) -> dict:
    import yaml
    with open(ctx.source("profiles", "generic-404.yaml")) as f:
        prof = yaml.safe_load(f)
    ident = {}
    for row in prof["objects"]:
        if row["index"] == 0x1018 and row.get("sub") in (1, 2, 3):
            ident[row["sub"]] = value_of(row["default"], 0)
    return {"profile": "generic-404-lss", "serials": list(LSS_SERIALS), "new_ids": list(LSS_NEW_IDS),
            "identity": [ident[1], ident[2], ident[3]], "timeout_ms": 50}


def test(ctx: it.Context) -> None:
    try:
        import yaml  # noqa: F401
    except ImportError:
        raise AssertionError("python3-yaml is missing (scripts/install-deps)")
    node = shutil.which("node")
    master_dir = ctx.source("tests", "master")
    if not node:
        raise AssertionError("node is missing (scripts/install-deps installs nodejs)")
    if not os.path.isdir(os.path.join(master_dir, "node_modules", "canopen")) or \
            not os.path.isdir(os.path.join(master_dir, "node_modules", "socketcan")):
        raise AssertionError("tests/master/node_modules is missing: scripts/install-deps "
                             "(npm ci --prefix tests/master)")
    it.require_iface("vcan0")
    cansimctl = os.path.join(os.path.dirname(ctx.require_cansimd()), "cansimctl")
    if not os.access(cansimctl, os.X_OK):
        it.skip(f"cansimctl not built next to cansimd ({cansimctl})")

    nodes = [plan_node(ctx, k) for k in PROFILES]
    for n in nodes:  # read by the package's own EDS reader (edsCheck in master_check.js)
        n["eds"] = os.path.join(ctx.tmp, n["profile"] + ".eds")
        subprocess.run([ctx.require_cansimd(), "--export-eds", ctx.source("profiles", n["profile"] + ".yaml"),
                        "--output", n["eds"]], check=True, timeout=it.scaled(10))
    d = ctx.daemon("--config", "{state_dir}/fleet.yaml", "--state-dir", "{state_dir}",
                   "--control-socket", "{state_dir}/control", "--bus", "none")
    lines = ["interfaces:", "  vcan0: {bit_rate: 250}", "nodes:"]
    for n in nodes:
        lines.append(f"  - {{profile: {ctx.source('profiles', n['profile'] + '.yaml')}, interface: vcan0, "
                     f"node_id: {n['id']}, name: {n['name']}, bit_rate: 250}}")
    for i, s in enumerate(LSS_SERIALS):
        lines.append(f"  - {{profile: {ctx.source('profiles', 'generic-404.yaml')}, interface: vcan0, "
                     f"node_id: 255, name: lss{i}, serial: {s}}}")
    with open(os.path.join(d.state_dir, "fleet.yaml"), "w") as f:
        f.write("\n".join(lines) + "\n")
    sock = os.path.join(d.state_dir, "control")

    plan = {"channel": "vcan0", "master_id": MASTER_ID, "scale": it.SCALE, "sdo_timeout_ms": 1000,
            "cansimctl": cansimctl, "control_socket": sock, "nodes": nodes, "lss": lss_plan(ctx)}
    plan_path = os.path.join(ctx.tmp, "plan.json")
    with open(plan_path, "w") as f:
        json.dump(plan, f, indent=1)

    with it.open_bus("vcan0") as bus:
        it.drain(bus)
        d.start()
        want = {n["id"] for n in nodes}
        seen = set()
        deadline = time.monotonic() + it.scaled(10)
        while seen != want and time.monotonic() < deadline:
            m = it.wait_for(bus, lambda x: x.arbitration_id - 0x700 in want and bytes(x.data) == b"\0",
                            deadline - time.monotonic())
            if m is not None:
                seen.add(m.arbitration_id - 0x700)
        assert seen == want, f"boot-ups seen: {sorted(map(hex, seen))} of {sorted(map(hex, want))}"
    it.wait_for_path(sock, 5)
    d.assert_alive()

    it.log(f"running the master: {node} tests/master/master_check.js ({len(nodes)} nodes + LSS pair)")
    t0 = time.monotonic()
    p = subprocess.run([node, os.path.join(master_dir, "master_check.js"), plan_path],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=min(it.scaled(60), 220), cwd=master_dir)
    out = p.stdout
    for line in out.splitlines():
        print(line, flush=True)
    it.log(f"master finished with status {p.returncode} in {time.monotonic() - t0:.1f} s")
    fails = [ln for ln in out.splitlines() if ln.startswith("CHECK ") and " FAIL " in ln]
    for ln in out.splitlines():
        if ln.startswith("CHECK ") and " DISAGREE " in ln:
            it.log(f"disagreement (cansimd follows CiA 301 here, the master does not): {ln}")
    assert "SUMMARY" in out, "the master did not finish (no SUMMARY line)"
    assert p.returncode == 0 and not fails, f"{len(fails)} checks failed:\n" + "\n".join(fails)
    d.assert_alive()


it.main(test)
