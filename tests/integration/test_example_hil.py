#!/usr/bin/env python3
"""examples/hil_bench_test.py, the HIL bench example, run as its users would:
`python3 -m pytest examples/hil_bench_test.py`, with the cansim client from
python/ (PYTHONPATH) and the built cansimd (CANSIMD). Every test of the
example must pass: a skip (no vcan0, say) fails this check, as do pytest's
other exit statuses, 5 ("no tests collected") included."""

# ctest-timeout: 180

import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

PYTEST_EXIT = {0: "all tests passed", 1: "tests failed", 2: "interrupted", 3: "internal error",
               4: "usage error", 5: "no tests collected"}


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    cansimd = ctx.require_cansimd()
    example = ctx.source("examples", "hil_bench_test.py")
    env = dict(os.environ, CANSIMD=cansimd, PYTHONPATH=ctx.source("python"), PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", example]
    it.log(f"running {' '.join(cmd)} (CANSIMD={cansimd})")
    # From the source folder, as a user of the checkout runs it: profile names resolve to profiles/.
    r = subprocess.run(cmd, cwd=ctx.source_dir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=it.scaled(30))
    print(r.stdout.rstrip(), flush=True)
    what = PYTEST_EXIT.get(r.returncode, "unknown")
    if r.returncode != 0:
        raise AssertionError(f"pytest {example}: exit status {r.returncode} ({what})")
    if " skipped" in r.stdout or " passed" not in r.stdout:
        raise AssertionError(f"pytest {example}: every test must run and pass")
    it.log(f"pytest exit status 0 ({what})")


it.main(test)
