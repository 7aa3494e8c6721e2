"""The workload of the march's instruction counts (docs/benchmarks.md,
issue 31): one warm-up solve of a case, then 20 more, all instants with
rates. Count the compiled march's instructions with

    valgrind --tool=callgrind --toggle-collect='_core::march::run*' \\
        .venv/bin/python benchmarks/march_instructions.py [cases/slider_crank.toml]
    callgrind_annotate callgrind.out.PID | head -40

and divide the total by 21 times the case's instants (printed last, with
the Newton iterations, factorisations and Jacobian evaluations of one
solve)."""
import sys
from pathlib import Path

import kinem

ROOT = Path(__file__).resolve().parents[1]


def main(case=ROOT / "cases" / "slider_crank.toml", solves=21):
    model = kinem.compile(kinem.load(case))
    for _ in range(solves):
        r = kinem.solve(model)
    print(f"{Path(case).stem}: {solves} solves of {len(r.q)} instants; success {r.success}, "
          f"{int(r.iterations.sum())} Newton iterations, {r.factorizations} factorisations, "
          f"{r.jacobian_evaluations} Jacobian evaluations per solve")


if __name__ == "__main__":
    main(*sys.argv[1:2])
