"""The rate_step each engine can afford (issue 24 item 2): per mechanism,
rate x dt at which the first of the engine's figures reaches its limit,
extrapolated from its run at dt, each figure by its own order in the step
(the adapter's ``order``: errors ~ (rate dt)^order; MuJoCo's velocities are
first order, its positions second). The smallest over
the book's cases and generated mechanisms, with a margin, is the default.

    python benchmarks/rate_step_bench.py [ENGINES] [SEEDS]
"""
import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import kinem  # noqa: E402
from adapters import case_settings, get  # noqa: E402
from adapters.base import rate_scale  # noqa: E402
from adapters.compare import compare, tolerance_of  # noqa: E402
from benchmarks.generated import KINDS, generated  # noqa: E402

BOOK = ("slider_crank", "four_bar", "quick_return_1", "quick_return_2", "quick_return_3", "gear_pair", "planetary",
        "rack_pinion", "rolling_pinion")


def mechanisms(seeds):
    for name in BOOK:
        yield name, kinem.load(ROOT / "cases" / f"{name}.toml")
    for kind in KINDS:
        for seed in range(seeds):
            yield f"{kind}-{seed}", kinem.load_dict(generated(kind, seed))


def main(engines, seeds, dt):
    for name, case in mechanisms(seeds):
        model = kinem.compile(case)
        ref = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(case), tolerance=1e-13))
        rate = rate_scale(model, ref.trajectory)
        for e in engines:
            a = get(e)
            if a.unsupported(model):
                continue
            s = case_settings(model, e, {"dt": dt, "substeps": None})
            run = a.run(model, settings=s)
            c = compare(model, ref, run, tolerance_of(a))
            if not c.ok:
                print(f"{name:16s} {e:7s} {c.label}")
                continue
            orders = a.order if isinstance(a.order, dict) else dict.fromkeys(c.tolerance, a.order or 2)
            used = run.settings["dt"]
            # each figure's affordable step, by its own order; a figure without one (not refined on) as second order
            steps = [(rate * used / max(getattr(c, k) / v, 1e-30) ** (1.0 / (orders.get(k) or 2)), getattr(c, k) / v, k)
                     for k, v in c.tolerance.items()]
            afford, ratio, figure = min(steps)
            print(f"{name:16s} {e:7s} rate {rate:7.3g} dt {used:.3g} rate*dt {rate * used:.3g} limiting {figure} at "
                  f"{ratio:.3g} of its limit: affordable rate_step {afford:.3g}", flush=True)


if __name__ == "__main__":
    main(tuple(sys.argv[1].split(",")) if len(sys.argv) > 1 else ("pymunk", "exudyn"),
         int(sys.argv[2]) if len(sys.argv) > 2 else 3, float(sys.argv[3]) if len(sys.argv) > 3 else 2e-4)
