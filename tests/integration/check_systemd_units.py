#!/usr/bin/env python3
"""`systemd-analyze verify` on systemd/cansimd.service and cansimd@.service.

The units run /usr/bin/cansimd, which need not be installed here: they are
verified as copies whose ExecStart= points at the built cansimd, with MANPATH
at the repository's man/ so their Documentation=man: pages must exist there.
Any message about the units (unknown keys, bad values, missing commands or
man pages) fails the check.
Skipped (exit 77) when systemd-analyze is missing, e.g. in minimal containers.
Registered as ctest 'systemd_units' (label unit: no CAN needed) by
tests/integration/CMakeLists.txt.

usage: check_systemd_units.py --cansimd PATH --source-dir DIR
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile

UNITS = ("cansimd.service", "cansimd@.service")


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimd", default=os.environ.get("CANSIMD", ""))
    p.add_argument("--source-dir", default=os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
    a = p.parse_args()
    tool = shutil.which("systemd-analyze")
    if not tool:
        print("SKIP: systemd-analyze not found (install systemd to verify the unit files)")
        return 77
    if not a.cansimd or not os.access(a.cansimd, os.X_OK):
        print(f"SKIP: cansimd is not built ({a.cansimd or 'no target'})")
        return 77
    binary = os.path.abspath(a.cansimd)
    with tempfile.TemporaryDirectory(prefix="cansim-units-") as tmp:
        paths = []
        for u in UNITS:
            with open(os.path.join(a.source_dir, "systemd", u)) as f:
                text = f.read()
            assert "/usr/bin/cansimd" in text, f"{u}: no /usr/bin/cansimd in it"
            dst = os.path.join(tmp, u)
            with open(dst, "w") as f:
                f.write(text.replace("/usr/bin/cansimd", binary))
            paths.append(dst)
        # Without man(1) the pages cannot be looked up at all.
        man = ["--man=no"] if shutil.which("man") is None else []
        env = dict(os.environ, MANPATH=os.path.join(a.source_dir, "man"))
        r = subprocess.run([tool, "verify", *man, *paths], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, timeout=120, env=env)
    out = r.stdout.strip()
    version = subprocess.run([tool, "--version"], stdout=subprocess.PIPE, text=True).stdout.split("\n")[0]
    print(f"{version}: systemd-analyze verify {' '.join(UNITS)}: exit {r.returncode}")
    about_units = [line for line in out.splitlines() if "cansimd" in line]
    if out:
        print(out)
    if r.returncode != 0 or about_units:
        print("FAIL: systemd-analyze verify reported problems in the unit files")
        return 1
    print("PASS: both unit files verify cleanly")
    return 0


if __name__ == "__main__":
    sys.exit(main())
