"""Issue 30: the cost of exact design sensitivities (kinem.sensitivity)
against the plain solve: every listed parameter's d/dp of positions,
velocities and accelerations at every output instant should cost at most
(1 + 0.5 P) plain solves (P parameters). Prints medians of round-robin runs;
then the four-bar's tolerance bands (kinem.tolerance, its [tolerances]):
N Monte Carlo samples over its 251 instants, median of min(REPEATS, 3) runs
(the target: 10,000 in 5 s).

    python benchmarks/sensitivity_bench.py [REPEATS [SAMPLES]]
"""
import sys

from common import load, rounds, say, timed

import kinem
from kinem.parameters import parameters
from kinem.sensitivity import sensitivity
from kinem.tolerance import tolerance

CASES = ("slider_crank", "four_bar", "quick_return_1", "cam_table41")


def main(repeats=7, samples=2000):
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
    model = kinem.compile(kinem.load("cases/four_bar.toml"))
    runs = min(repeats, 3)
    seconds, every, b = rounds({"tolerance": timed(lambda: tolerance(model, samples=samples, outputs=["B.x", "B.y"]))},
                               runs, warm=False)["tolerance"]
    say(f"four_bar tolerance: {samples} samples in {seconds:.2f} s, median of {runs} "
        f"({', '.join(f'{s:.2f}' for s in every)}; {1e3 * seconds / samples:.2f} ms a sample; "
        f"10,000 would take about {1e4 * seconds / samples:.1f} s; target 5 s), {len(b.rejected)} rejected; "
        f"load {load()}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7, int(sys.argv[2]) if len(sys.argv) > 2 else 2000)
