"""Each engine's default settings against the ones before the engines chose
their own ("auto"; docs/engines.md, "Measured costs before and after"):
stepping time per output interval on the five lower-pair cases, the two
settings interleaved in one process (median of N runs each), with the
errors against native at tolerance 1e-13 and the load average.

    python benchmarks/defaults_bench.py [N] [--json FILE]

``BEFORE`` reproduces main's defaults at 78b3341 in today's adapters (pymunk
100 iterations; MuJoCo dt 2.5e-4, driver overwritten before every step,
armature 1e9; Exudyn unchanged, a control for the noise).
"""
import argparse
import json
import statistics
from dataclasses import replace

import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import ROOT, say  # puts the repository root on sys.path

from adapters import get
from adapters.compare import compare, tolerance_of
from adapters.tune import CASES, REFERENCE_TOLERANCE
from kinem.case import load
from kinem.model import compile
from kinem.options import Options
from kinem.solver import solve

BEFORE = {"pymunk": {"iterations": 100}, "mujoco": {"dt": 2.5e-4, "drive": "overwrite", "armature": 1e9},
          "exudyn": {}}


def loadavg():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", nargs="?", type=int, default=9, help="runs of each setting per case")
    ap.add_argument("--json", help="write the figures here")
    a = ap.parse_args(argv)
    out = {"load_start": loadavg(), "engines": {}}
    for e, before in BEFORE.items():
        adapter, tol, rows = get(e), tolerance_of(get(e)), {}
        for name in CASES:
            case = load(ROOT / "cases" / f"{name}.toml")
            model = compile(case)
            ref = solve(model, options=replace(Options.of(case), tolerance=REFERENCE_TOLERANCE))
            runs = {"before": [], "after": []}
            for k in range(a.n):
                for which in ("before", "after") if k % 2 == 0 else ("after", "before"):
                    over = dict(case.engines.get(e, {}), **(before if which == "before" else {}))
                    runs[which].append(adapter.run(model, settings=adapter.settings(over)))
            rows[name] = {w: {"us_per_interval": 1e6 * statistics.median(r.per_interval for r in rs),
                              "substeps": rs[0].substeps, "notes": list(rs[0].notes),
                              "position_error_rel": compare(model, ref, rs[0], tol).position_error_rel,
                              "within_tolerance": compare(model, ref, rs[0], tol).within_tolerance}
                          for w, rs in runs.items()}
            say(f"{e:7s} {name:15s} " + "  ".join(
                f"{w} {r['us_per_interval']:7.1f} us ({r['substeps']} steps, pos/L {r['position_error_rel']:.1e})"
                for w, r in rows[name].items()))
        mean = {w: statistics.mean(r[w]["us_per_interval"] for r in rows.values()) for w in ("before", "after")}
        say(f"{e:7s} mean of the cases: before {mean['before']:.0f} us, after {mean['after']:.0f} us per output "
            f"interval: after / before {mean['after'] / mean['before']:.2f}")
        out["engines"][e] = {"cases": rows, "mean": mean}
    out["load_end"] = loadavg()
    say(f"load average {out['load_start']} -> {out['load_end']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
