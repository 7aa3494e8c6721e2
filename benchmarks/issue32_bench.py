"""Issue 32's targets: ``kinem.sweep`` of the four-bar's coupler length over
201 values (tests/data/four_bar_named.toml, 251 instants; target < 1 s warm)
against a loop of 201 solves, and ``kinem.animate``'s 250-frame GIF
(target < 10 s).

    python benchmarks/issue32_bench.py [--repeats N] [--only sweep|animate]
"""
import argparse
import tempfile
from pathlib import Path

import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import ROOT, load, rounds, say, timed

import numpy as np

import kinem

FOUR_BAR = ROOT / "tests" / "data" / "four_bar_named.toml"
OUTPUTS = ("B.x", "B.y", "rocker.phi")


def sweep(repeats):
    lengths = np.linspace(0.28, 0.32, 201)

    def loop():
        for c in lengths:
            kinem.solve(kinem.compile(kinem.load(FOUR_BAR, parameters={"coupler": c})))

    res = rounds({"sweep": timed(lambda: kinem.sweep(FOUR_BAR, {"coupler": lengths}, outputs=OUTPUTS)),
                  "loop": timed(loop)}, repeats, warm=True)
    s = res["sweep"][2]
    assert s.success and s.data.shape == (201, 251, 3)
    say(f"sweep of 201 coupler lengths x 251 instants: {res['sweep'][0]:.3f} s warm (median of {repeats}; "
        f"target < 1 s); a loop of 201 load+compile+solve: {res['loop'][0]:.3f} s")


def animate(repeats):
    result = kinem.solve(kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml")))
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "four_bar.gif"
        res = rounds({"gif": timed(lambda: kinem.animate(result, out, frames=250, progress=False))}, repeats)
        say(f"kinem.animate of the four-bar to a 250-frame GIF: {res['gif'][0]:.2f} s (median of {repeats}; "
            f"target < 10 s), {out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    p = argparse.ArgumentParser()
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--only", choices=("sweep", "animate"))
    a = p.parse_args()
    say(f"load average {load()}")
    for name, fn in (("sweep", sweep), ("animate", animate)):
        if a.only in (None, name):
            fn(a.repeats)
