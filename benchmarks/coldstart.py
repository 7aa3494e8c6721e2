"""Cold-start probe for benchmarks/run.py: the steps of
``kinem solve CASE --steps 1 --outputs positions`` in a fresh interpreter,
each timed, printed as one JSON line. The interpreter's own start-up (before
this file's first line) is not visible from here: run.py measures it as the
wall time of ``python -c pass``.

    python benchmarks/coldstart.py cases/slider_crank.toml
"""
import time

T0 = time.perf_counter()

import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402


def main(path):
    marks = {}
    t = T0
    import kinem.cli  # noqa: F401  (what `python -m kinem` imports: the package, numpy, the registry)
    from kinem.solver import solve
    from kinem.case import check_time, load
    from kinem.model import compile
    from kinem.output import csv_text
    marks["import kinem (+numpy)"], t = time.perf_counter() - t, time.perf_counter()
    case = check_time(load(path).with_time(None, 1))
    marks["load case (TOML, validate)"], t = time.perf_counter() - t, time.perf_counter()
    model = compile(case)
    marks["compile"], t = time.perf_counter() - t, time.perf_counter()
    already = "scipy.linalg" in sys.modules
    import scipy.linalg  # noqa: F401  (kinem.linalg imports it lazily at the first factorisation)
    marks["import scipy.linalg (lazy, first factorisation)"], t = time.perf_counter() - t, time.perf_counter()
    r = solve(model, ("positions",))
    marks["solve (2 instants)"], t = time.perf_counter() - t, time.perf_counter()
    text = csv_text(r.trajectory)
    with open(os.devnull, "w") as f:
        f.write(text)
    marks["write CSV"], t = time.perf_counter() - t, time.perf_counter()
    print(json.dumps({"marks": marks, "scipy_linalg_preloaded": already, "success": bool(r.success)}))


if __name__ == "__main__":
    main(sys.argv[1])
