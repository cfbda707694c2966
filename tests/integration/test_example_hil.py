#!/usr/bin/env python3
"""examples/hil_bench_test.py, the HIL bench example, run as its users would:
`python3 -m pytest examples/hil_bench_test.py`, with the cansim client from
python/ (PYTHONPATH) and the built cansimd (CANSIMD). Every test of the
example must pass: a skip (no vcan0, say) fails this check, as do pytest's
other exit statuses, 5 ("no tests collected") included. Then the same for
README's "Bench quick start": its fleet line and its test, as printed there."""

# ctest-timeout: 180

import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402

def readme_block(text: str, marker: str, lang: str) -> str:
    m = re.search(rf"<!-- {marker} -->\n```{lang}\n(.*?)```", text, re.S)
    assert m, f"README.md has no ```{lang} block after <!-- {marker} -->"
    return m.group(1)


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.run_pytest(ctx, "examples/hil_bench_test.py", ctx.source("examples", "hil_bench_test.py"))
    with open(ctx.source("README.md"), encoding="utf-8") as f:
        readme = f.read()
    fleet = os.path.join(ctx.tmp, "bench.yaml")
    test_file = os.path.join(ctx.tmp, "test_bench.py")
    with open(fleet, "w") as f:
        f.write(readme_block(readme, "quickstart-fleet", "yaml"))
    with open(test_file, "w") as f:
        f.write(readme_block(readme, "quickstart-test", "python"))
    it.run_pytest(ctx, "README's Bench quick start", "-p", "cansim.pytest_plugin", f"--cansim-config={fleet}", test_file)


it.main(test)
