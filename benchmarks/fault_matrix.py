"""Issue 25's "done when": mutated case files and a fault matrix, each run
checked against the command line's contract.

    python benchmarks/fault_matrix.py [--cases 5000] [--faults 48] [--seed 0] [--json FILE]

Fuzz: ``--cases`` mutated case files (the mutations of tests/test_fuzz.py:
deleted, renamed, invalid and odd values, swapped bodies, and its SLOW_KINDS:
drivers up to 1e6 times faster than the output step, tables of up to 1e5
rows, outline splines cut short), each run by ``kinem info`` or
``kinem solve --steps 3 --out o.csv`` (the default limits) in this process.
Contract: exit 0, 1 or 2; no traceback or internal error; one line on
standard error for 1 and 2; no output unless 0; nothing left in the folder;
every case answered or refused within LIMIT_S. A progress line every
PROGRESS cases (a long run can be stopped and still tell its figures).

Fault matrix, each run in a scratch folder (its cwd and TMPDIR) in a session
of its own, its output path holding an old file of mode 0600 beforehand:

- SIGKILL or SIGTERM at a random moment of ``solve``, ``report --jobs 2``,
  ``export`` and ``animate``;
- disk full: the output on a small tmpfs (when this process may mount one);
- closed standard output, error, or both.

Contract: exit 0, 1, 2, 141, 128 + the signal or killed by it, never 3; no
traceback; no process of the session left 5 s after the end; the output is
the old file or the complete new one (equal to a reference run's, for
solve), with mode 0600 either way; nothing in the scratch folder but the
named outputs. Prints one line per violation and a summary; exit 1 when
there is any.
"""
import argparse
import contextlib
import io
import json
import os
import random
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

CASES = ROOT / "cases"
OLD = b"old content\n"
SETTLE = 5.0   # seconds a killed command's processes get to end (the bound)
LIMIT_S = 60.0   # seconds within which every fuzzed case is answered (issue 33)
PROGRESS = 50
BASES = ("slider_crank", "four_bar", "quick_return_3", "pin_in_spline_slot", "cam_table41")


# -- fuzz ---------------------------------------------------------------------------------------

def fuzz(n, rng, problems):
    """n mutated cases through kinem.cli.main in this process; returns (counts by exit code, slowest s)."""
    import tomllib

    from kinem.cli import main
    from test_fuzz import KINDS, SLOW_KINDS, mutate

    bases = {b: tomllib.loads((CASES / f"{b}.toml").read_text()) for b in BASES}
    counts, slowest, begun = {}, 0.0, time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for k in range(n):
            text, invalid = mutate(bases[rng.choice(sorted(bases))], rng.choice, KINDS + SLOW_KINDS)
            case = folder / "case.toml"
            case.write_text(text)
            command = rng.choice(["info", "solve"])
            args = [command, str(case)] + (["--steps", "3", "--out", str(folder / "o.csv")] if command == "solve"
                                           else [])
            err = io.StringIO()
            start = time.monotonic()
            try:
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    code = main(args)
            except BaseException as e:  # noqa: BLE001 - a violation, recorded
                code = f"raised {type(e).__name__}"
            took = time.monotonic() - start
            slowest = max(slowest, took)
            counts[code] = counts.get(code, 0) + 1
            e = err.getvalue()
            why = []
            if code not in (0, 1, 2):
                why.append(f"exit {code}")
            if "Traceback" in e or "internal error" in e:
                why.append("traceback or internal error")
            lines = [line for line in e.splitlines() if not line.startswith("kinem: warning: ")]  # warnings: own lines
            if code in (1, 2) and (len(lines) != 1 or not lines[0].startswith("kinem: ")):
                why.append("not one line")
            if took > LIMIT_S:
                why.append(f"took {took:.0f} s")
            if invalid and code != 2:
                why.append("invalid case not exit 2")
            if code != 0 and (folder / "o.csv").exists():
                why.append("output written by a failed run")
            left = sorted(p.name for p in folder.iterdir() if p.name not in ("case.toml", "o.csv"))
            if left:
                why.append(f"left {left}")
            if why:
                keep = folder.parent / f"kinem-fuzz-{k}.toml"
                shutil.copy(case, keep)
                problems.append(f"fuzz {k} ({command}): {'; '.join(why)}: {e.strip()[:200]} (case kept in {keep})")
            (folder / "o.csv").unlink(missing_ok=True)
            if (k + 1) % PROGRESS == 0:
                print(f"fuzz progress: {k + 1} cases in {time.monotonic() - begun:.0f} s, exit codes "
                      f"{dict(sorted(counts.items(), key=str))}, slowest {slowest:.1f} s, {len(problems)} problems",
                      flush=True)
    return counts, slowest


# -- fault matrix ---------------------------------------------------------------------------------

def commands(scratch):
    """name -> (argv after 'kinem', output path, whether the output must equal the reference)."""
    slider, four = str(CASES / "slider_crank.toml"), str(CASES / "four_bar.toml")
    return {
        "solve": (["solve", slider, "--steps", "40000", "--outputs", "positions", "--out", str(scratch / "o.csv")],
                  scratch / "o.csv", True),
        "report": (["report", four, "--engines", "pymunk", "--out", str(scratch / "r"), "--baseline", "none",
                    "--no-stress", "--quick", "--jobs", "2"], None, False),
        "export": (["export", slider, "--engine", "pymunk", "--out", str(scratch / "m.py")], scratch / "m.py", True),
        "animate": (["animate", four, "--engines", "native", "--out", str(scratch / "a.gif")],
                    scratch / "a.gif", False),
    }


def session_processes(sid):
    """PIDs of the live processes of session sid (from /proc)."""
    from test_orphans import processes

    return processes(3, sid)


def launch(argv, scratch, redirect=""):
    env = {**os.environ, "TMPDIR": str(scratch / "tmp"), "PYTHONPATH": os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}
    cmd = [sys.executable, "-m", "kinem", *argv]
    if redirect:
        cmd = ["sh", "-c", f'exec "$@" {redirect}', "sh", *cmd]
    return subprocess.Popen(cmd, cwd=scratch, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)


def prepare(scratch, out):
    scratch.mkdir(parents=True, exist_ok=True)
    for q in scratch.iterdir():   # emptied, not removed: it may be a mount point
        shutil.rmtree(q) if q.is_dir() and not q.is_symlink() else q.unlink()
    (scratch / "tmp").mkdir()
    if out is not None:
        out.write_bytes(OLD)
        os.chmod(out, 0o600)


def judge(label, p, scratch, out, reference, killed_by, problems, keep=()):
    """Checks a finished run (p waited for) against the contract."""
    try:
        stdout, stderr = p.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        stdout, stderr = p.communicate()
        problems.append(f"{label}: did not end within 600 s")
    err = stderr.decode(errors="replace")
    code = p.returncode
    allowed = {0, 1, 2, 141}
    if killed_by is not None:
        allowed |= {-killed_by, 128 + killed_by}
    if code not in allowed:
        problems.append(f"{label}: exit {code}: {err.strip()[:200]}")
    if "Traceback" in err or "internal error" in err:
        problems.append(f"{label}: traceback or internal error: {err.strip()[-300:]}")
    end = time.monotonic() + SETTLE
    while session_processes(p.pid) and time.monotonic() < end:
        time.sleep(0.05)
    left = session_processes(p.pid)
    if left:
        problems.append(f"{label}: processes left {left}")
        for pid in left:   # ours: started by this run
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
    named = ({out} if out is not None else set()) | {scratch / k for k in keep}
    if out is not None and out.exists():
        data = out.read_bytes()
        mode = stat.S_IMODE(os.stat(out).st_mode)
        if data != OLD and reference is not None and data != reference:
            problems.append(f"{label}: output is neither the old file nor the complete new one")
        if data != OLD and reference is None and code != 0:
            problems.append(f"{label}: output replaced by a run that did not succeed (exit {code})")
        if mode != 0o600:
            problems.append(f"{label}: output mode {oct(mode)}, not 0o600")
    elif out is not None:
        problems.append(f"{label}: output removed")
    report = scratch / "r"
    extra = [str(q.relative_to(scratch)) for q in scratch.rglob("*")
             if q not in named and q != scratch / "tmp" and not (q == report or report in q.parents)]
    extra += [str(q.relative_to(scratch)) for q in report.rglob("*") if q.name.endswith(".tmp")] \
        if report.exists() else []
    if extra:
        problems.append(f"{label}: files left outside the named outputs: {extra[:5]}")
    return code


def references(scratch, problems, names):
    """name -> (seconds a whole run takes, its output bytes or None)."""
    out = {}
    for name, (argv, path, exact) in commands(scratch).items():
        if name not in names:
            continue
        prepare(scratch, path)
        start = time.monotonic()
        p = launch(argv, scratch)
        code = judge(f"reference {name}", p, scratch, path, None, None, problems)
        out[name] = (time.monotonic() - start, path.read_bytes() if exact and path is not None and code == 0
                     else None)
    return out


def faults(n, rng, problems, root, names=("solve", "report", "export", "animate"), disk=True):
    scratch = root / "scratch"
    refs = references(scratch, problems, names)
    table = {}
    for k in range(n):
        name = rng.choice(sorted(refs))
        sig = rng.choice([signal.SIGKILL, signal.SIGTERM])
        argv, path, _ = commands(scratch)[name]
        prepare(scratch, path)
        delay = rng.uniform(0.0, refs[name][0])
        p = launch(argv, scratch)
        time.sleep(delay)
        with contextlib.suppress(ProcessLookupError):
            os.kill(p.pid, sig)
        code = judge(f"{name} {signal.Signals(sig).name} at {delay:.2f} s", p, scratch, path, refs[name][1], sig,
                     problems)
        table.setdefault(f"{name} {signal.Signals(sig).name}", []).append(code)
    for name in [m for m in ("solve", "export", "animate") if m in names]:
        argv, path, _ = commands(scratch)[name]
        for redirect in (">&-", "2>&-", ">&- 2>&-"):
            prepare(scratch, path)
            code = judge(f"{name} {redirect}", launch(argv, scratch, redirect), scratch, path, refs[name][1], None,
                         problems)
            if code != 0:
                problems.append(f"{name} {redirect}: exit {code} though its named output is a file")
            table.setdefault(f"{name} {redirect}", []).append(code)
    if disk:
        table.update(disk_full(root, refs, problems))
    return table


def disk_full(root, refs, problems):
    """The outputs on a 64 KiB tmpfs (not enough for any of them): exit 1, the old file kept."""
    mount = root / "small"
    mount.mkdir(exist_ok=True)
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)], capture_output=True)
    if p.returncode != 0:
        return {"disk full": ["skipped: cannot mount a tmpfs here"]}
    table = {}
    try:
        for name in ("solve", "export", "animate"):
            argv, path, _ = commands(mount)[name]
            prepare(mount, path)
            filler = mount / "filler"
            with contextlib.suppress(OSError), open(filler, "wb") as f:   # the rest of the space taken
                while True:
                    f.write(b"\0" * 4096)
                    f.flush()
            code = judge(f"{name} disk full", launch(argv, mount), mount, path, None, None, problems, keep=("filler",))
            if code != 1 or path.read_bytes() != OLD:
                problems.append(f"{name} disk full: exit {code}, old file {'kept' if path.read_bytes() == OLD else 'lost'}")
            filler.unlink()
            table[f"{name} disk full"] = [code]
    finally:
        subprocess.run(["umount", str(mount)], capture_output=True)
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=5000)
    ap.add_argument("--faults", type=int, default=48)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", help="write the figures here")
    a = ap.parse_args(argv)
    rng = random.Random(a.seed)
    problems = []
    start = time.monotonic()
    counts, slowest = fuzz(a.cases, rng, problems)
    fuzz_s = time.monotonic() - start
    print(f"fuzz: {a.cases} cases in {fuzz_s:.0f} s, exit codes {dict(sorted(counts.items(), key=str))}, "
          f"slowest {slowest:.1f} s", flush=True)
    table = {}
    if a.faults:   # --faults 0: the fuzz alone
        with tempfile.TemporaryDirectory() as tmp:
            table = faults(a.faults, rng, problems, Path(tmp))
    for label, codes in sorted(table.items()):
        print(f"  {label}: exits {codes}")
    for p in problems:
        print(f"PROBLEM {p}")
    print(f"{len(problems)} problems; {time.monotonic() - start:.0f} s in all")
    if a.json:
        Path(a.json).write_text(json.dumps({"fuzz": {"cases": a.cases, "exits": {str(k): v for k, v in counts.items()},
                                                     "slowest_s": slowest},
                                            "faults": {k: [str(c) for c in v] for k, v in table.items()},
                                            "problems": problems}, indent=1))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
