"""Issue 30: the cost of exact design sensitivities (kinem.sensitivity)
against the plain solve: every listed parameter's d/dp of positions,
velocities and accelerations at every output instant should cost at most
(1 + 0.5 P) plain solves (P parameters). Prints medians of round-robin runs.

    python benchmarks/sensitivity_bench.py [REPEATS]
"""
import sys

from common import load, rounds, say, timed

import kinem
from kinem.parameters import parameters
from kinem.sensitivity import sensitivity

CASES = ("slider_crank", "four_bar", "quick_return_1", "cam_table41")


def main(repeats=7):
    say(f"load {load()}; median of {repeats} (seconds); bound: (1 + 0.5 P) x the solve")
    for name in CASES:
        model = kinem.compile(kinem.load(f"cases/{name}.toml"))
        every = [p.path for p in parameters(model.case)]
        for count in (1, 4, len(every)):
            paths = every[:count]
            r = rounds({"solve": timed(lambda: kinem.solve(model)),
                        "sensitivity": timed(lambda: sensitivity(model, paths))}, repeats, warm=True)
            solve, sens = r["solve"][0], r["sensitivity"][0]
            ratio = sens / solve
            bound = 1 + 0.5 * count
            say(f"{name:16s} P={count:3d}  solve {solve * 1e3:8.2f} ms  sensitivity {sens * 1e3:8.2f} ms  "
                f"ratio {ratio:6.2f}  bound {bound:6.1f}  {'ok' if ratio <= bound else 'OVER'}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
