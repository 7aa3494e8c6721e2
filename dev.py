#!/usr/bin/env python3
"""The project's two entry points, usable with nothing but Python 3.11 and pip.

    python3 dev.py report [ARGS...]   the main job (``kinem report``)
    python3 dev.py test   [ARGS...]   the test suite (pytest)
    python3 dev.py kinem  [ARGS...]   any kinem command (``kinem solve CASE``, ``kinem --help``)

Each first makes ``.venv`` and installs the project into it (again only when
``pyproject.toml`` changed), so a fresh clone needs no other step.
"""
import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PYTHON = BIN / ("python.exe" if os.name == "nt" else "python")
STAMP = VENV / ".kinem-installed"


def ensure_env() -> None:
    digest = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    if STAMP.exists() and STAMP.read_text() == digest and PYTHON.exists():
        return
    if not PYTHON.exists():
        print("dev.py: creating .venv", file=sys.stderr)
        venv.create(VENV, with_pip=True)
    print("dev.py: installing kinem and its dependencies into .venv", file=sys.stderr)
    pip = [str(PYTHON), "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run(pip + ["install", "-e", f"{ROOT}[test]"], check=True)
    STAMP.write_text(digest)


def main(argv: list[str]) -> int:
    if not argv or argv[0] not in ("report", "test", "kinem"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    ensure_env()
    cmd, rest = argv[0], argv[1:]
    if cmd == "report":
        args = [str(PYTHON), "-m", "kinem", "report", *rest]
    elif cmd == "kinem":   # run where the user is: case and output paths are theirs
        return subprocess.run([str(PYTHON), "-m", "kinem", *rest]).returncode
    else:
        args = [str(PYTHON), "-m", "pytest", *rest]
    return subprocess.run(args, cwd=ROOT).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
