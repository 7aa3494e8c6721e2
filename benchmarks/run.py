"""Benchmarks of the native solver against the engines (issue 7); docs/benchmarks.md.

    python benchmarks/run.py [--quick | --tiny] [--json FILE] [--profile]

Sections (every figure is a ratio of two timings taken in this same run;
timings are medians of repeated runs, taken round-robin so that a change in
the machine's load hits every contender alike):

  1 engines    native cost per output step (default: the compiled march,
               kinem.march) vs each engine's cost per step
               (EngineRun.wall_time / steps: the stepping loop only) at
               default settings, on slider_crank, four_bar, quick_return_1;
               native step by step ([solver] block = 1) timed beside it
  2 precision  work-precision: wall time per simulated second for each
               engine to first reach 1e-6 and 1e-10 of L (dt swept from
               coarse to fine) vs native at the loosest tolerance of its
               sweep that reaches 1e-10 (and at its default 1e-12); errors
               against the native solution at tolerance 1e-13
  3 scaling    N-four-bar chains of 10 .. 10,000 bodies: cost per step
  4 batch      B slider-crank variants merged (kinem.batch): cost per
               variant-step vs one model solved alone, at its default
               (compiled march) and step by step
  5 skips      what the solver skips and what each skip saves; compiled march
               vs step by step
  6 anatomy    where the slider-crank step's time goes: step by step (timed
               pieces, LAPACK vs the rest) and compiled march (cProfile groups)
  7 cold start `python -m kinem solve ... --steps 1 --outputs positions`
  targets      each of issue 7's targets: met / not met, with the figure

--quick: fewer repeats and a shorter sweep (about a minute). --tiny: a smoke
configuration for tests/test_benchmarks.py (seconds; figures meaningless).
"""
import argparse
import dataclasses
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

# sibling modules of this script (benchmarks/ is sys.path[0]); common, imported first, puts the
# repository root on sys.path for kinem and adapters
sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import CASES, TIGHT, _plain, load_case, machine, native, reference_solution, say
from anatomy_bench import section_anatomy
from coldstart_bench import environments, section_coldstart
from engines_bench import section_engines, section_equal_error, section_precision
from scaling_bench import section_batch, section_scaling
from skips_bench import section_skips

import kinem


@dataclass(frozen=True)
class Config:
    name: str
    native_repeats: int        # native solves timed per figure (median kept)
    engine_repeats: int        # engine runs at default settings timed (median kept)
    dt_factors: tuple          # work-precision sweep: multiples of the engine's default dt, coarse to fine
    retime: int                # runs of each work-precision crossing point (median kept)
    sweep_budget: float        # s: a sweep point predicted to step longer than this is not run
    bodies: tuple              # scaling: body counts (N-four-bar with 2N + 2 bodies)
    scaling_steps: int
    batch_sizes: tuple
    batch_steps: int
    subprocess_repeats: int    # cold start and import times
    case_end: float | None = None  # shorten the three cases to this end time (tiny only)


FULL = Config("full", native_repeats=7, engine_repeats=5,
              dt_factors=(100, 50, 20, 10, 5, 2, 1, 0.5, 0.2, 0.1), retime=3, sweep_budget=6.0,
              bodies=(10, 100, 1000, 10000), scaling_steps=20, batch_sizes=(1, 10, 100, 1000), batch_steps=200,
              subprocess_repeats=5)
QUICK = Config("quick", native_repeats=3, engine_repeats=1,
               dt_factors=(100, 20, 10, 2, 1, 0.5, 0.2), retime=1, sweep_budget=1.0,
               bodies=(10, 100, 1000, 10000), scaling_steps=8, batch_sizes=(1, 10, 100, 1000), batch_steps=100,
               subprocess_repeats=3)
TINY = Config("tiny", native_repeats=2, engine_repeats=1, dt_factors=(100, 10), retime=1, sweep_budget=0.5,
              bodies=(10, 100), scaling_steps=3, batch_sizes=(1, 10), batch_steps=5, subprocess_repeats=1,
              case_end=0.1)


# -- targets ----------------------------------------------------------------------------------------

def targets(res):
    out = []

    def add(name, met, figure, goal, gap):
        out.append({"target": name, "met": met, "figure": figure, "goal": goal, "gap": None if met else gap})

    eng = {(r["case"], r["engine"]): r for r in res.get("engines", []) if r.get("status") == "ok"}
    mj = eng.get(("slider_crank", "mujoco"))
    if mj:
        x = mj["native_over_engine_step"]
        add("native slider-crank step <= MuJoCo mj_step", x <= 1.0,
            f"native {mj['native_us_per_output_step']:.1f} us/output step (compiled march) vs MuJoCo "
            f"{mj['engine_us_per_step']:.2f} us/step: x{x:.2f}", "ratio <= 1",
            f"native {x:.1f} times too slow")
    sc = res.get("scaling", {}).get("ratio_10000_1000")
    if sc is not None:
        add("linear in N (sparse): t(10,000)/t(1,000) <= 12", sc <= 12, f"{sc:.2f}", "<= 12",
            f"{sc / 12:.2f} times over")
    batch = {r["B"]: r for r in res.get("batch", [])}
    if 1000 in batch:
        v = batch[1000]
        x = v["speedup"]
        add("batch of 1,000 slider-cranks: per variant-step >= 20x below single", x >= 20,
            f"x{x:.1f} against the single model at its default (compiled march): {v['us_per_variant_step']:.1f} vs "
            f"{v['single_us_per_step']:.1f} us; x{v['speedup_vs_step_by_step']:.1f} against it step by step "
            f"({v['single_step_by_step_us_per_step']:.1f} us)", ">= 20", f"{20 / x:.1f} times short" if x > 0 else "")
    wp = res.get("precision", {})
    if wp:
        figs, met, worst = [], True, 0.0
        for name, v in wp.items():
            x = v["native_over_fastest_1e-6"]
            ok = x is not None and x < 1.0 and v["native_error"] <= TIGHT
            met &= ok
            worst = max(worst, x if x is not None else float("inf"))
            figs.append(f"{name} x{x:.2f} (tolerance {v['native_tolerance']:.0e})" if x is not None else f"{name} n/a")
        add("native to 1e-10 faster than any engine to 1e-6 (wall per simulated s)", met,
            "native/fastest: " + ", ".join(figs), "ratio < 1 on each case",
            f"native up to {worst:.1f} times too slow")
    eq = res.get("equal_error", {})
    if eq:
        figs, behind = [], []
        for key, v in eq.items():
            for row in v["rows"]:
                for e, p in row.items():
                    if isinstance(p, dict) and "native_over_engine" in p and e != "native":
                        figs.append(p["native_over_engine"])
                        if p["native_over_engine"] > 1.0:
                            behind.append(f"{key} {row['target']:.0e} {e} x{p['native_over_engine']:.2f}")
        if figs:
            add("native at most as costly as each expert-tuned engine at equal error, per output interval",
                not behind, f"native/engine from x{min(figs):.2f} to x{max(figs):.2f} over {len(figs)} pairings; "
                f"native behind in {len(behind)}: " + ("; ".join(behind[:6]) + (" ..." if len(behind) > 6 else "")),
                "ratio <= 1 everywhere", f"native behind in {len(behind)} of {len(figs)} pairings")
    say("\n== targets (issue 7; goals, not test assertions) ==")
    for t in out:
        say(f"   [{'MET' if t['met'] else 'NOT MET':7s}] {t['target']}: {t['figure']} (goal {t['goal']})"
            + (f"; gap: {t['gap']}" if t["gap"] else ""))
    return out


SECTIONS = ("engines", "precision", "scaling", "batch", "skips", "anatomy", "coldstart")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="fewer repeats, shorter sweep (~1 min)")
    g.add_argument("--tiny", action="store_true", help="smoke configuration for the tests (figures meaningless)")
    p.add_argument("--json", metavar="FILE", help="also write every figure as JSON")
    p.add_argument("--profile", action="store_true", help="print a cProfile of the slider-crank solve")
    p.add_argument("--only", metavar="SECTIONS", help=f"comma-separated subset of {','.join(SECTIONS)}")
    a = p.parse_args(argv)
    cfg = TINY if a.tiny else QUICK if a.quick else FULL
    only = set(SECTIONS if not a.only else (s.strip() for s in a.only.split(",")))
    bad = only - set(SECTIONS)
    if bad:
        p.error(f"--only: unknown sections {sorted(bad)}")
    start = time.perf_counter()
    m = machine()
    say(f"kinem benchmarks ({cfg.name}) on {m['cpu']}, {m['cores']} cores ({m['usable_cores']} usable), "
        f"{m['implementation']} {m['python']}, {m['platform']}")
    say("   " + ", ".join(f"{k} {v}" for k, v in m["packages"].items())
        + (f"; load average {m['load_average'][0]:.2f}" if m["load_average"] else ""))
    say("   every figure: median of repeated runs; ratios from timings taken in this run\n")
    res = {"config": dataclasses.asdict(cfg), "machine": m}
    state = {}
    clock = {}

    def timed(name, fn):
        t = time.perf_counter()
        res[name] = fn()
        clock[name] = time.perf_counter() - t

    if only & {"engines", "precision", "skips", "anatomy"}:
        if "engines" in only:
            timed("engines", lambda: section_engines(cfg, state))
        else:
            for name in CASES:
                case = load_case(name, cfg)
                model = kinem.compile(case)
                state[name] = {"case": case, "model": model, "ref": reference_solution(model)}
                native(model)()
    if "precision" in only:
        timed("precision", lambda: section_precision(cfg, state))
        timed("equal_error", lambda: section_equal_error(cfg, state))
    if "scaling" in only:
        timed("scaling", lambda: section_scaling(cfg))
    if "batch" in only:
        timed("batch", lambda: section_batch(cfg))
    if "skips" in only:
        timed("skips", lambda: section_skips(cfg, state))
    if "anatomy" in only:
        timed("anatomy", lambda: section_anatomy(cfg, state, a.profile))
    if "coldstart" in only:
        timed("coldstart", lambda: section_coldstart(cfg, environments()))
    res["targets"] = targets(res)
    res["elapsed_s"] = time.perf_counter() - start
    m["load_average_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    res["section_s"] = clock
    say(f"\nelapsed {res['elapsed_s']:.0f} s (" + ", ".join(f"{k} {v:.0f} s" for k, v in clock.items()) + ")")
    if a.json:
        Path(a.json).write_text(json.dumps(_plain(res), indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
