#!/usr/bin/env python3
"""examples/hil_bench_test.py, the HIL bench example, run as its users would:
`python3 -m pytest examples/hil_bench_test.py`, against the built cansimd
(CANSIMD, CANSIM_SOURCE_DIR, CANSIM_IT_TIME_SCALE set from this run).
pytest's exit status decides: 0 passes (tests skipped by the example
itself, only when cansimd answers io.cansim.Error.NotSupported, count as
passed and are listed with their reason); anything else fails, 5 ("no tests
collected") included."""

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
    env = dict(os.environ, CANSIMD=cansimd, CANSIM_SOURCE_DIR=ctx.source_dir, CANSIM_IFACE="vcan0",
               CANSIM_IT_TIME_SCALE=str(it.SCALE), PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", example]
    it.log(f"running {' '.join(cmd)} (CANSIMD={cansimd})")
    r = subprocess.run(cmd, cwd=ctx.tmp, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=it.scaled(30))
    print(r.stdout.rstrip(), flush=True)
    what = PYTEST_EXIT.get(r.returncode, "unknown")
    if r.returncode != 0:
        raise AssertionError(f"pytest {example}: exit status {r.returncode} ({what})")
    it.log(f"pytest exit status 0 ({what}{', some skipped' if ' skipped' in r.stdout else ''})")


it.main(test)
