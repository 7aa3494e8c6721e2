"""Verdicts on generated mechanisms at 0.25x, 1x and 4x speed and 1000x size
(issue 24): each engine at its defaults, the figures against its tolerance.

    python benchmarks/verdict_bench.py [SEEDS] [ENGINES]
"""
import sys

sys.path.insert(0, __file__.rsplit("/", 2)[0])
import kinem  # noqa: E402
from adapters.compare import run_engine  # noqa: E402
from benchmarks.generated import KINDS, generated  # noqa: E402
from kinem.report.runs import REFERENCE_TOLERANCE  # noqa: E402


def main(seeds=2, engines=("pymunk", "mujoco", "exudyn")):
    import dataclasses

    for kind in KINDS:
        for seed in range(seeds):
            for f, k in ((0.25, 1), (1, 1), (4, 1), (1, 1000)):
                case = kinem.load_dict(generated(kind, seed, f, k))
                model = kinem.compile(case)
                ref = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(case),
                                                                     tolerance=REFERENCE_TOLERANCE))
                for e in engines:
                    c = run_engine(model, ref, e)
                    bad = "; ".join(f"{m} {v:.1e}>{lim:.0e}" for m, v, lim in c.exceeded) if c.ok else c.label
                    print(f"{kind:13s} {seed} f={f:<5g} k={k:<5g} {e:7s} pos {c.position_error_rel:.1e} "
                          f"ang {c.angle_error:.1e} vel {c.velocity_error_rel:.1e} "
                          f"omg {c.angular_velocity_error_rel:.1e} steps/int {c.substeps:4d} "
                          f"us/int {1e6 * c.time_per_interval:7.1f}  {'ok' if c.within_tolerance else 'OUT'} {bad}",
                          flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2,
         tuple(sys.argv[2].split(",")) if len(sys.argv) > 2 else ("pymunk", "mujoco", "exudyn"))
