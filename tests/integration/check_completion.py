#!/usr/bin/python3
"""completions/cansimctl (the bash completion the package installs) in a real
bash: verbs, node names from the daemon (a stand-in cansimctl that prints a
`list` table), channels, units by channel, fault kinds, NMT commands, verb
options, and the verbs it knows are exactly those `cansimctl help` lists.
No CAN, no daemon: registered as a unit-tier test (ctest name
bash_completion); skipped (77) without bash.

usage: check_completion.py --cansimctl PATH --source-dir DIR
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

LIST = """KEY                NAME       INTERFACE  ID    PROFILE      PERSONALITY    NMT
vcan0/dps/0        dps        vcan0      0x7f  dps          honeywell-dps  pre-operational
vcan0/generic/0    generic    vcan0      0x10  generic-404  generic        operational
vcan0/generic/1    generic    vcan0      0x11  generic-404  generic        operational
"""
PLANT = """vessel (step 0.001000 s, at 12.000000 s)
VARIABLE       KIND      VALUE  UNIT
tank.pressure  pressure  6      bar
faults: none
"""
PLANT_FAULTS = ["blocked", "input_lost", "leak", "valve_stuck"]


def complete(completion: str, fake: str, line: str, net: str = "") -> list:
    """COMPREPLY for the command line `line` (the cursor at its end); `net`:
    the folder of network interfaces (default: the machine's)."""
    script = f"""
source {completion}
{f"_cansimctl_net={net!r}" if net else ""}
COMP_LINE={line!r}
read -ra COMP_WORDS <<< "$COMP_LINE"
[[ $COMP_LINE == *' ' ]] && COMP_WORDS+=("")
COMP_WORDS[0]={fake}
COMP_CWORD=$((${{#COMP_WORDS[@]}} - 1))
_cansimctl
printf '%s\\n' "${{COMPREPLY[@]}}"
"""
    out = subprocess.run(["bash", "--norc", "--noprofile", "-c", script], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    return sorted(w for w in out.stdout.split("\n") if w)


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--cansimctl", required=True)
    p.add_argument("--source-dir", required=True)
    ns = p.parse_args()
    if not shutil.which("bash"):
        print("SKIP: no bash")
        return 77
    completion = os.path.join(ns.source_dir, "completions", "cansimctl")
    tmp = tempfile.mkdtemp()
    fake = os.path.join(tmp, "cansimctl")
    with open(fake, "w") as f:
        f.write("#!/bin/sh\ncase \" $* \" in *' list '*) cat <<'EOF'\n" + LIST + "EOF\n;;\n"
                "*' plant '*) cat <<'EOF'\n" + PLANT + "EOF\n;; esac\n")
    os.chmod(fake, 0o755)
    errors = []

    def expect(line, want, exact=True, net=""):
        got = complete(completion, fake, line, net)
        ok = got == sorted(want) if exact else set(want) <= set(got)
        if not ok:
            errors.append(f"{line!r}: got {got}, expected {'' if exact else 'at least '}{sorted(want)}")

    usage = subprocess.run([ns.cansimctl, "help"], capture_output=True, text=True).stdout
    verbs = re.findall(r"^  ([a-z-]+)", usage.split("Commands:")[1].split("\n\n")[0], re.M)
    expect("cansimctl ", verbs)
    expect("cansimctl po", ["power-cycle"])
    expect("cansimctl status ", ["dps", "dps/0", "generic", "generic/0", "generic/1", "vcan0/dps/0",
                                 "vcan0/generic/0", "vcan0/generic/1"])
    expect("cansimctl --socket /run/x/control set gen", ["generic", "generic/0", "generic/1"])
    expect("cansimctl set dps ", ["pressure", "temperature"])
    expect("cansimctl set dps pressure 5 ", ["MPa", "Pa", "bar", "kPa", "mbar", "psi"])
    expect("cansimctl set dps temperature 5 ", ["K", "degC", "degF"])
    expect("cansimctl set dps pressure 5 bar --", ["--ramp"], exact=False)
    # The fault kinds the daemon knows (physics/fault.cpp kNames).
    with open(os.path.join(ns.source_dir, "src", "physics", "fault.cpp")) as f:
        names = re.search(r"kNames\[kFaultKindCount\] = \{(.*?)\};", f.read(), re.S).group(1)
    kinds = re.findall(r'"([a-z_]+)"', names)
    expect("cansimctl fault dps ", [k for k in kinds if k not in PLANT_FAULTS])
    expect("cansimctl fault dps drift dur", ["duration="])
    # Plants: plant:NAME where a NODE goes, their own fault kinds and keys (docs/plants.md).
    assert sorted(k for k in kinds if k in PLANT_FAULTS) == PLANT_FAULTS, kinds
    expect("cansimctl fault plant:", ["plant:vessel"])
    expect("cansimctl fault plant:vessel ", PLANT_FAULTS)
    expect("cansimctl fault plant:vessel leak ta", ["target="])
    expect("cansimctl plant ", ["vessel"])
    expect("cansimctl plant vessel ", ["override", "set"])
    expect("cansimctl nmt 'generic/*' ", ["pre-operational", "reset-communication", "reset-node", "start", "stop"])
    expect("cansimctl write dps 0x1017 5 --type u", ["u16", "u32", "u64", "u8"])
    expect("cansimctl help mon", ["monitor"])
    expect("cansimctl --js", ["--json"])
    # monitor offers the CAN interfaces only (sysfs type 280), not eth0 or lo.
    net = os.path.join(tmp, "net")
    for dev, kind in (("vcan0", 280), ("can1", 280), ("eth0", 1), ("lo", 772)):
        os.makedirs(os.path.join(net, dev))
        with open(os.path.join(net, dev, "type"), "w") as f:
            f.write(f"{kind}\n")
    expect("cansimctl monitor ", ["can1", "vcan0"], net=net)
    expect("cansimctl monitor vcan0 v", ["vcan0"], net=net)
    expect("cansimctl capture ", ["can1", "vcan0"], net=net)
    expect("cansimctl replay bench.log --on ", ["can1", "vcan0"], net=net)
    expect("cansimctl override dps --", ["--off"], exact=False)
    shutil.rmtree(tmp, ignore_errors=True)
    for e in errors:
        print("FAIL", e)
    print("PASS" if not errors else f"{len(errors)} failure(s)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
