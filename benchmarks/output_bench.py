"""CSV output cost per row (issue 17, item 4): kinem's formatter against the
alternatives, on the slider-crank's 48-column trajectory, beside the analysis
cost per instant measured in the same run.

    python benchmarks/output_bench.py [--steps N] [--repeats R]

Contenders (each writes every double so that it reads back exactly):
  orjson       kinem.output.csv_rows: orjson formats the whole array in
               compiled code (shortest round-trip form), rows split by a
               bytes replace
  savetxt      numpy.savetxt with %.17g (kinem before issue 17)
  %-format     one '%.17g,...' format string applied to the flattened rows
  repr-join    ','.join(map(repr, row)) per row (shortest form, in Python)
Figures are medians of R runs taken round-robin; the ratio to the analysis
(kinem.solve per output instant, default outputs) is what a CLI user pays
for output on top of the solve.
"""
import argparse
import io
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import kinem  # noqa: E402
from kinem.output import csv_rows  # noqa: E402


def contenders(t, data):
    block = np.column_stack([t, data])

    def savetxt():
        buf = io.StringIO()
        np.savetxt(buf, block, fmt="%.17g", delimiter=",")
        return buf.getvalue().encode()

    def percent():
        fmt = ",".join(["%.17g"] * block.shape[1]) + "\n"
        return ((fmt * len(block)) % tuple(block.ravel().tolist())).encode()

    def repr_join():
        return "".join(",".join(map(repr, row)) + "\n" for row in block.tolist()).encode()

    return {"orjson": lambda: csv_rows(t, data), "savetxt": savetxt, "%-format": percent, "repr-join": repr_join}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--repeats", type=int, default=5)
    a = p.parse_args(argv)
    root = Path(__file__).resolve().parents[1]
    model = kinem.compile(kinem.load(root / "cases" / "slider_crank.toml").with_time(steps=a.steps))
    kinem.solve(model)   # warm: kernels compiled or loaded
    times = {k: [] for k in ("solve", "orjson", "savetxt", "%-format", "repr-join")}
    for _ in range(a.repeats):
        start = time.perf_counter()
        r = kinem.solve(model)
        times["solve"].append(time.perf_counter() - start)
        for name, fn in contenders(r.trajectory.t, r.trajectory.data).items():
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    rows = len(r.trajectory)
    us = {k: 1e6 * statistics.median(v) / rows for k, v in times.items()}
    print(f"output_bench: slider_crank, {rows} rows x {len(r.trajectory.columns)} columns, "
          f"medians of {a.repeats} (round-robin)")
    print(f"  {'analysis (kinem.solve)':24s} {us['solve']:8.2f} us per instant")
    for k in ("orjson", "savetxt", "%-format", "repr-join"):
        print(f"  {k:24s} {us[k]:8.2f} us per row   {us[k] / us['solve']:6.2f}x the analysis   "
              f"{us[k] / us['orjson']:6.1f}x orjson")
    return us


if __name__ == "__main__":
    main()
