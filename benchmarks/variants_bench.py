"""Issue 31 item 5: many variants of one mechanism solved together
(kinem.solve(model, parameters=...), kinem.variants). Targets: 1,000
variants of the slider-crank at <= 0.5 us per variant-step on 2 cores, and
10,000 four-bar variants over its 250 steps in under 2 s. Prints the load
average, the medians of REPEATS runs (round-robin, each warm), the
per-variant-step cost, the processor time per variant-step (what 2 idle
cores would take: a shared machine's wall clock is not), the same work with
the variants marched one by one instead of 8 at a time as lanes (the same
figures: checked), and once through the merged path (kinem.batch: merged
cases, 128 variants a case) for comparison.

    python benchmarks/variants_bench.py [REPEATS]
"""
import resource
import statistics
import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import load, rounds, say, timed

import numpy as np

import kinem
from kinem.parameters import resolve
from kinem.result import OUTPUTS
from kinem.variants import _asked, _merged, solve_variants

# (case, variants, {path: +- spread}, outputs, target seconds per variant-step or None, target seconds or None)
WORK = (
    ("slider_crank", 1000, {"constraints.B.si.0": 5.0, "constraints.T.qi.1": 2.0}, ["B.x", "B.y", "slider.x"],
     0.5e-6, None),
    ("slider_crank", 1000, {"constraints.B.si.0": 5.0, "constraints.T.qi.1": 2.0}, list(OUTPUTS), 0.5e-6, None),
    ("four_bar", 10_000, {"points.B.at.0": 1e-4, "constraints.A.sj.0": 1e-4}, ["B.x", "B.y"], None, 2.0),
)


def processor() -> float:
    """This process's processor seconds (every thread, user and system)."""
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def charged(fn, into):
    """fn, appending each call's processor seconds to ``into``."""
    def run():
        start = processor()
        out = fn()
        into.append(processor() - start)
        return out
    return run


def designs(model, spread, count, seed=0):
    rng = np.random.default_rng(seed)
    listed = resolve(model.case, list(spread))
    return {p.path: p.value + rng.uniform(-1, 1, count) * spread[p.path] for p in listed}


def main(repeats=3):
    say(f"load {load()}; {kinem.native.THREADS} threads; median of {repeats} (seconds)")
    for name, count, spread, outputs, per_step, whole in WORK:
        model = kinem.compile(kinem.load(f"cases/{name}.toml"))
        values = designs(model, spread, count)
        steps = count * len(model.times)
        cpu = {"lanes": [], "one by one": []}
        lanes = lambda: kinem.solve(model, outputs=outputs, parameters=values)
        alone = lambda: solve_variants(model, values, outputs=outputs, lanes=False)
        r = rounds({"lanes": timed(charged(lanes, cpu["lanes"])),
                    "one by one": timed(charged(alone, cpu["one by one"]))}, repeats, warm=True)
        seconds, every, v = r["lanes"]
        assert v.success.all(), [m for m in v.messages if m][:3]
        assert np.array_equal(r["one by one"][2].data, v.data, equal_nan=True), "lanes and one by one differ"
        verdict = []
        if per_step is not None:
            verdict.append(f"target <= {per_step * 1e6:.2f} us: {'ok' if seconds / steps <= per_step else 'OVER'}")
        if whole is not None:
            verdict.append(f"target < {whole:g} s: {'ok' if seconds < whole else 'OVER'}")
        shown = ",".join(outputs) if len(outputs) < 4 else "all stages"
        say(f"{name:13s} {count:6d} variants x {len(model.times)} instants ({shown}), load {load()}:")
        for mode in ("lanes", "one by one"):
            seconds, every, _ = r[mode]
            c = statistics.median(cpu[mode])
            say(f"{'':13s} {mode:10s} {seconds:7.3f} s ({', '.join(f'{s:.3f}' for s in every)}), "
                f"{seconds / steps * 1e6:.3f} us per variant-step{'; ' + '; '.join(verdict) if mode == 'lanes' else ''}; "
                f"processor {c:.3f} s: {c / steps * 1e6:.3f} us per variant-step on one core, "
                f"{c / kinem.native.THREADS / steps * 1e6:.3f} us on {kinem.native.THREADS} idle cores")
        say(f"{'':13s} lanes x{r['one by one'][0] / r['lanes'][0]:.2f} wall, "
            f"x{statistics.median(cpu['one by one']) / statistics.median(cpu['lanes']):.2f} processor; the same data")
        # the same work through the merged path, once
        listed = resolve(model.case, list(values))
        columns, _ = _asked(model, outputs)
        q0 = kinem.solve(model, times=model.times[:1]).q[0]
        grid = np.column_stack(list(values.values()))
        seconds, m = timed(lambda: _merged(model, listed, grid, columns, model.times, q0, model.options))()
        gap = np.nanmax(np.abs(m.data - v.data)) if m.success.all() else float("nan")
        say(f"{'':13s} merged path (kinem.batch): {seconds:7.3f} s, {seconds / steps * 1e6:.3f} us per "
            f"variant-step; largest difference from the variants' {gap:.2e}; load {load()}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
