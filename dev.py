#!/usr/bin/env python3
"""The project's two entry points, usable with nothing but Python 3.11 and pip.

    python3 dev.py report [ARGS...]   the main job (``kinem report``)
    python3 dev.py test   [ARGS...]   the test suite (pytest)
    python3 dev.py kinem  [ARGS...]   any kinem command (``kinem solve CASE``, ``kinem --help``)

Each first makes ``.venv`` and installs the project into it, building the
compiled core (kinem/core, Rust, by maturin in the release profile): again
when ``pyproject.toml`` or the crate's sources change, so a fresh clone
needs no other step. The build takes minutes the first time: its stages
(pip's downloads, each crate cargo compiles) are printed as they happen,
with the seconds elapsed; on a failure, the last lines of the build's own
output. ``test`` also checks the crate (cargo fmt, clippy,
cargo test) and the layers of the Python package (import-linter) first, then
runs pytest on two worker processes (``-n 0`` for one).
"""
import collections
import hashlib
import os
import subprocess
import sys
import tempfile
import time
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
    only the crate's sources do; kinem's Python byte-compiled (`compiled`)."""
    deps = digest([ROOT / "pyproject.toml"])
    core = digest([CRATE / "Cargo.toml", CRATE / "Cargo.lock", *sorted(CRATE.glob("src/**/*.rs"))])
    have = STAMP.read_text().split() if STAMP.exists() and PYTHON.exists() else []
    if have != [deps, core]:
        if not PYTHON.exists():
            print("dev.py: creating .venv", file=sys.stderr)
            venv.create(VENV, with_pip=True)
        pip = [str(PYTHON), "-m", "pip", "--disable-pip-version-check", "-v"]
        if have[:1] == [deps]:
            with_progress(pip + ["install", "--no-deps", "-e", str(ROOT)], "rebuilding kinem's compiled core")
        else:
            with_progress(pip + ["install", "-e", f"{ROOT}[test]"],
                          "installing kinem and its dependencies into .venv and building its core")
        STAMP.write_text(f"{deps} {core}")
    compiled()


def compiled() -> None:
    """kinem's Python byte-compiled here, as a wheel's install does, at every
    command (only what changed since: a pull that edits Python alone leaves
    the stamp as it is): a run then writes no bytecode in the tree."""
    subprocess.run([str(PYTHON), "-m", "compileall", "-q", "kinem", "adapters"], cwd=ROOT, check=True)


# the lines of pip's and cargo's verbose output that mark a stage of the install
STAGES = ("Collecting ", "Downloading ", "Building wheel", "Building editable", "Compiling ", "Finished ",
          "Installing collected", "Successfully installed", "\U0001f4e6")   # the last: maturin's "Built wheel"
TAIL = 40   # lines of the build's own output shown when it fails


def stage(line: str) -> str | None:
    """The stage a line of the verbose install output marks, or None."""
    text = line.strip()
    return text if text.startswith(STAGES) else None


def with_progress(cmd, what) -> None:
    """Runs the (verbose) pip command, printing each stage it reaches with the
    seconds elapsed, so that a multi-minute build shows it is alive; on a
    failure, the last TAIL lines of its output, then CalledProcessError."""
    start = time.monotonic()
    print(f"dev.py: {what} (minutes the first time; its stages follow)", file=sys.stderr, flush=True)
    tail = collections.deque(maxlen=TAIL)
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace") as p:
        for line in p.stdout:
            tail.append(line)
            shown = stage(line)
            if shown:
                print(f"dev.py: [{time.monotonic() - start:5.0f} s] {shown[:110]}", file=sys.stderr, flush=True)
    if p.returncode:
        sys.stderr.write("".join(tail))
        raise subprocess.CalledProcessError(p.returncode, cmd)
    print(f"dev.py: done in {time.monotonic() - start:.0f} s", file=sys.stderr, flush=True)


def check_core() -> int:
    """The crate's own checks: formatting, clippy with warnings as errors,
    its unit tests (without the Python bindings), and the import layers."""
    env = {**os.environ, "CARGO_TERM_COLOR": "never"}
    for cmd in (["cargo", "fmt", "--check"], ["cargo", "clippy", "--release", "--all-targets", "--", "-D", "warnings"],
                ["cargo", "test", "--release", "--no-default-features"]):
        if subprocess.run(cmd, cwd=CRATE, env=env).returncode:
            print(f"dev.py: {' '.join(cmd)} failed", file=sys.stderr)
            return 1
    return subprocess.run([str(BIN / "lint-imports"), "--no-cache"], cwd=ROOT).returncode


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
        args = [str(PYTHON), "-m", "pytest", "-p", "no:cacheprovider", *workers, *rest]
        # the tests write only under temporary folders: no bytecode of theirs nor of what they run, no
        # pytest cache, hypothesis's store in a temporary folder
        with tempfile.TemporaryDirectory(prefix="kinem-hypothesis-") as store:
            env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1", "HYPOTHESIS_STORAGE_DIRECTORY": store}
            return subprocess.run(args, cwd=ROOT, env=env).returncode
    return subprocess.run(args, cwd=ROOT).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
