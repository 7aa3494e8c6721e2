"""The workload of the march's instruction counts (docs/benchmarks.md,
issue 31): one warm-up solve of a case, then 20 more, all instants with
rates. CASE is a case file or one of the peers' mechanisms
(benchmarks/peers.py: slider-crank, four-bar, jansen; 500 instants).
Count the compiled march's instructions with

    valgrind --tool=callgrind --toggle-collect='_core::march::run*' \\
        --callgrind-out-file=/tmp/callgrind.out.%p \\
        .venv/bin/python benchmarks/march_instructions.py [CASE]
    callgrind_annotate /tmp/callgrind.out.PID | head -40

(the counts written to /tmp, not the tree; add --inclusive=yes for each
function's share with its callees) and
divide the total by 21 times the case's instants (printed last, with the
Newton iterations, factorisations and Jacobian evaluations of one
solve)."""
import sys
from pathlib import Path

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports

import kinem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PEERS = ("slider-crank", "four-bar", "jansen")


def load(case):
    if str(case) in PEERS:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        import peers
        return kinem.load_dict(getattr(peers, str(case).replace("-", "_") + "_case")())
    return kinem.load(case)


def main(case=ROOT / "cases" / "slider_crank.toml", solves=21):
    model = kinem.compile(load(case))
    for _ in range(solves):
        r = kinem.solve(model)
    print(f"{Path(str(case)).stem}: {solves} solves of {len(r.q)} instants; success {r.success}, "
          f"{int(r.iterations.sum())} Newton iterations, {r.factorizations} factorisations, "
          f"{r.jacobian_evaluations} Jacobian evaluations per solve")


if __name__ == "__main__":
    main(*sys.argv[1:2])
