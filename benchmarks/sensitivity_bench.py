"""Issue 30: the cost of exact design sensitivities (kinem.sensitivity)
against the plain solve: every listed parameter's d/dp of positions,
velocities and accelerations at every output instant should cost at most
(1 + 0.5 P) plain solves (P parameters). P = 1 is run for the case's
first parameter and for a moving link's dimension (DIMENSION).
Round-robin runs (solve, sensitivity, the core's part alone), each warm
(right after an untimed call of the same); medians of the process's CPU time (the machine is shared:
CPU time is what the call itself spends, the same measure on both sides)
and of wall time; and the same ratio for first calls, each on a model
just compiled (nothing kept by the model from an earlier call). Per case: the core's part (Plan.sensitivity with
kinem.sensitivity.core_inputs) per instant and parameter against the plain
solve per instant (the core's part with its own factorisation at every
instant: kinem.sensitivity uses the march's, Plan.march_sensitivity), and
the tables' tangents built in Python (kinem.sensitivity.tangent_inputs),
and the Python part of a call: its CPU time less the core's fused pass in
it (Plan.march_sensitivity, timed inside the call: ``Split``). Then the four-bar's tolerance bands (kinem.tolerance,
its [tolerances]): N Monte Carlo samples over its 251 instants, median of
min(REPEATS, 3) runs (the target: 10,000 in 5 s).

    python benchmarks/sensitivity_bench.py [REPEATS [SAMPLES]]
"""
import gc
import statistics
import sys
import time

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import load, rounds, say, timed

import kinem
from kinem.parameters import parameters, resolve
from kinem.sensitivity import core_inputs, sensitivity, tangent_inputs
from kinem.tolerance import tolerance

CASES = ("slider_crank", "four_bar", "quick_return_1", "cam_table41")
# P = 1 is measured twice: the case's first parameter (a ground's value or
# pivot on three of the four, whose tangents are partly exact zeros) and a
# moving link's dimension (a crank's pin, the cam outline's coefficient),
# which a designer would ask about first; the bound holds for both.
DIMENSION = {"slider_crank": "constraints.B.si.0", "four_bar": "points.A.at.0",
             "quick_return_1": "points.A.at.0", "cam_table41": "constraints.contact.outline.spline.s.3"}


class Split:
    """A model's Plan with its fused pass (march_sensitivity) timed: ``core``
    accumulates the CPU seconds spent in it."""

    def __init__(self, plan):
        self.plan, self.core = plan, 0.0

    def __getattr__(self, name):
        return getattr(self.plan, name)

    def march_sensitivity(self, *args):
        c = time.process_time()
        try:
            return self.plan.march_sensitivity(*args)
        finally:
            self.core += time.process_time() - c


def python_part(name, paths):
    """() -> the CPU seconds of one kinem.sensitivity call outside the core's
    fused pass, on its own compiled model (its plan a ``Split``)."""
    model = kinem.compile(kinem.load(f"cases/{name}.toml"))
    split = model.__dict__["plan"] = Split(model.plan)   # the cached Plan, wrapped

    def run():
        split.core = 0.0
        c = time.process_time()
        sensitivity(model, paths)
        return time.process_time() - c - split.core
    return run


def medians(fns: dict, repeats: int) -> dict:
    """name -> (median CPU seconds, median wall seconds), round-robin, each
    timed call right after an untimed one of the same callable (a callable
    that returns a number: that is its CPU seconds)."""
    cpu, wall = {k: [] for k in fns}, {k: [] for k in fns}
    for _ in range(max(1, repeats)):
        for k, fn in fns.items():
            gc.collect()
            fn()
            c, w = time.process_time(), time.perf_counter()
            own = fn()
            cpu[k].append(own if isinstance(own, float) else time.process_time() - c)
            wall[k].append(time.perf_counter() - w)
    return {k: (statistics.median(cpu[k]), statistics.median(wall[k])) for k in fns}


def first_calls(name, paths, repeats: int) -> tuple:
    """(median CPU seconds of a first solve, of a first sensitivity call):
    each on a model just compiled (its compile untimed), so nothing the
    model keeps for later calls (its plan, columns' layout, the parameters'
    tangents and names) is there yet."""
    case = kinem.load(f"cases/{name}.toml")
    out = {"solve": [], "sensitivity": []}
    for _ in range(max(1, repeats)):
        for k, call in (("solve", kinem.solve), ("sensitivity", lambda m: sensitivity(m, paths))):
            model = kinem.compile(case)
            gc.collect()
            c = time.process_time()
            call(model)
            out[k].append(time.process_time() - c)
    return statistics.median(out["solve"]), statistics.median(out["sensitivity"])


def main(repeats=7, samples=2000):
    say(f"load {load()}; medians of {repeats}, CPU time (wall time); bound: (1 + 0.5 P) x the solve")
    for name in CASES:
        model = kinem.compile(kinem.load(f"cases/{name}.toml"))
        every = [p.path for p in parameters(model.case)]
        result = kinem.solve(model)
        instants = len(result.trajectory.t)
        ones = [every[:1]] + ([[DIMENSION[name]]] if DIMENSION[name] != every[0] else [])
        for paths in (*ones, every[:4], every):
            count = len(paths)
            listed = resolve(model.case, paths)
            args = core_inputs(model, listed, result)
            r = medians({"solve": lambda: kinem.solve(model), "sensitivity": lambda: sensitivity(model, paths),
                         "core": lambda: model.plan.sensitivity(*args),
                         "tangents": lambda: tangent_inputs(model, listed),
                         "python": python_part(name, paths)}, repeats)
            (solve, solve_wall), (sens, sens_wall), (core, _) = r["solve"], r["sensitivity"], r["core"]
            tangents, python = r["tangents"][0], r["python"][0]
            ratio, bound = sens / solve, 1 + 0.5 * count
            first_solve, first_sens = first_calls(name, paths, repeats)
            say(f"{name:15s} P={count:3d} ({paths[0] if count == 1 else 'the first ' + str(count)})  solve {solve * 1e3:6.2f} ms ({solve_wall * 1e3:6.2f})  "
                f"sensitivity {sens * 1e3:7.2f} ms ({sens_wall * 1e3:7.2f})  ratio {ratio:6.2f} "
                f"({sens_wall / solve_wall:6.2f})  bound {bound:5.1f}  {'ok' if ratio <= bound else 'OVER'}  "
                f"core {core * 1e3:6.2f} ms: {1e6 * core / (instants * count):5.2f} us per instant and parameter, "
                f"the solve {1e6 * solve / instants:5.2f} us per instant ({instants} instants); "
                f"tangents (Python) {tangents * 1e3:5.2f} ms; "
                f"Python part of a call {python * 1e3:5.2f} ms ({python / solve:4.2f} solves); "
                f"first calls on a fresh model: solve {first_solve * 1e3:6.2f} ms, sensitivity "
                f"{first_sens * 1e3:7.2f} ms, ratio {first_sens / first_solve:6.2f} "
                f"{'ok' if first_sens <= bound * first_solve else 'OVER'}")
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
