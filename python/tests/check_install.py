#!/usr/bin/python3
"""The package installs as the README says, without any package index:

    python3 -m venv --system-site-packages VENV
    VENV/bin/pip install --no-build-isolation --no-index ./python

then `import cansim` comes from the venv and pytest finds the plugin by its
entry point (pytest --help lists --cansim-config). The checkout stays clean
(the build happens in a copy). Exit 0 pass, 1 fail.
"""

import os
import shutil
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(*cmd, cwd=None):
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        print(f"FAIL: {' '.join(cmd)} -> {r.returncode}\n{r.stdout}\n{r.stderr}")
        sys.exit(1)
    return r.stdout


def main():
    with tempfile.TemporaryDirectory(prefix="cansim-install-") as tmp:
        src = os.path.join(tmp, "python")
        shutil.copytree(SOURCE, src, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info", "tests"))
        venv = os.path.join(tmp, "venv")
        run(sys.executable, "-m", "venv", "--system-site-packages", venv)
        py = os.path.join(venv, "bin", "python")
        run(py, "-m", "pip", "install", "--quiet", "--no-build-isolation", "--no-index", src)
        where = run(py, "-c", "import cansim, os; print(os.path.dirname(cansim.__file__)); "
                              "print(os.path.exists(os.path.join(os.path.dirname(cansim.__file__), 'py.typed')))",
                    cwd=tmp).split()
        if not where[0].startswith(venv) or where[1] != "True":
            print(f"FAIL: cansim imported from {where[0]} (py.typed: {where[1]}), expected the venv {venv}")
            return 1
        help_text = run(py, "-m", "pytest", "--help", cwd=tmp)
        if "--cansim-config=PATH" not in help_text:
            print("FAIL: pytest does not load the cansim plugin by its entry point")
            return 1
        print(f"PASS: installed into {where[0]}; pytest lists --cansim-config")
    return 0


if __name__ == "__main__":
    sys.exit(main())
