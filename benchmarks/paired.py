"""Two builds of kinem timed in one process, their calls alternating, for
deciding whether a change pays (docs/benchmarks.md, "Paired in one
process"). On a shared machine the same build's figure moves by up to a
factor of 2 from one process to the next; within one process, pairs of
calls of the two builds move together.

    python benchmarks/paired.py OTHER [--what march|cases|sensitivity|fixed] [--pairs N] [--cases A,B]

A is this tree's package, B is OTHER's (a checkout whose core is built,
for example by `python3 dev.py kinem --version` there; this tree itself
for an A/A run, which shows the spread). Each package is copied into a
temporary folder under its own name (kinem_a, kinem_b; its native.py made
to import its own core), so the two compiled cores load side by side;
nothing is written in either tree.

- march: a warm kinem.solve per instant on benchmarks/peers.py's cases over
  5,000 instants (march_time.py's), the calling thread's processor time;
  per pair B / A - 1.
- cases: a warm kinem.solve of cases/NAME.toml at its own instants and
  settings (--cases, default the six cases with rates whose chords run
  long: the cams' roller, the slots, the quick returns), batches of
  CASE_BATCH calls, the calling thread's processor time per call; per pair
  B / A - 1.
- sensitivity: kinem.sensitivity(model, [a moving link's dimension]) over
  kinem.solve(model), each build's own ratio (sensitivity_bench.py's cases
  and DIMENSION, its pattern: gc, an untimed call, the timed one; the
  process's processor time); per round B's ratio / A's - 1.
- fixed: a warm kinem.solve of 2 instants (benchmarks/common.fixed_cost's,
  issue 31's fixed cost) on peers.py's cases, batches of 200 calls, the
  calling thread's processor time per call; per pair B / A - 1.

Prints per case each build's median, the median of the pairs' changes
and their quartiles, and the load average. The two copies' code lies at
different addresses, which alone moves a figure by a few per cent: read a
change against an A/A run's."""
import argparse
import gc
import importlib
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

import peers  # noqa: E402

INSTANTS = 5000
CORE_IMPORT = "from kinem._core import"   # native.py's before it imported its own package's core


def copy_package(tree: Path, into: Path, name: str):
    """tree's kinem/ (its built core, not its sources under core/) as package ``name`` in ``into``."""
    source = tree / "kinem"
    if not any(source.glob("_core*.so")) and not any(source.glob("_core*.pyd")):
        sys.exit(f"paired.py: {source} has no built core (run `python3 dev.py kinem --version` there)")
    target = into / name
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("core", "__pycache__"))
    native = target / "native.py"
    native.write_text(native.read_text().replace(CORE_IMPORT, "from ._core import"))
    return importlib.import_module(name)


def quartiles(changes) -> str:
    q = statistics.quantiles(changes, n=4)
    return f"{100 * statistics.median(changes):+.2f} % (quartiles {100 * q[0]:+.1f} to {100 * q[2]:+.1f})"


def march(builds, pairs, cases):
    clock = time.thread_time_ns
    for name in cases or ("slider_crank", "four_bar", "jansen"):
        case = getattr(peers, name + "_case")()
        models = [k.compile(k.load_dict(case)) for k in builds]
        t = builds[0].solve(models[0]).trajectory.t
        times = np.linspace(t[0], t[0] + 10 * (t[-1] - t[0]), INSTANTS)
        for k, m in zip(builds, models):
            k.solve(m, times=times)   # warm
        ns = ([], [])
        for i in range(pairs):
            for j in ((0, 1) if i % 2 == 0 else (1, 0)):
                start = clock()
                builds[j].solve(models[j], times=times)
                ns[j].append(clock() - start)
        a, b = (1e-3 * statistics.median(v) / INSTANTS for v in ns)
        changes = [y / x - 1 for x, y in zip(*ns)]
        print(f"{name:13s} A {a:.4f} us, B {b:.4f} us per instant; B / A - 1: {quartiles(changes)}; "
              f"{pairs} pairs, load {os.getloadavg()[0]:.2f}", flush=True)


CASE_BATCH = 10
LONG_CHORDS = ("cam_roller_circle", "pin_in_slot", "pin_in_spline_slot", "quick_return_1", "quick_return_2",
               "quick_return_3")


def alternating(builds, models, pairs, batch):
    """Each build's warm solves of its model, ``batch`` calls at a time, the builds alternating (A first in even
    pairs, B first in odd ones), on the thread's processor time: (A's median us a call, B's, B / A - 1 a pair)."""
    clock, ns = time.thread_time_ns, ([], [])
    for i in range(pairs):
        for j in ((0, 1) if i % 2 == 0 else (1, 0)):
            solve, model = builds[j].solve, models[j]
            start = clock()
            for _ in range(batch):
                solve(model)
            ns[j].append((clock() - start) / batch)
    a, b = (1e-3 * statistics.median(v) for v in ns)
    return a, b, [y / x - 1 for x, y in zip(*ns)]


def case_files(builds, pairs, cases):
    root = HERE.parent
    for name in cases or LONG_CHORDS:
        models = [k.compile(k.load(str(root / "cases" / f"{name}.toml"))) for k in builds]
        for k, m in zip(builds, models):
            k.solve(m)   # warm
        a, b, changes = alternating(builds, models, pairs, CASE_BATCH)
        print(f"{name:18s} A {a:.1f} us, B {b:.1f} us a warm solve; B / A - 1: {quartiles(changes)}; "
              f"{pairs} pairs of {CASE_BATCH} calls, load {os.getloadavg()[0]:.2f}", flush=True)


def fixed(builds, pairs, cases):
    batch = 200
    for name in cases or ("slider_crank", "four_bar", "jansen"):
        case = getattr(peers, name + "_case")()
        models = []
        for k in builds:
            c = k.load_dict(case)
            models.append(k.compile(c.with_time(end=c.end / c.steps, steps=1)))   # 2 instants (common.fixed_cost's)
            k.solve(models[-1])   # warm
        a, b, changes = alternating(builds, models, pairs, batch)
        print(f"{name:13s} A {a:.2f} us, B {b:.2f} us a warm solve of 2 instants; B / A - 1: {quartiles(changes)}; "
              f"{pairs} pairs of {batch} calls, load {os.getloadavg()[0]:.2f}", flush=True)


def sensitivity(builds, pairs, cases):
    from sensitivity_bench import DIMENSION

    clock = time.process_time_ns   # the core may run on the pool's threads
    root = HERE.parent
    calls = [importlib.import_module(k.__name__ + ".sensitivity").sensitivity for k in builds]
    for name in cases or tuple(DIMENSION):
        path = DIMENSION[name]
        models = [k.compile(k.load(str(root / "cases" / f"{name}.toml"))) for k in builds]
        ns = {(j, w): [] for j in (0, 1) for w in ("solve", "sensitivity")}
        for i in range(pairs):
            for j in ((0, 1) if i % 2 == 0 else (1, 0)):
                for what, fn in (("solve", lambda: builds[j].solve(models[j])),
                                 ("sensitivity", lambda: calls[j](models[j], [path]))):
                    gc.collect()
                    fn()
                    start = clock()
                    fn()
                    ns[j, what].append(clock() - start)
        ratios = [[s / v for s, v in zip(ns[j, "sensitivity"], ns[j, "solve"])] for j in (0, 1)]
        a, b = (statistics.median(r) for r in ratios)
        changes = [y / x - 1 for x, y in zip(*ratios)]
        print(f"{name:15s} {path}: sensitivity / solve A {a:.3f}, B {b:.3f}; B / A - 1: {quartiles(changes)}; "
              f"solve A {1e-3 * statistics.median(ns[0, 'solve']):.0f} us, B "
              f"{1e-3 * statistics.median(ns[1, 'solve']):.0f} us; {pairs} rounds, load {os.getloadavg()[0]:.2f}",
              flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("other", type=Path, help="the other tree (B), built; this tree for an A/A run")
    p.add_argument("--what", choices=("march", "cases", "sensitivity", "fixed"), default="march")
    p.add_argument("--pairs", type=int, default=100)
    p.add_argument("--cases", default="", help="comma-separated (default: every case of --what)")
    a = p.parse_args()
    cases = tuple(c for c in a.cases.split(",") if c)
    with tempfile.TemporaryDirectory(prefix="kinem-paired-") as scratch:
        sys.path.insert(0, scratch)
        builds = [copy_package(HERE.parent, Path(scratch), "kinem_a"),
                  copy_package(a.other.resolve(), Path(scratch), "kinem_b")]
        print(f"A {HERE.parent}, B {a.other.resolve()}", flush=True)
        {"march": march, "cases": case_files, "sensitivity": sensitivity, "fixed": fixed}[a.what](builds, max(2, a.pairs), cases)


if __name__ == "__main__":
    main()
