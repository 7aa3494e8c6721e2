"""Section 7 (cold start) of benchmarks/run.py; it runs the probe
benchmarks/coldstart.py in subprocesses."""
import atexit
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import ROOT, say

# The full run's CSV goes to a scratch file, never to os.devnull: run as root, an atomic
# writer would rename its temporary file over the device.
SCRATCH = tempfile.mkdtemp(prefix="kinem-bench-")
atexit.register(shutil.rmtree, SCRATCH, True)
SINK = os.path.join(SCRATCH, "full.csv")


# -- 7 cold start ---------------------------------------------------------------------------------

def environments():
    """Subprocess environments: as given, and with a bytecode cache. With
    PYTHONDONTWRITEBYTECODE set (as in some CI images) every kinem module is
    compiled from source at each start; the cached variant writes .pyc files
    under a temporary PYTHONPYCACHEPREFIX (never into the repository)."""
    import atexit
    import shutil
    import tempfile

    given = dict(os.environ)
    cached = dict(os.environ)
    cached.pop("PYTHONDONTWRITEBYTECODE", None)
    cached["PYTHONPYCACHEPREFIX"] = tempfile.mkdtemp(prefix="kinem-bench-pyc-")
    atexit.register(shutil.rmtree, cached["PYTHONPYCACHEPREFIX"], True)
    return {"as given": given, "bytecode cached": cached}


def section_coldstart(cfg, envs):
    say("\n== 7. cold start: python -m kinem solve cases/slider_crank.toml --steps 1 --outputs positions ==")
    case = str(ROOT / "cases" / "slider_crank.toml")
    cmds = {"cli": [sys.executable, "-m", "kinem", "solve", case, "--steps", "1", "--outputs", "positions"],
            "pass": [sys.executable, "-c", "pass"],
            "probe": [sys.executable, str(ROOT / "benchmarks" / "coldstart.py"), case],
            "full": [sys.executable, "-m", "kinem", "solve", case, "--out", SINK, "--format", "csv"]}
    n = cfg.subprocess_repeats
    dont = os.environ.get("PYTHONDONTWRITEBYTECODE")
    say(f"   PYTHONDONTWRITEBYTECODE={dont!r} here; 'bytecode cached': .pyc files in a temporary "
        "PYTHONPYCACHEPREFIX, written by one unmeasured run")
    for env in envs.values():
        subprocess.run(cmds["probe"], cwd=ROOT, env=env, capture_output=True, check=True)
    walls = {(e, k): [] for e in envs for k in cmds}
    marks = {e: [] for e in envs}
    for _ in range(n):  # round-robin: load changes hit every command alike
        for e, env in envs.items():
            for k, cmd in cmds.items():
                t = time.perf_counter()
                p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, check=True)
                walls[(e, k)].append(time.perf_counter() - t)
                if k == "probe":
                    marks[e].append(json.loads(p.stdout.strip().splitlines()[-1])["marks"])
    out = {"repeats": n, "PYTHONDONTWRITEBYTECODE": dont}
    names = ["interpreter start-up (python -c pass)"] + list(marks[next(iter(envs))][0])
    table = {}
    for e in envs:
        total = statistics.median(walls[(e, "cli")])
        split = {names[0]: statistics.median(walls[(e, "pass")])}
        split.update({k: statistics.median(m[k] for m in marks[e]) for k in names[1:]})
        rest = total - sum(split.values())
        table[e] = (total, split, rest)
        out[e] = {"total_s": total, "probe_s": statistics.median(walls[(e, "probe")]), "split_s": split,
                  "rest_s": rest, "largest": max(split, key=split.get),
                  "full_run_s": statistics.median(walls[(e, "full")])}
    say(f"   {'(medians of ' + str(n) + ' runs)':48s} " + " ".join(f"{e:>18s}" for e in envs))
    say(f"   {'total: kinem solve ... wall time':48s} " + " ".join(f"{1e3 * table[e][0]:15.0f} ms" for e in envs))
    for k in names:
        say(f"   {k:48s} " + " ".join(f"{1e3 * table[e][1][k]:8.1f} ms {100 * table[e][1][k] / table[e][0]:5.1f}%"
                                      for e in envs))
    say(f"   {'rest (argparse, runpy, interpreter exit, noise)':48s} "
        + " ".join(f"{1e3 * table[e][2]:8.1f} ms {100 * table[e][2] / table[e][0]:5.1f}%" for e in envs))
    for e in envs:
        say(f"   largest ({e}): {out[e]['largest']}")
    say(f"   {'full default run (compiled march: loads numba)':48s} "
        + " ".join(f"{1e3 * out[e]['full_run_s']:15.0f} ms" for e in envs))
    say(f"   {'  its ratio to the --steps 1 run':48s} "
        + " ".join(f"{out[e]['full_run_s'] / out[e]['total_s']:17.2f}x" for e in envs))
    return out
