#!/usr/bin/python3
"""The package installs as docs/python.md says, without any package index:
its recipe (the sh block after <!-- venv-recipe -->, but apt-get) run as
written, in a copy of the checkout, with a python3 first in PATH that is
not Debian's (a copy of the interpreter with a prefix of its own: no
dist-packages, no setuptools, no wheel, as pyenv's or conda's), then
`import cansim` comes from the venv, jeepney from Debian, and pytest finds
the plugin by its entry point (pytest --help lists --cansim-config), also
when README's quick start command runs with the venv first in PATH (a venv
has no `pytest` script of its own: a bare `pytest` is Debian's, outside the
venv). The checkout stays clean. Exit 0 pass, 1 fail.
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = os.path.join(os.path.dirname(SOURCE), "docs", "python.md")
README = os.path.join(os.path.dirname(SOURCE), "README.md")


def recipe() -> str:
    """The install commands of docs/python.md, without the apt-get line."""
    with open(DOCS) as f:
        block = re.search(r"<!-- venv-recipe -->\s*```sh\n(.*?)```", f.read(), re.S).group(1)
    return "\n".join(line for line in block.splitlines() if not line.startswith("sudo apt-get"))


def foreign_python(tmp: str) -> str:
    """A python3 that is not Debian's: the interpreter copied under a prefix of
    its own (its stdlib linked), so it has no dist-packages, setuptools or wheel."""
    base = os.path.realpath(sys.executable)
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    root = os.path.join(tmp, "foreign")
    os.makedirs(os.path.join(root, "bin"))
    os.makedirs(os.path.join(root, "lib"))
    shutil.copy2(base, os.path.join(root, "bin", "python3"))
    os.symlink(os.path.join(os.path.dirname(os.path.dirname(base)), "lib", version), os.path.join(root, "lib", version))
    return os.path.join(root, "bin")


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
        venv = os.path.join(tmp, ".venv")
        env = dict(os.environ, PATH=foreign_python(tmp) + os.pathsep + os.environ.get("PATH", ""))
        r = subprocess.run(["sh", "-e", "-c", recipe()], cwd=tmp, env=env, capture_output=True, text=True)
        if r.returncode != 0:
            print(f"FAIL: docs/python.md's recipe with a foreign python3 first in PATH -> {r.returncode}\n"
                  f"{recipe()}\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
            return 1
        py = os.path.join(venv, "bin", "python")
        run(py, "-c", "import jeepney", cwd=tmp)
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
        with open(README, encoding="utf-8") as f:
            m = re.search(r"`([^`]*pytest) --cansim-config bench\.yaml test_bench\.py`", f.read())
        if not m:
            print("FAIL: README.md's quick start has no `... pytest --cansim-config bench.yaml test_bench.py`")
            return 1
        venv_first = dict(os.environ, PATH=os.path.join(venv, "bin") + os.pathsep + os.environ.get("PATH", ""))
        r = subprocess.run(m.group(1).split() + ["--help"], cwd=tmp, env=venv_first, capture_output=True, text=True)
        if "--cansim-config=PATH" not in r.stdout:
            print(f"FAIL: README's `{m.group(1)} --cansim-config ...` with the venv first in PATH does not know "
                  f"--cansim-config (exit {r.returncode}) {r.stderr.strip()[-200:]}")
            return 1
        print(f"PASS: installed into {where[0]}; pytest lists --cansim-config")
    return 0


if __name__ == "__main__":
    sys.exit(main())
