#!/usr/bin/env python3
"""The project's two entry points, usable with nothing but Python 3.11 and pip.

    python3 dev.py report [ARGS...]   the main job (``kinem report``)
    python3 dev.py test   [ARGS...]   the test suite (pytest)
    python3 dev.py kinem  [ARGS...]   any kinem command (``kinem solve CASE``, ``kinem --help``)

Each first makes ``.venv`` and installs the project into it, building the
compiled core (kinem/core, Rust, by maturin in the release profile): again
when ``pyproject.toml`` or the crate's sources change, so a fresh clone
needs no other step. ``test`` also checks the crate (cargo fmt, clippy,
cargo test) and the layers of the Python package (import-linter) first, then
runs pytest on two worker processes (``-n 0`` for one).
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
CRATE = ROOT / "kinem" / "core"


def digest(paths) -> str:
    h = hashlib.sha256()
    for p in paths:
        h.update(str(p.relative_to(ROOT)).encode() + b"\0" + p.read_bytes())
    return h.hexdigest()


def ensure_env() -> None:
    """.venv with kinem installed (editable) and its core built: the
    dependencies again when pyproject.toml changes, the core alone when
    only the crate's sources do."""
    deps = digest([ROOT / "pyproject.toml"])
    core = digest([CRATE / "Cargo.toml", CRATE / "Cargo.lock", *sorted(CRATE.glob("src/**/*.rs"))])
    have = STAMP.read_text().split() if STAMP.exists() and PYTHON.exists() else []
    if have == [deps, core]:
        return
    if not PYTHON.exists():
        print("dev.py: creating .venv", file=sys.stderr)
        venv.create(VENV, with_pip=True)
    pip = [str(PYTHON), "-m", "pip", "--disable-pip-version-check", "-q"]
    if have[:1] == [deps]:
        print("dev.py: rebuilding kinem's compiled core", file=sys.stderr)
        subprocess.run(pip + ["install", "--no-deps", "-e", str(ROOT)], check=True)
    else:
        print("dev.py: installing kinem and its dependencies into .venv (and building its core)", file=sys.stderr)
        subprocess.run(pip + ["install", "-e", f"{ROOT}[test]"], check=True)
    STAMP.write_text(f"{deps} {core}")


def check_core() -> int:
    """The crate's own checks: formatting, clippy with warnings as errors,
    its unit tests (without the Python bindings), and the import layers."""
    env = {**os.environ, "CARGO_TERM_COLOR": "never"}
    for cmd in (["cargo", "fmt", "--check"], ["cargo", "clippy", "--release", "--all-targets", "--", "-D", "warnings"],
                ["cargo", "test", "--release", "--no-default-features"]):
        if subprocess.run(cmd, cwd=CRATE, env=env).returncode:
            print(f"dev.py: {' '.join(cmd)} failed", file=sys.stderr)
            return 1
    return subprocess.run([str(BIN / "lint-imports")], cwd=ROOT).returncode


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
        if check_core():
            return 1
        # both cores by default (the suite's tests are independent); -n 0 runs them in one process
        workers = [] if any(a == "-n" or a.startswith(("-n", "--numprocesses")) for a in rest) else ["-n", "2"]
        args = [str(PYTHON), "-m", "pytest", *workers, *rest]
    return subprocess.run(args, cwd=ROOT).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
