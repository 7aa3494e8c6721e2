"""Issue 24 item 2's target: each engine's chosen setting (dt = "auto",
refined by its self-check) against the cheapest step within its tolerance
(judged against native), on generated mechanisms not in cases/. Cost in
engine steps per output interval (wall time is proportional to it for one
mechanism and engine; it is too noisy on a shared machine to compare
settings by); 'all attempts' counts the first attempts of a refined run.

    python benchmarks/chosen_vs_cheapest.py [SEEDS] [ENGINES]
"""
import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import kinem  # noqa: E402
from adapters import case_settings, get  # noqa: E402
from adapters.compare import compare, tolerance_of  # noqa: E402
from benchmarks.generated import KINDS, generated  # noqa: E402


def within(a, model, ref, engine, n):
    run = a.run(model, settings=case_settings(model, engine, {"substeps": n, "dt": "auto"}))
    return bool(compare(model, ref, run, tolerance_of(a)).within_tolerance)


def cheapest(a, model, ref, engine, hi):
    """The fewest steps per interval within tolerance (errors fall with n)."""
    lo = 1
    while not within(a, model, ref, engine, hi):
        lo, hi = hi, hi * 2
    while lo < hi:
        mid = (lo + hi) // 2
        if within(a, model, ref, engine, mid):
            hi = mid
        else:
            lo = mid + 1
    return hi


def main(seeds, engines):
    ratios = {e: [] for e in engines}
    for kind in KINDS:
        for seed in range(seeds):
            case = kinem.load_dict(generated(kind, 100 + seed))
            model = kinem.compile(case)
            ref = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(case), tolerance=1e-13))
            for e in engines:
                a = get(e)
                run = a.run(model, settings=case_settings(model, e))
                c = compare(model, ref, run, tolerance_of(a))
                best = cheapest(a, model, ref, e, max(run.substeps, 1))
                total = run.steps / (len(model.times) - 1)
                ratios[e].append(run.substeps / best)
                print(f"{kind:13s} {100 + seed} {e:7s} chosen {run.substeps:4d} steps/interval "
                      f"({c.verdict.value}); cheapest within tolerance {best:4d}; chosen/cheapest "
                      f"{run.substeps / best:.2f}; all attempts/cheapest {total / best:.2f}", flush=True)
    for e, r in ratios.items():
        print(f"{e}: chosen/cheapest median {sorted(r)[len(r) // 2]:.2f}, max {max(r):.2f} over {len(r)}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2,
         tuple(sys.argv[2].split(",")) if len(sys.argv) > 2 else ("pymunk", "mujoco", "exudyn"))
