"""Benchmarks of the native solver against the engines (issue 7); docs/benchmarks.md.

    python benchmarks/run.py [--quick | --tiny] [--json FILE] [--profile]

Sections (every figure is a ratio of two timings taken in this same run;
timings are medians of repeated runs, taken round-robin so that a change in
the machine's load hits every contender alike):

  1 engines    native cost per output step (default: the block march,
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
               (block march) and step by step
  5 skips      what the solver skips and what each skip saves; block march
               vs step by step
  6 anatomy    where the slider-crank step's time goes: step by step (timed
               pieces, LAPACK vs the rest) and block march (cProfile groups)
  7 cold start `python -m kinem solve ... --steps 1 --outputs positions`
  targets      each of issue 7's targets: met / not met, with the figure

--quick: fewer repeats and a shorter sweep (about a minute). --tiny: a smoke
configuration for tests/test_benchmarks.py (seconds; figures meaningless).
"""
import argparse
import cProfile
import dataclasses
import gc
import io
import json
import os
import platform
import pstats
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import kinem  # noqa: E402
from kinem import analysis  # noqa: E402
from kinem.batch import merge  # noqa: E402
from kinem.reference import four_bar, n_four_bar, rel_error, slider_crank, slider_crank_case  # noqa: E402

CASES = ("slider_crank", "four_bar", "quick_return_1")
ENGINES = ("pymunk", "mujoco", "exudyn")
REFERENCE_TOLERANCE = 1e-13   # as kinem.report.runs: errors are measured against this solution
LOOSE, TIGHT = 1e-6, 1e-10    # position errors / L of the work-precision targets


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


def say(text=""):
    print(text, flush=True)


# -- timing -------------------------------------------------------------------------

def rounds(fns: dict, repeats: int) -> dict:
    """Runs each callable ``repeats`` times round-robin (A B C A B C ...);
    each returns (seconds, payload). Returns name -> (median seconds, all
    seconds, payload of the last run)."""
    times = {k: [] for k in fns}
    last = {}
    for _ in range(max(1, repeats)):
        for k, fn in fns.items():
            gc.collect()
            seconds, last[k] = fn()
            times[k].append(seconds)
    return {k: (statistics.median(v), v, last[k]) for k, v in times.items()}


def per_call(fn, min_time=0.1, repeats=7) -> float:
    """Median seconds per call of a fast function (batches of calls)."""
    n, t = 1, 0.0
    while True:
        start = time.perf_counter()
        for _ in range(n):
            fn()
        t = time.perf_counter() - start
        if t >= min_time / repeats or n > 10**6:
            break
        n *= 4
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        samples.append((time.perf_counter() - start) / n)
    return statistics.median(samples)


def native(model, outputs=kinem.OUTPUTS):
    """A timed native solve: (wall_time of the analysis loop, SolveResult)."""
    def run():
        r = kinem.solve(model, outputs)
        if not r.success:
            raise RuntimeError(f"{model.case.name}: {r.message}")
        return r.wall_time, r
    return run


def step_by_step(model_or_case):
    """The same model marched one output instant at a time ([solver] block =
    1: the march before kinem.march, and the one sparse models, modified
    Newton and traces always use)."""
    case = getattr(model_or_case, "case", model_or_case)
    return kinem.compile(dataclasses.replace(case, block=1))


def march_of(model) -> str:
    from kinem.march import usable

    return "block" if usable(model, False, len(model.times)) else "step"


def per_step(result) -> float:
    """Seconds per output instant of a SolveResult (as adapters.compare.native_row)."""
    return result.wall_time / max(len(result.iterations), 1)


# -- what-if patches (benchmark process only; kinem's files are untouched) ----------------

def parity_c(perm) -> int:
    """Permutation parity with the cycle count from scipy's C connected
    components instead of kinem.linalg._parity's Python loop."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    p = np.asarray(perm, dtype=np.intp)
    n = len(p)
    if n < 64:
        return _PARITY[0](p)
    g = csr_matrix((np.ones(n, np.int8), p, np.arange(n + 1)), shape=(n, n))
    cycles = connected_components(g, directed=False, return_labels=False)
    return -1 if (n - cycles) % 2 else 1


_PARITY = []


class patched:
    """Context manager: set module attributes, restore them on exit."""

    def __init__(self, *triples):
        self.triples = triples

    def __enter__(self):
        self.saved = [(m, k, getattr(m, k)) for m, k, _ in self.triples]
        for m, k, v in self.triples:
            setattr(m, k, v)

    def __exit__(self, *exc):
        for m, k, v in self.saved:
            setattr(m, k, v)


def fast_parity():
    from kinem import linalg

    if not _PARITY:
        _PARITY.append(linalg._parity)
    return patched((linalg, "_parity", parity_c))


def timed_with(patch_factory, run):
    def fn():
        with patch_factory():
            return run()
    return fn


# -- machine --------------------------------------------------------------------------

def machine() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for pkg in ("kinem", "numpy", "scipy", "pymunk", "mujoco", "exudyn"):
        try:
            versions[pkg] = version(pkg)
        except PackageNotFoundError:
            versions[pkg] = "not installed"
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"cpu": cpu, "cores": os.cpu_count(), "usable_cores": usable, "python": platform.python_version(),
            "implementation": platform.python_implementation(), "platform": platform.platform(),
            "packages": versions, "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


# -- cases ------------------------------------------------------------------------------

def load_case(name, cfg):
    case = kinem.load(ROOT / "cases" / f"{name}.toml")
    if cfg.case_end is not None and cfg.case_end < case.end:
        h = case.end / case.steps
        case = case.with_time(cfg.case_end, max(1, round(cfg.case_end / h)))
    return case


def reference_solution(case):
    r = kinem.solve(kinem.compile(dataclasses.replace(case, tolerance=REFERENCE_TOLERANCE)))
    return r if r.success else kinem.solve(kinem.compile(case))


def adapter_of(name):
    from adapters import get

    try:
        return get(name), ""
    except Exception as e:  # noqa: BLE001 - an engine that does not import is reported, not fatal
        return None, f"{type(e).__name__}: {e}"


def engine_runner(adapter, model, ref, overrides=None):
    settings = adapter.settings({**dict(model.case.engines.get(adapter.name, {})), **(overrides or {})})

    def run():
        r = adapter.run(model, ref.q[0], ref.qd[0], settings)
        return r.wall_time, r
    return run


# -- 1 engines at default settings ------------------------------------------------------

def section_engines(cfg, state):
    from adapters.compare import compare

    say("== 1. native cost per output step vs engine cost per step (default settings) ==")
    say("   native: full analysis (positions, velocities, accelerations) to the case tolerance (default 1e-12) by the"
        " default block march; engine: EngineRun.wall_time/steps")
    say(f"   {'case':15s} {'native us/out':>13s} {'engine':7s} {'us/step':>8s} {'steps/out':>9s} {'us/out':>9s} "
        f"{'nat/eng-step':>12s} {'nat/eng-out':>11s} {'pos err/L':>9s}")
    rows = []
    for name in CASES:
        case = load_case(name, cfg)
        model = kinem.compile(case)
        ref = reference_solution(case)
        sbs = step_by_step(model)
        state[name] = {"case": case, "model": model, "ref": ref, "model_sbs": sbs}
        native(model)()  # warm-up (lazy imports, caches)
        native(sbs)()
        fns = {"native": native(model), "step": native(sbs)}
        adapters = {}
        for e in ENGINES:
            adapter, why = adapter_of(e)
            if adapter is None:
                rows.append({"case": name, "engine": e, "status": f"failed: import: {why}"})
                continue
            reason = adapter.unsupported(model)
            if reason:
                rows.append({"case": name, "engine": e, "status": reason})
                continue
            adapters[e] = adapter
            fns[e] = engine_runner(adapter, model, ref)
        # natives are cheap: more repeats for them, interleaved with the engines' runs
        nat_times, sbs_times, eng_times, last = [], [], {e: [] for e in adapters}, {}
        for k in range(max(cfg.native_repeats, cfg.engine_repeats)):
            gc.collect()
            t, last["native"] = fns["native"]()
            nat_times.append(t)
            gc.collect()
            t, last["step"] = fns["step"]()
            sbs_times.append(t)
            if k < cfg.engine_repeats:
                for e in adapters:
                    gc.collect()
                    t, last[e] = fns[e]()
                    eng_times[e].append(t)
        nat = last["native"]
        nat_step = statistics.median(nat_times) / len(nat.iterations)
        sbs_step = statistics.median(sbs_times) / len(last["step"].iterations)
        state[name]["native_step"] = nat_step
        state[name]["native_wall"] = statistics.median(nat_times)
        state[name]["native_step_sbs"] = sbs_step
        march = {"native_march": march_of(model), "native_step_by_step_us_per_output_step": 1e6 * sbs_step,
                 "native_block_over_step_by_step": nat_step / sbs_step}
        first = True
        for e, adapter in adapters.items():
            run = last[e]
            if not run.ok:
                rows.append({"case": name, "engine": e, "status": run.status})
                say(f"   {name:15s} {1e6 * nat_step:13.1f} {e:7s} {run.status}")
                continue
            c = compare(model, ref, run)
            eng_step = statistics.median(eng_times[e]) / run.steps
            out_steps = run.steps / max(len(model.times) - 1, 1)
            row = {"case": name, "engine": e, "status": "ok", "native_us_per_output_step": 1e6 * nat_step,
                   "native_repeats": len(nat_times), "engine_repeats": len(eng_times[e]),
                   "engine_us_per_step": 1e6 * eng_step, "engine_steps_per_output": out_steps,
                   "engine_us_per_output_interval": 1e6 * eng_step * out_steps,
                   "native_over_engine_step": nat_step / eng_step,
                   "native_over_engine_output": nat_step / (eng_step * out_steps),
                   "engine_position_error_rel": c.position_error_rel, "settings": _plain(run.settings), **march}
            rows.append(row)
            nat_col = f"{1e6 * nat_step:13.1f}" if first else " " * 13
            say(f"   {name if first else '':15s} {nat_col} {e:7s} "
                f"{1e6 * eng_step:8.2f} {out_steps:9.0f} {1e6 * eng_step * out_steps:9.1f} "
                f"{nat_step / eng_step:12.1f} {row['native_over_engine_output']:11.2f} {c.position_error_rel:9.1e}")
            first = False
        say(f"   {name:15s} native step by step (block = 1): {1e6 * sbs_step:.1f} us/out; "
            f"default ({'block march' if march['native_march'] == 'block' else 'step by step: block march not usable'})"
            f" / step by step: x{nat_step / sbs_step:.3f} ({sbs_step / nat_step:.1f} times faster)")
        rows.append({"case": name, "engine": "native step by step", "status": "native", **march,
                     "native_us_per_output_step": 1e6 * nat_step})
    say("   nat/eng-step: native cost per output step over one engine step; nat/eng-out: over the engine's steps"
        " for one output interval")
    return rows


# -- 2 work-precision ---------------------------------------------------------------------

def section_precision(cfg, state):
    from adapters.compare import compare, errors

    say("\n== 2. work-precision: wall time per simulated second to reach a position error (/L) ==")
    say(f"   errors: max position error / L against the native solution at tolerance {REFERENCE_TOLERANCE:.0e} "
        "(as kinem report); native by its default march (block march), its tolerances timed round-robin")
    say(f"   native's cost: the loosest tolerance of its sweep whose error is <= {TIGHT:.0e}; engines: the first dt"
        f" of the sweep (coarse to fine) that reaches {LOOSE:.0e}, and the first that reaches {TIGHT:.0e}")
    out = {}
    for name in CASES:
        s = state[name]
        case, model, ref = s["case"], s["model"], s["ref"]
        # native: the tolerance sweep; the loosest tolerance reaching TIGHT gives native's cost
        sweep = sorted({1e-6, 1e-8, 1e-10, 1e-12, case.tolerance}, reverse=True)
        models = {tol: model if tol == case.tolerance else kinem.compile(dataclasses.replace(case, tolerance=tol))
                  for tol in sweep}
        for m in models.values():
            native(m)()  # warm-up
        timed = rounds({tol: native(m) for tol, m in models.items()}, cfg.native_repeats)
        nat = {}
        for tol, (med, walls, r) in timed.items():
            nat[tol] = {"tolerance": tol, "wall_per_sim_second": med / case.end, "runs": len(walls),
                        "position_error_rel": errors(models[tol], ref, r.q, r.trajectory)["position_error_rel"]}
        reached = next((tol for tol in sweep if nat[tol]["position_error_rel"] <= TIGHT), None)
        used = reached if reached is not None else case.tolerance
        native_err = nat[used]["position_error_rel"]
        native_cost = nat[used]["wall_per_sim_second"]
        default = nat[case.tolerance]
        target = max(TIGHT, native_err)
        if reached is not None:
            say(f"   {name}: native reaches {TIGHT:.0e} at tolerance {reached:.0e}: error {native_err:.1e}, "
                f"{1e3 * native_cost:.2f} ms per simulated s; at the case tolerance {case.tolerance:.0e}: error "
                f"{default['position_error_rel']:.1e}, {1e3 * default['wall_per_sim_second']:.2f} ms/s")
        else:
            say(f"   {name}: native does not reach {TIGHT:.0e} in its sweep; at the case tolerance "
                f"{case.tolerance:.0e}: error {native_err:.1e}, {1e3 * native_cost:.2f} ms/s "
                f"(target for the engines: {target:.0e})")
        say("     native tolerance sweep: " + ", ".join(
            f"{t:.0e}: err {v['position_error_rel']:.1e} at {1e3 * v['wall_per_sim_second']:.2f} ms/s"
            for t, v in nat.items()))
        engines = {}
        for e in ENGINES:
            adapter, why = adapter_of(e)
            if adapter is None or adapter.unsupported(model):
                continue
            dt0 = adapter.defaults()["dt"]
            points, seen, per_step_cost = [], set(), None
            for f in cfg.dt_factors:
                h = case.end / case.steps
                expected_steps = case.steps * max(1, int(np.ceil(h / (dt0 * f) - 1e-9)))
                if expected_steps in seen:
                    continue
                if per_step_cost is not None and expected_steps * per_step_cost > cfg.sweep_budget:
                    points.append({"factor": f, "skipped": f"over the {cfg.sweep_budget:g} s budget "
                                   f"(~{expected_steps * per_step_cost:.1f} s)"})
                    break
                run = engine_runner(adapter, model, ref, {"dt": dt0 * f})()[1]
                seen.add(run.steps)
                c = compare(model, ref, run)
                p = {"factor": f, "dt": run.settings.get("dt"), "steps": run.steps, "status": c.status,
                     "position_error_rel": c.position_error_rel if c.status == "ok" else None,
                     "wall_per_sim_second": run.wall_time / case.end, "walls": [run.wall_time]}
                points.append(p)
                if run.steps:
                    per_step_cost = run.wall_time / run.steps
                if c.status == "ok" and c.position_error_rel <= target:
                    break
            ok = [p for p in points if p.get("status") == "ok"]
            loose = next((p for p in ok if p["position_error_rel"] <= LOOSE), None)
            tight = next((p for p in ok if p["position_error_rel"] <= target), None)
            best = min(ok, key=lambda p: p["position_error_rel"]) if ok else None
            for p in {id(x): x for x in (loose, tight, best) if x is not None}.values():
                runner = engine_runner(adapter, model, ref, {"dt": dt0 * p["factor"]})
                for _ in range(cfg.retime - 1):
                    p["walls"].append(runner()[0])
                p["wall_per_sim_second"] = statistics.median(p["walls"]) / case.end
            engines[e] = {"points": points, "loose": loose, "tight": tight, "best": best}
            def fmt(p, what):
                if p is None:
                    return f"{what}: not reached"
                return (f"{what}: dt {p['dt']:.2g} (err {p['position_error_rel']:.1e}) "
                        f"{1e3 * p['wall_per_sim_second']:.2f} ms/s")
            line = f"     {e:7s} {fmt(loose, '<=1e-6')}; " + (fmt(tight, f'<={target:.0e}') if tight else
                                                              'not reached ' + fmt(best, 'best'))
            reach = tight or best
            if reach:
                line += f"; native/engine at that point {native_cost / reach['wall_per_sim_second']:.2f}"
            say(line)
        loose_costs = [v["loose"]["wall_per_sim_second"] for v in engines.values() if v["loose"]]
        fastest_loose = min(loose_costs) if loose_costs else None
        out[name] = {"native": {str(k): v for k, v in nat.items()}, "native_tolerance": used,
                     "native_reaches_tight": reached is not None, "native_error": native_err,
                     "native_wall_per_sim_second": native_cost, "native_default_tolerance": case.tolerance,
                     "native_default_error": default["position_error_rel"],
                     "native_default_wall_per_sim_second": default["wall_per_sim_second"],
                     "target_error": target, "engines": engines, "fastest_engine_to_1e-6": fastest_loose,
                     "native_over_fastest_1e-6": native_cost / fastest_loose if fastest_loose else None,
                     "native_default_over_fastest_1e-6":
                         default["wall_per_sim_second"] / fastest_loose if fastest_loose else None}
        if fastest_loose:
            say(f"     native to {TIGHT:.0e} (tolerance {used:.0e}) / fastest engine to {LOOSE:.0e}: "
                f"{native_cost / fastest_loose:.2f}; at the case tolerance {case.tolerance:.0e}: "
                f"{default['wall_per_sim_second'] / fastest_loose:.2f}")
    return out


# -- 3 scaling --------------------------------------------------------------------------------

def chain_case(bodies, steps, solver):
    n = max(1, round((bodies - 2) / 2))
    d = n_four_bar(n)
    # crank 0 from pi/2 + 0.5 turning 0.5 rad: never near the horizontal (singular) position
    d["time"] = {"end": 0.5, "steps": steps}
    case = kinem.load_dict(d)
    return dataclasses.replace(case, linear_solver=solver), n


def lu_pieces(model, r):
    """Seconds of one kinem Factor (assemble, LU, pivot check) and of its
    det_sign (two permutation parities on the sparse path) at a mid instant."""
    from kinem.linalg import Factor

    k = len(r.iterations) // 2
    vals = model.jac_values(r.q[k], float(r.trajectory.t[k]))
    f = Factor(model, vals)
    return per_call(lambda: Factor(model, vals), 0.05, 3), per_call(lambda: f.det_sign, 0.05, 3)


def section_scaling(cfg):
    say("\n== 3. scaling: N-four-bar chain (2N+2 bodies), crank turning 0.5 rad, away from the horizontal ==")
    say(f"   {'bodies':>7s} {'N':>5s} {'coords':>7s} {'sparse us/step':>14s} {'us/body-step':>12s} "
        f"{'auto':>6s} {'auto us/step':>12s} {'LU ms':>7s} {'det_sign ms':>11s} {'C-parity us/step':>16s} "
        f"{'max err':>8s}")
    rows = []
    for bodies in cfg.bodies:
        case, n = chain_case(bodies, cfg.scaling_steps, "sparse")
        t = time.perf_counter()
        model = kinem.compile(case)
        compile_s = time.perf_counter() - t
        auto = kinem.compile(dataclasses.replace(case, linear_solver="auto"))
        fns = {"sparse": native(model), "C-parity": timed_with(fast_parity, native(model))}
        if not auto.sparse:
            fns["auto"] = native(auto)
        for f in fns.values():
            f()  # warm-up
        res = rounds(fns, cfg.native_repeats if bodies < 5000 else max(3, cfg.native_repeats // 2))
        r = res["sparse"][2]
        ni = len(r.iterations)
        step = res["sparse"][0] / ni
        auto_step = res["auto"][0] / ni if "auto" in res else step
        fast = res["C-parity"][0] / ni
        t_lu, t_det = lu_pieces(model, r)
        # exact solution: every crank angle equals the driver
        drive = np.pi / 2 + 0.5 - r.trajectory.t
        err = max(float(np.max(np.abs(r.trajectory[f"crank{k}.phi"] - drive))) for k in range(0, n + 1, max(1, n // 10)))
        rows.append({"bodies": 2 * n + 2, "N": n, "coordinates": model.n, "us_per_step_sparse": 1e6 * step,
                     "us_per_body_step": 1e6 * step / (2 * n + 2), "auto_path": "sparse" if auto.sparse else "dense",
                     "us_per_step_auto": 1e6 * auto_step, "ms_factor": 1e3 * t_lu, "ms_det_sign": 1e3 * t_det,
                     "det_sign_share": t_det / step, "us_per_step_c_parity": 1e6 * fast,
                     "compile_s": compile_s, "max_crank_error": err,
                     "newton_iterations": int(r.iterations.sum()), "factorizations": int(r.factorizations),
                     "instants": ni})
        say(f"   {2 * n + 2:7d} {n:5d} {model.n:7d} {1e6 * step:14.1f} {1e6 * step / (2 * n + 2):12.2f} "
            f"{rows[-1]['auto_path']:>6s} {1e6 * auto_step:12.1f} {1e3 * t_lu:7.2f} {1e3 * t_det:11.2f} "
            f"{1e6 * fast:16.1f} {err:8.1e}")
    by = {r["bodies"]: r for r in rows}
    out = {"rows": rows, "ratio_10000_1000": None}
    if 1000 in by and 10000 in by:
        out["ratio_10000_1000"] = by[10000]["us_per_step_sparse"] / by[1000]["us_per_step_sparse"]
        out["ratio_10000_1000_c_parity"] = by[10000]["us_per_step_c_parity"] / by[1000]["us_per_step_c_parity"]
        say(f"   t(10,000 bodies) / t(1,000 bodies) = {out['ratio_10000_1000']:.2f} (linear: 10); "
            f"with the C parity: {out['ratio_10000_1000_c_parity']:.2f}")
    big = rows[-1]
    say(f"   det_sign (Python-loop permutation parity) is {100 * big['det_sign_share']:.0f}% of a "
        f"{big['bodies']}-body step; C-parity column: the same solve with kinem.linalg._parity replaced by "
        "scipy's connected components (benchmark-side patch)")
    return out


# -- 4 batch ------------------------------------------------------------------------------------

def variants(b, steps, seed=7):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(b):
        r, l, e = 0.1 * (1 + 0.2 * rng.random()), 0.3 * (1 + 0.2 * rng.random()), 0.02 * (rng.random() - 0.5)
        out.append(kinem.load_dict(slider_crank_case(r, l, e, end=1.0, steps=steps)))
    return out


def section_batch(cfg):
    say("\n== 4. batch: B slider-crank variants (different r, l, offset) merged into one case (kinem.batch) ==")
    say(f"   1 s, {cfg.batch_steps} output steps; a merged model has 12 B coordinates in B diagonal blocks"
        " (kinem.model.Blocks): the block march solves one 12 x 12 LU per variant and instant")
    say("   single: one variant alone at its default (block march); sbs: the same solved step by step (block = 1,"
        " the march of merged models above that size)")
    say(f"   {'B':>5s} {'coords':>7s} {'path':>6s} {'march':>5s} {'us/variant-step':>15s} {'single us':>9s} "
        f"{'sbs us':>7s} {'single/batch':>12s} {'sbs/batch':>9s} {'C-parity single/batch':>21s} "
        f"{'merge+compile s':>15s}")
    cases = variants(max(cfg.batch_sizes), cfg.batch_steps)
    single_model = kinem.compile(cases[0])
    single_sbs = step_by_step(single_model)
    rows = []
    for b in cfg.batch_sizes:
        t = time.perf_counter()
        model = kinem.compile(merge(cases[:b])) if b > 1 else single_model
        build = time.perf_counter() - t
        fns = {"single": native(single_model), "sbs": native(single_sbs), "batch": native(model)}
        if model.sparse:
            fns["C-parity"] = timed_with(fast_parity, native(model))
        for f in fns.values():
            f()
        res = rounds(fns, cfg.native_repeats if b < 1000 else max(3, cfg.native_repeats // 2))
        single = res["single"][0] / len(res["single"][2].iterations)
        sbs = res["sbs"][0] / len(res["sbs"][2].iterations)
        batch = res["batch"][0] / len(res["batch"][2].iterations) / b
        fast = res["C-parity"][0] / len(res["batch"][2].iterations) / b if "C-parity" in res else batch
        rows.append({"B": b, "coordinates": model.n, "path": "sparse" if model.sparse else "dense",
                     "march": march_of(model), "us_per_variant_step": 1e6 * batch, "single_us_per_step": 1e6 * single,
                     "single_step_by_step_us_per_step": 1e6 * sbs, "speedup": single / batch,
                     "speedup_vs_step_by_step": sbs / batch, "speedup_c_parity": single / fast, "build_s": build,
                     "newton_iterations": int(res["batch"][2].iterations.sum()),
                     "single_newton_iterations": int(res["single"][2].iterations.sum()),
                     "single_step_by_step_newton_iterations": int(res["sbs"][2].iterations.sum()),
                     "instants": len(res["batch"][2].iterations)})
        say(f"   {b:5d} {model.n:7d} {rows[-1]['path']:>6s} {rows[-1]['march']:>5s} {1e6 * batch:15.2f} "
            f"{1e6 * single:9.1f} {1e6 * sbs:7.1f} {single / batch:12.1f} {sbs / batch:9.1f} "
            f"{single / fast:21.1f} {build:15.3f}")
    say(f"   single variant alone: {statistics.median(r['single_us_per_step'] for r in rows):.1f} us/step at its "
        f"default, {statistics.median(r['single_step_by_step_us_per_step'] for r in rows):.1f} step by step (medians"
        " over the rows; each ratio uses the single-model timings of its own row)")
    return rows


# -- 5 skips --------------------------------------------------------------------------------------

def closed_form_errors(name, r):
    """Max relative errors (positions, velocities, accelerations) against kinem.reference."""
    tr, t = r.trajectory, r.trajectory.t
    if name == "slider_crank":
        ref = slider_crank(5.76 - 1.2 * t + np.pi, np.full_like(t, -1.2), np.zeros_like(t), 200.0, 500.0, 0.0, -1.0)
        pos = max(rel_error(tr["slider.x"], ref["x"]), rel_error(tr["rod.phi"], ref["phi"], angle=True))
        vel = max(rel_error(tr["slider.vx"], ref["vx"]), rel_error(tr["rod.omega"], ref["omega"]))
        acc = max(rel_error(tr["slider.ax"], ref["ax"]), rel_error(tr["rod.alpha"], ref["alpha"]))
    else:
        th2, w2, a2 = np.pi / 4 + 1.5 * t - 0.6 * t**2, 1.5 - 1.2 * t, np.full_like(t, -1.2)
        ref = four_bar(th2, w2, a2, 0.1, 0.3, 0.22, 0.2)
        pos = max(rel_error(tr["coupler.phi"], ref["th3"], angle=True), rel_error(tr["rocker.phi"], ref["th4"], angle=True))
        vel = max(rel_error(tr["coupler.omega"], ref["w3"]), rel_error(tr["rocker.omega"], ref["w4"]))
        acc = max(rel_error(tr["coupler.alpha"], ref["a3"]), rel_error(tr["rocker.alpha"], ref["a4"]))
    return {"positions": pos, "velocities": vel, "accelerations": acc}


def section_skips(cfg, state):
    from scipy.linalg import lu_factor

    from kinem.constraints import REGISTRY
    from kinem.linalg import Factor

    say("\n== 5. what the solver skips, and what each skip saves ==")
    out = {}

    # outputs not requested
    say("   a) outputs not requested: positions only vs positions, velocities, accelerations (default: block march)")
    rows = []
    for name in CASES:
        model = state[name]["model"]
        res = rounds({"all": native(model), "positions": native(model, ("positions",))}, cfg.native_repeats)
        a, p = res["all"], res["positions"]
        n = len(a[2].iterations)
        rows.append({"case": name, "all_us_per_step": 1e6 * a[0] / n, "positions_us_per_step": 1e6 * p[0] / n,
                     "ratio": a[0] / p[0], "factorizations_all": a[2].factorizations,
                     "factorizations_positions": p[2].factorizations})
        say(f"      {name:15s} all {1e6 * a[0] / n:7.1f} us/step, positions only {1e6 * p[0] / n:7.1f}: "
            f"x{a[0] / p[0]:.2f} saved; factorisations {a[2].factorizations} -> {p[2].factorizations}")
    out["outputs"] = rows

    # block march vs step by step
    say("   b) block march (default, [solver] block = 256) vs step by step (block = 1): per output instant")
    rows = []
    for name in CASES:
        model = state[name]["model"]
        sbs = state[name].get("model_sbs") or step_by_step(model)
        res = rounds({"block": native(model), "step": native(sbs)}, cfg.native_repeats)
        row = {"case": name, "march": march_of(model)}
        for k in ("block", "step"):
            med, _, r = res[k]
            n = len(r.iterations)
            row[k] = {"us_per_instant": 1e6 * med / n, "iterations_per_instant": float(r.iterations.sum()) / n,
                      "jacobians_per_instant": r.jacobian_evaluations / n, "factorizations_per_instant":
                      r.factorizations / n, "instants": n}
        row["ratio_step_block"] = res["step"][0] / res["block"][0]
        rows.append(row)
        b, st = row["block"], row["step"]
        label = "block" if row["march"] == "block" else "block (not usable)"
        say(f"      {name:15s} {label} {b['us_per_instant']:6.1f} us, {b['iterations_per_instant']:.2f} "
            f"Newton it., {b['jacobians_per_instant']:.2f} Jacobians per instant | step by step "
            f"{st['us_per_instant']:6.1f} us, {st['iterations_per_instant']:.2f} it., {st['jacobians_per_instant']:.2f}"
            f" Jacobians | x{row['ratio_step_block']:.1f} faster")
    say("      (iterations: Newton updates; Jacobians include the one at the converged point for velocities and"
        " accelerations; the block march starts a block's far instants from an extrapolation, so they take more"
        " iterations, each a share of one batched pass)")
    out["block_march"] = rows

    # Jacobian reuse
    say("   c) Jacobian reuse (modified Newton, [solver] jacobian_reuse = true) vs full Newton, both step by step"
        " (block = 1; modified Newton exists only there); error vs closed form (kinem.reference)")
    rows = []
    for name in ("slider_crank", "four_bar"):
        case = state[name]["case"]
        off = kinem.compile(dataclasses.replace(case, jacobian_reuse=False, block=1))
        on = kinem.compile(dataclasses.replace(case, jacobian_reuse=True, block=1))
        res = rounds({"off": native(off), "on": native(on)}, cfg.native_repeats)
        row = {"case": name}
        for k in ("off", "on"):
            med, _, r = res[k]
            n = len(r.iterations)
            row[k] = {"us_per_step": 1e6 * med / n, "jacobians_per_instant": r.jacobian_evaluations / n,
                      "factorizations_per_instant": r.factorizations / n,
                      "iterations_per_instant": float(r.iterations.sum()) / n, "errors": closed_form_errors(name, r)}
        row["ratio_off_on"] = res["off"][0] / res["on"][0]
        rows.append(row)
        for k in ("off", "on"):
            v = row[k]
            e = v["errors"]
            say(f"      {name:13s} reuse {k:3s}: {v['us_per_step']:7.1f} us/step, {v['jacobians_per_instant']:.2f} "
                f"Jacobians and {v['factorizations_per_instant']:.2f} LUs per instant; error pos {e['positions']:.1e}"
                f" vel {e['velocities']:.1e} acc {e['accelerations']:.1e}")
        say(f"      {name:13s} off/on time ratio x{row['ratio_off_on']:.2f}")
    out["jacobian_reuse"] = rows

    # factorisation reuse between velocity and acceleration
    say("   d) one factorisation per instant serves velocity and acceleration (step by step, block = 1; the block"
        " march's two getrs per instant share one getrf by construction)")
    model = state["slider_crank"].get("model_sbs") or step_by_step(state["slider_crank"]["model"])
    real_acc = analysis.acceleration

    def twice(m, d):  # a solver that factorises again for the acceleration solve
        d.factor = None
        real_acc(m, d)

    def native_twice():
        analysis.acceleration = twice
        try:
            return native(model)()
        finally:
            analysis.acceleration = real_acc
    res = rounds({"once": native(model), "twice": native_twice}, cfg.native_repeats)
    r1, r2 = res["once"][2], res["twice"][2]
    n = len(r1.iterations)
    q, t0 = r1.q[n // 2], float(r1.trajectory.t[n // 2])
    vals = model.jac_values(q, t0)
    J = model.assemble(vals * model.entry_scale, False)
    t_lapack = per_call(lambda: lu_factor(J, check_finite=False))
    t_factor = per_call(lambda: Factor(model, vals))
    step = res["once"][0] / n
    fac = {"factorizations_per_instant_once": r1.factorizations / n, "factorizations_per_instant_twice": r2.factorizations / n,
           "us_per_step_once": 1e6 * step, "us_per_step_twice": 1e6 * res["twice"][0] / n,
           "ratio_twice_once": res["twice"][0] / res["once"][0], "us_lu_factor": 1e6 * t_lapack,
           "us_kinem_factor": 1e6 * t_factor, "lu_over_step": t_lapack / step, "factor_over_step": t_factor / step}
    out["factorization_reuse"] = fac
    say(f"      slider_crank: {fac['factorizations_per_instant_once']:.2f} LUs per instant "
        f"({fac['us_per_step_once']:.1f} us/step) vs {fac['factorizations_per_instant_twice']:.2f} when the acceleration"
        f" factorises again ({fac['us_per_step_twice']:.1f} us/step): x{fac['ratio_twice_once']:.3f}")
    say(f"      one scipy lu_factor of the 12x12 Jacobian {1e6 * t_lapack:.1f} us = {100 * fac['lu_over_step']:.1f}% of"
        f" a step; kinem's Factor (assemble, scale, LU, pivot check) {1e6 * t_factor:.1f} us = "
        f"{100 * fac['factor_over_step']:.1f}%")

    # constraint types the model does not use
    say("   e) constraint families the model does not use are never constructed")
    families = {d.family for d in REGISTRY.values() if d.family is not None}
    built = {cls: 0 for cls in families}
    originals = {cls: cls.__init__ for cls in families}

    def counting(cls):
        def init(self, *a, **k):
            built[cls] += 1
            originals[cls](self, *a, **k)
        return init
    for cls in families:
        cls.__init__ = counting(cls)
    try:
        m = kinem.compile(state["slider_crank"]["case"])
    finally:
        for cls, f in originals.items():
            cls.__init__ = f
    q = m.q0.copy()
    t_phi = per_call(lambda: m.phi(q, 0.1))
    t_jac = per_call(lambda: m.jac_values(q, 0.1))
    fam = [{"family": type(f).__name__, "rows": f.n_rows, "us_phi": 1e6 * per_call(lambda f=f: f.phi(q, 0.1)),
            "us_jac": 1e6 * per_call(lambda f=f: f.jac(q, 0.1))} for f in m.families]
    smallest = min(x["us_phi"] + x["us_jac"] for x in fam)
    unused = len(families) - sum(built.values())
    out["families"] = {"registered": len(families), "constructed": sum(built.values()),
                       "constructed_classes": sorted(c.__name__ for c, k in built.items() if k),
                       "types_registered": len(REGISTRY), "us_phi": 1e6 * t_phi, "us_jac": 1e6 * t_jac,
                       "per_family": fam, "smallest_family_us_phi_plus_jac": smallest,
                       "unused_if_built_us_per_phi_jac_at_least": smallest * unused}
    say(f"      slider_crank: {sum(built.values())} of {len(families)} registered families constructed "
        f"({', '.join(out['families']['constructed_classes'])}); {len(REGISTRY)} case-file types registered")
    say(f"      model.phi {1e6 * t_phi:.1f} us, model.jac_values {1e6 * t_jac:.1f} us per evaluation; "
        + ", ".join(f"{x['family']} ({x['rows']} rows) {x['us_phi']:.1f}+{x['us_jac']:.1f}" for x in fam)
        + " us (phi+jac)")
    say(f"      a family costs at least ~{smallest:.1f} us per phi+jac (the smallest above): the {unused} unused ones, "
        f"if built, would add >= ~{smallest * unused:.0f} us per evaluation "
        f"(x{(1e6 * (t_phi + t_jac) + smallest * unused) / (1e6 * (t_phi + t_jac)):.1f})")

    # engines not asked for: import times
    say("   f) engines not asked for are not imported (subprocess wall time, median)")
    snippets = {"python -c pass": "pass", "import kinem": "import kinem",
                "import kinem, scipy.linalg": "import kinem, scipy.linalg",
                "kinem + pymunk": "import kinem, adapters.pymunk_sim, pymunk",
                "kinem + mujoco": "import kinem, adapters.mujoco_sim, mujoco",
                "kinem + exudyn": "import kinem, adapters.exudyn_sim, exudyn",
                "kinem + all three engines": "import kinem, adapters.pymunk_sim, adapters.mujoco_sim, "
                                             "adapters.exudyn_sim, pymunk, mujoco, exudyn"}
    envs = environments()
    env = envs["bytecode cached"]
    subprocess.run([sys.executable, "-c", snippets["kinem + all three engines"]], cwd=ROOT, env=env, check=True,
                   capture_output=True)  # writes the .pyc cache
    times = subprocess_times({k: [sys.executable, "-c", v] for k, v in snippets.items()}, cfg.subprocess_repeats, env)
    base = times["import kinem"]
    out["imports"] = {k: {"ms": 1e3 * v, "over_kinem": v / base} for k, v in times.items()}
    say("      (bytecode cached, see 7)")
    for k, v in times.items():
        say(f"      {k:28s} {1e3 * v:7.1f} ms  (x{v / base:.2f} of import kinem)")
    return out


def subprocess_times(cmds: dict, repeats: int, env=None) -> dict:
    samples = {k: [] for k in cmds}
    for _ in range(max(1, repeats)):
        for k, cmd in cmds.items():
            t = time.perf_counter()
            subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            samples[k].append(time.perf_counter() - t)
    return {k: statistics.median(v) for k, v in samples.items()}


# -- 6 anatomy of the slider-crank step ----------------------------------------------------

def section_anatomy(cfg, state, profile=False):
    say("\n== 6. where a slider-crank output step goes (full analysis, dense path) ==")
    out = anatomy_step_by_step(cfg, state)
    out["block_march"] = anatomy_block(cfg, state)
    if profile:
        model = state["slider_crank"]["model"]
        pr = cProfile.Profile()
        pr.enable()
        for _ in range(5):
            kinem.solve(model)
        pr.disable()
        s = io.StringIO()
        pstats.Stats(pr, stream=s).sort_stats("tottime").print_stats(15)
        say("   cProfile (5 solves, default march, by own time):")
        say("\n".join("   " + line for line in s.getvalue().splitlines() if line.strip()))
    return out


def anatomy_step_by_step(cfg, state):
    """Each piece of the step-by-step step (block = 1) timed on its own, times
    its calls per instant."""
    from scipy.linalg import lapack

    from kinem.linalg import Factor

    model = state["slider_crank"].get("model_sbs") or step_by_step(state["slider_crank"]["model"])
    med, _, r = rounds({"n": native(model)}, cfg.native_repeats)["n"]
    n = len(r.iterations)
    step = med / n
    k = n // 2
    q, qd, t = r.q[k], r.qd[k], float(r.trajectory.t[k])
    vals = model.jac_values(q, t)
    J = model.assemble(vals * model.entry_scale, False)
    lu, piv, _ = lapack.dgetrf(J)
    b = np.ones(model.n)
    f = Factor(model, vals)
    phi = model.phi(q, t)
    costs = {"model.phi": per_call(lambda: model.phi(q, t)),
             "model.scaled_residual": per_call(lambda: model.scaled_residual(phi)),
             "model.jac_values": per_call(lambda: model.jac_values(q, t)),
             "Factor (assemble+LU+checks)": per_call(lambda: Factor(model, vals)),
             "Factor.solve": per_call(lambda: f.solve(b)),
             "model.nu": per_call(lambda: model.nu(t)),
             "model.gamma": per_call(lambda: model.gamma(q, qd, t)),
             "det_sign": per_call(lambda: f.det_sign),
             "LAPACK dgetrf (raw)": per_call(lambda: lapack.dgetrf(J)),
             "LAPACK dgetrs (raw)": per_call(lambda: lapack.dgetrs(lu, piv, b))}
    it = float(r.iterations.sum()) / n
    counts = {"model.phi": it + 1, "model.scaled_residual": it + 1, "model.jac_values": r.jacobian_evaluations / n,
              "Factor (assemble+LU+checks)": r.factorizations / n, "Factor.solve": it + 2, "model.nu": 1,
              "model.gamma": 1, "det_sign": 1, "LAPACK dgetrf (raw)": r.factorizations / n,
              "LAPACK dgetrs (raw)": it + 2}
    rows = []
    say(f"   a) step by step (block = 1): {1e6 * step:.1f} us per instant ({it:.2f} Newton iterations, "
        f"{r.jacobian_evaluations / n:.2f} Jacobians, {r.factorizations / n:.2f} LUs per instant); each piece timed"
        " on its own")
    say(f"      {'piece':30s} {'us/call':>8s} {'calls/step':>10s} {'% of step':>9s}")
    for name, c in costs.items():
        share = c * counts[name] / step
        rows.append({"piece": name, "us_per_call": 1e6 * c, "calls_per_step": counts[name], "share": share})
        say(f"      {name:30s} {1e6 * c:8.2f} {counts[name]:10.2f} {100 * share:8.1f}%")
    accounted = sum(x["share"] for x in rows if not x["piece"].startswith("LAPACK"))
    lapack_share = sum(x["share"] for x in rows if x["piece"].startswith("LAPACK"))
    say(f"      kinem pieces above: {100 * accounted:.0f}% of the step; the rest ({100 * (1 - accounted):.0f}%): the "
        "tracker and Newton loop (predictor, jump test, copies, bookkeeping)")
    say(f"      LAPACK itself (getrf + getrs, f2py call included): {100 * lapack_share:.1f}% of the step; "
        f"Python/numpy overhead: {100 * (1 - lapack_share):.1f}%")
    return {"march": "step", "us_per_step": 1e6 * step, "pieces": rows, "lapack_share": lapack_share,
            "kinem_pieces_share": accounted}


ANATOMY_GROUPS = {
    "families": "family evaluations (kinem/constraints, functions.py, model.py)",
    "dense": "compiled batched LU and solves (kinem/dense.py, numba)",
    "rest": "rest (march and tracker logic with their numpy arithmetic, result assembly)",
}


def own_group(key):
    """The anatomy group of a profiled function by its file, or None for a
    function charged to its callers (numpy's Python wrappers, builtins such
    as ufunc methods: their time belongs to whoever called them)."""
    file, _, func = key
    path = Path(file).as_posix() if file != "~" else ""
    pkg = (ROOT / "kinem").as_posix() + "/"
    if path.startswith(pkg):
        rel = path[len(pkg):]
        if rel.startswith("constraints/") or rel in ("functions.py", "model.py"):
            return "families"
        if rel == "dense.py":
            return "dense"
        return "rest"
    return None


def profile_groups(stats) -> dict:
    """Own time (tottime) per anatomy group. A function without a group of
    its own is charged to its callers, pro rata to the time it spent for
    each (recursively)."""
    memo = {}

    def shares(key, seen=()):
        if key in memo:
            return memo[key]
        g = own_group(key)
        if g is not None:
            res = {g: 1.0}
        else:
            callers = stats.stats[key][4] if key in stats.stats else {}
            total = sum(v[2] for v in callers.values())
            if not callers or total <= 0 or key in seen:
                res = {"rest": 1.0}
            else:
                res = {}
                for c, v in callers.items():
                    for gg, x in shares(c, seen + (key,)).items():
                        res[gg] = res.get(gg, 0.0) + x * v[2] / total
        memo[key] = res
        return res

    out = {g: 0.0 for g in ANATOMY_GROUPS}
    for key, (_, _, tt, _, _) in stats.stats.items():
        for g, x in shares(key).items():
            out[g] += tt * x
    return out


def counted_calls(model):
    """One unprofiled solve with counting wrappers: the compiled LU and solve
    calls and the matrices they handle, and the model's family passes (phi,
    jac_values, nu, gamma)."""
    from kinem import dense
    from kinem.model import Model

    counts = {"dense.factor": 0, "dense.solve": 0, "matrices factorised": 0, "matrices solved": 0}

    def counter(name, fn, matrices=None):
        def wrapped(*a, **k):
            counts[name] += 1
            if matrices:
                counts[matrices] += len(a[0])
            return fn(*a, **k)
        return wrapped
    passes = ("phi", "jac_values", "nu", "gamma")
    counts.update({f"model.{p}": 0 for p in passes})
    with patched((dense, "factor", counter("dense.factor", dense.factor, "matrices factorised")),
                 (dense, "solve", counter("dense.solve", dense.solve, "matrices solved")),
                 *((Model, p, counter(f"model.{p}", getattr(Model, p))) for p in passes)):
        r = kinem.solve(model)
    return counts, len(r.iterations)


def anatomy_block(cfg, state):
    """The block march's time by cProfile groups, its compiled LU and solve
    calls per instant with their cost per matrix, and its family passes."""
    from kinem import dense

    model = state["slider_crank"]["model"]
    med, _, r = rounds({"n": native(model)}, cfg.native_repeats)["n"]
    n = len(r.iterations)
    per_instant = med / n
    runs = 5
    pr = cProfile.Profile()
    pr.enable()
    for _ in range(runs):
        kinem.solve(model)
    pr.disable()
    stats = pstats.Stats(pr)
    groups = profile_groups(stats)
    total = sum(groups.values())
    counts, n_counted = counted_calls(model)
    per = {k: v / n_counted for k, v in counts.items()}
    # the cost per matrix of the compiled kernels, on stacks of this model's J_s as large as the average call
    stack = max(1, round(per["matrices factorised"] / max(per["dense.factor"], 1e-12)))
    k = n // 2
    J = model.assemble(model.jac_values(r.q[k], float(r.trajectory.t[k])) * model.entry_scale, False)
    S = np.broadcast_to(J, (stack, model.n, model.n)).copy()
    piv = dense.factor(S.copy())
    B = np.ones((stack, model.n))
    t_factor = per_call(lambda: dense.factor(S.copy())) / stack
    t_solve = per_call(lambda: dense.solve(S, piv, B.copy())) / stack
    Q, T = r.q[:stack].copy(), r.trajectory.t[:stack].copy()
    t_phi = per_call(lambda: model.phi(Q, T))
    t_jac = per_call(lambda: model.jac_values(Q, T))
    dense_us = t_factor * per["matrices factorised"] + t_solve * per["matrices solved"]
    say(f"   b) block march (the default): {1e6 * per_instant:.1f} us per instant ({r.iterations.sum() / n:.2f} Newton"
        f" iterations, {r.jacobian_evaluations / n:.2f} Jacobians per instant); cProfile of {runs} solves, own time"
        f" grouped ({1e3 * total:.0f} ms profiled vs {1e3 * runs * med:.0f} ms unprofiled analysis loops)")
    say(f"      {'group':78s} {'share':>6s} {'~us/instant':>11s}")
    rows = {}
    for g, label in ANATOMY_GROUPS.items():
        share = groups[g] / total if total else 0.0
        rows[g] = {"label": label, "share": share, "us_per_instant_estimate": 1e6 * share * per_instant}
        say(f"      {label:78s} {100 * share:5.1f}% {1e6 * share * per_instant:11.1f}")
    say("      (~us/instant: share x the unprofiled cost; the profiler inflates Python-heavy groups somewhat)")
    say(f"      per instant: {per['matrices factorised']:.2f} LUs in {per['dense.factor']:.3f} calls (~{stack} "
        f"matrices each, {1e6 * t_factor:.2f} us per matrix), {per['matrices solved']:.2f} solves in "
        f"{per['dense.solve']:.3f} calls ({1e6 * t_solve:.2f} us per matrix): ~{1e6 * dense_us:.1f} us of the "
        f"instant's {1e6 * per_instant:.1f} us ({100 * dense_us / per_instant:.0f}%)")
    fam = sum(per[f"model.{p}"] for p in ("phi", "jac_values", "nu", "gamma"))
    say(f"      family passes: {fam:.3f} model.phi/jac_values/nu/gamma calls per instant; one phi pass over "
        f"{stack} instants {1e6 * t_phi:.1f} us ({1e6 * t_phi / stack:.2f} per instant), one jac_values pass "
        f"{1e6 * t_jac:.1f} us ({1e6 * t_jac / stack:.2f} per instant)")
    return {"march": march_of(model), "us_per_instant": 1e6 * per_instant, "profiled_runs": runs,
            "profiled_s": total, "unprofiled_s": runs * med, "groups": rows, "calls_per_instant": per,
            "stack": stack, "us_lu_per_matrix": 1e6 * t_factor, "us_solve_per_matrix": 1e6 * t_solve,
            "dense_us_per_instant": 1e6 * dense_us, "dense_share": dense_us / per_instant,
            "family_passes_per_instant": fam, "us_phi_pass": 1e6 * t_phi, "us_jac_values_pass": 1e6 * t_jac}


# -- 7 cold start ---------------------------------------------------------------------------------

def environments():
    """Subprocess environments: as given, and with a bytecode cache. With
    PYTHONDONTWRITEBYTECODE set (as in some CI images) every kinem module is
    compiled from source at each start; the cached variant writes .pyc files
    under a temporary PYTHONPYCACHEPREFIX (never into the repository)."""
    import atexit
    import shutil
    import tempfile

    given = dict(os.environ)
    cached = dict(os.environ)
    cached.pop("PYTHONDONTWRITEBYTECODE", None)
    cached["PYTHONPYCACHEPREFIX"] = tempfile.mkdtemp(prefix="kinem-bench-pyc-")
    atexit.register(shutil.rmtree, cached["PYTHONPYCACHEPREFIX"], True)
    return {"as given": given, "bytecode cached": cached}


def section_coldstart(cfg, envs):
    say("\n== 7. cold start: python -m kinem solve cases/slider_crank.toml --steps 1 --outputs positions ==")
    case = str(ROOT / "cases" / "slider_crank.toml")
    cmds = {"cli": [sys.executable, "-m", "kinem", "solve", case, "--steps", "1", "--outputs", "positions"],
            "pass": [sys.executable, "-c", "pass"],
            "probe": [sys.executable, str(ROOT / "benchmarks" / "coldstart.py"), case],
            "full": [sys.executable, "-m", "kinem", "solve", case, "--out", os.devnull, "--format", "csv"]}
    n = cfg.subprocess_repeats
    dont = os.environ.get("PYTHONDONTWRITEBYTECODE")
    say(f"   PYTHONDONTWRITEBYTECODE={dont!r} here; 'bytecode cached': .pyc files in a temporary "
        "PYTHONPYCACHEPREFIX, written by one unmeasured run")
    for env in envs.values():
        subprocess.run(cmds["probe"], cwd=ROOT, env=env, capture_output=True, check=True)
    walls = {(e, k): [] for e in envs for k in cmds}
    marks = {e: [] for e in envs}
    for _ in range(n):  # round-robin: load changes hit every command alike
        for e, env in envs.items():
            for k, cmd in cmds.items():
                t = time.perf_counter()
                p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, check=True)
                walls[(e, k)].append(time.perf_counter() - t)
                if k == "probe":
                    marks[e].append(json.loads(p.stdout.strip().splitlines()[-1])["marks"])
    out = {"repeats": n, "PYTHONDONTWRITEBYTECODE": dont}
    names = ["interpreter start-up (python -c pass)"] + list(marks[next(iter(envs))][0])
    table = {}
    for e in envs:
        total = statistics.median(walls[(e, "cli")])
        split = {names[0]: statistics.median(walls[(e, "pass")])}
        split.update({k: statistics.median(m[k] for m in marks[e]) for k in names[1:]})
        rest = total - sum(split.values())
        table[e] = (total, split, rest)
        out[e] = {"total_s": total, "probe_s": statistics.median(walls[(e, "probe")]), "split_s": split,
                  "rest_s": rest, "largest": max(split, key=split.get),
                  "full_run_s": statistics.median(walls[(e, "full")])}
    say(f"   {'(medians of ' + str(n) + ' runs)':48s} " + " ".join(f"{e:>18s}" for e in envs))
    say(f"   {'total: kinem solve ... wall time':48s} " + " ".join(f"{1e3 * table[e][0]:15.0f} ms" for e in envs))
    for k in names:
        say(f"   {k:48s} " + " ".join(f"{1e3 * table[e][1][k]:8.1f} ms {100 * table[e][1][k] / table[e][0]:5.1f}%"
                                      for e in envs))
    say(f"   {'rest (argparse, runpy, interpreter exit, noise)':48s} "
        + " ".join(f"{1e3 * table[e][2]:8.1f} ms {100 * table[e][2] / table[e][0]:5.1f}%" for e in envs))
    for e in envs:
        say(f"   largest ({e}): {out[e]['largest']}")
    say(f"   {'full default run (block march: loads numba)':48s} "
        + " ".join(f"{1e3 * out[e]['full_run_s']:15.0f} ms" for e in envs))
    say(f"   {'  its ratio to the --steps 1 run':48s} "
        + " ".join(f"{out[e]['full_run_s'] / out[e]['total_s']:17.2f}x" for e in envs))
    return out


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
            f"native {mj['native_us_per_output_step']:.1f} us/output step (block march) vs MuJoCo "
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
            f"x{x:.1f} against the single model at its default (block march): {v['us_per_variant_step']:.1f} vs "
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
    say("\n== targets (issue 7; goals, not test assertions) ==")
    for t in out:
        say(f"   [{'MET' if t['met'] else 'NOT MET':7s}] {t['target']}: {t['figure']} (goal {t['goal']})"
            + (f"; gap: {t['gap']}" if t["gap"] else ""))
    return out


def _plain(v):
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v if isinstance(v, (str, int, float, bool)) or v is None else str(v)


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
                state[name] = {"case": case, "model": model, "ref": reference_solution(case),
                               "model_sbs": step_by_step(model)}
                native(model)()
    if "precision" in only:
        timed("precision", lambda: section_precision(cfg, state))
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
