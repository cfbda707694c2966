"""README's Bench quick start test and examples/hil_bench_test.py as their
users run them, on a host without kernel CAN: `pytest -n 4` through the
plugin, python3-can's socketcand client as the master on the kernel-free
bus. Every test must run and pass: a skip fails this check."""

import os
import re
import subprocess
import sys

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def readme_block(marker: str, lang: str) -> str:
    with open(os.path.join(REPO, "README.md"), encoding="utf-8") as f:
        m = re.search(rf"<!-- {marker} -->\n```{lang}\n(.*?)```", f.read(), re.S)
    assert m, f"README.md has no ```{lang} block after <!-- {marker} -->"
    return m.group(1)


def test_quick_start_and_example_under_xdist(tmp_path):
    fleet, test = tmp_path / "bench.yaml", tmp_path / "test_bench.py"
    fleet.write_text(readme_block("quickstart-fleet", "yaml"))
    test.write_text(readme_block("quickstart-test", "python"))
    # One session for both: the example brings its own fleet (a cansim_config fixture), the quick start
    # takes --cansim-config; run from the checkout, where profile names resolve to profiles/.
    cmd = [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", "-p", "cansim.pytest_plugin",
           "-n", "4", "--cansim-require", f"--cansim-config={fleet}", f"--basetemp={tmp_path / 'base'}",
           os.path.join(REPO, "examples", "hil_bench_test.py"), str(test)]
    r = subprocess.run(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=180)
    print(r.stdout)
    assert r.returncode == 0, f"pytest exit status {r.returncode}"
    assert re.search(r"\b4 passed\b", r.stdout) and "skipped" not in r.stdout
