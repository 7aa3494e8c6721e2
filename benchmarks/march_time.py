"""The march's time per instant, for a paired comparison of two builds
(docs/benchmarks.md "Rounds 15 and 17 in time"). Instruction counts
(march_instructions.py) stopped predicting time in round 15: a change is
kept when this figure falls too. Run it alternately from each tree, a few
rounds, in one session:

    for i in 1 2 3; do for d in TREE_A TREE_B; do
        (cd $d && .venv/bin/python benchmarks/march_time.py); done; done

Per case (benchmarks/peers.py: slider-crank, four-bar, Jansen leg): warm
kinem.solve over 5,000 instants spanning ten times the case's own output
interval (the fixed cost of a call under 1 % of it), the median of 25
solves, in microseconds per instant; and the load average."""
import os
import statistics
import sys
import time
from pathlib import Path

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import kinem  # noqa: E402
import peers  # noqa: E402

INSTANTS, SOLVES = 5000, 25


def per_instant(case) -> float:
    model = kinem.compile(kinem.load_dict(case))
    t = kinem.solve(model).trajectory.t
    times = np.linspace(t[0], t[0] + 10 * (t[-1] - t[0]), INSTANTS)
    kinem.solve(model, times=times)   # warm
    seconds = []
    for _ in range(SOLVES):
        start = time.perf_counter()
        kinem.solve(model, times=times)
        seconds.append(time.perf_counter() - start)
    return 1e6 * statistics.median(seconds) / INSTANTS


def main():
    figures = [f"{name} {per_instant(getattr(peers, name + '_case')()):.4f}"
               for name in ("slider_crank", "four_bar", "jansen")]
    print(f"{Path.cwd().name}: us per instant: {' | '.join(figures)}; load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
