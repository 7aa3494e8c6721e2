"""Sections 1 (engines at default settings) and 2 (work-precision) of
benchmarks/run.py."""
import dataclasses
import gc
import statistics

import numpy as np

import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import (CASES, ENGINES, LOOSE, REFERENCE_TOLERANCE, TIGHT, _plain, adapter_of, engine_runner,
                    load_case, march_of, native, reference_solution, rounds, say, step_by_step)
import kinem


# -- 1 engines at default settings ------------------------------------------------------

def section_engines(cfg, state):
    from adapters.compare import compare

    say("== 1. native cost per output step vs engine cost per step (default settings) ==")
    say("   native: full analysis (positions, velocities, accelerations) to the case tolerance (default 1e-12) by the"
        " default compiled march; engine: EngineRun.wall_time/steps")
    say(f"   {'case':15s} {'native us/out':>13s} {'engine':7s} {'us/step':>8s} {'steps/out':>9s} {'us/out':>9s} "
        f"{'nat/eng-step':>12s} {'nat/eng-out':>11s} {'pos err/L':>9s}")
    rows = []
    for name in CASES:
        case = load_case(name, cfg)
        model = kinem.compile(case)
        ref = reference_solution(model)
        state[name] = {"case": case, "model": model, "ref": ref}
        fns = {"native": native(model), "step": native(model, options=step_by_step(model))}
        fns["native"]()  # warm-up (lazy imports, caches)
        fns["step"]()
        adapters = {}
        for e in ENGINES:
            adapter, why = adapter_of(e)
            if adapter is None:
                rows.append({"case": name, "engine": e, "status": f"failed: import: {why}"})
                continue
            reason = adapter.unsupported(model)
            if reason:
                rows.append({"case": name, "engine": e, "status": f"unsupported: {reason}"})
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
                rows.append({"case": name, "engine": e, "status": run.label})
                say(f"   {name:15s} {1e6 * nat_step:13.1f} {e:7s} {run.label}")
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
            f"default ({'compiled march' if march['native_march'] == 'compiled' else 'step by step: compiled march not usable'})"
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
        "(as kinem report); native by its default march (compiled march), its tolerances timed round-robin")
    say(f"   native's cost: the loosest tolerance of its sweep whose error is <= {TIGHT:.0e}; engines: the first dt"
        f" of the sweep (coarse to fine) that reaches {LOOSE:.0e}, and the first that reaches {TIGHT:.0e}")
    out = {}
    for name in CASES:
        s = state[name]
        case, model, ref = s["case"], s["model"], s["ref"]
        # native: the tolerance sweep; the loosest tolerance reaching TIGHT gives native's cost
        options = kinem.Options.of(case)
        sweep = sorted({1e-6, 1e-8, 1e-10, 1e-12, options.tolerance}, reverse=True)
        fns = {tol: native(model, options=dataclasses.replace(options, tolerance=tol)) for tol in sweep}
        for f in fns.values():
            f()  # warm-up
        timed = rounds(fns, cfg.native_repeats)
        nat = {}
        for tol, (med, walls, r) in timed.items():
            nat[tol] = {"tolerance": tol, "wall_per_sim_second": med / case.end, "runs": len(walls),
                        "position_error_rel": errors(model, ref, r.q, r.trajectory)["position_error_rel"]}
        reached = next((tol for tol in sweep if nat[tol]["position_error_rel"] <= TIGHT), None)
        used = reached if reached is not None else options.tolerance
        native_err = nat[used]["position_error_rel"]
        native_cost = nat[used]["wall_per_sim_second"]
        default = nat[options.tolerance]
        target = max(TIGHT, native_err)
        if reached is not None:
            say(f"   {name}: native reaches {TIGHT:.0e} at tolerance {reached:.0e}: error {native_err:.1e}, "
                f"{1e3 * native_cost:.2f} ms per simulated s; at the case tolerance {options.tolerance:.0e}: error "
                f"{default['position_error_rel']:.1e}, {1e3 * default['wall_per_sim_second']:.2f} ms/s")
        else:
            say(f"   {name}: native does not reach {TIGHT:.0e} in its sweep; at the case tolerance "
                f"{options.tolerance:.0e}: error {native_err:.1e}, {1e3 * native_cost:.2f} ms/s "
                f"(target for the engines: {target:.0e})")
        say("     native tolerance sweep: " + ", ".join(
            f"{t:.0e}: err {v['position_error_rel']:.1e} at {1e3 * v['wall_per_sim_second']:.2f} ms/s"
            for t, v in nat.items()))
        engines = {}
        for e in ENGINES:
            adapter, why = adapter_of(e)
            if adapter is None or adapter.unsupported(model):
                continue
            dt0 = adapter.step(model, dict(model.case.engines.get(e, {})))   # dt = "auto": the one it picks
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
                p = {"factor": f, "dt": run.settings.get("dt"), "steps": run.steps, "status": c.label,
                     "position_error_rel": c.position_error_rel if c.ok else None,
                     "wall_per_sim_second": run.wall_time / case.end, "walls": [run.wall_time]}
                points.append(p)
                if run.steps:
                    per_step_cost = run.wall_time / run.steps
                if c.ok and c.position_error_rel <= target:
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
                     "native_wall_per_sim_second": native_cost, "native_default_tolerance": options.tolerance,
                     "native_default_error": default["position_error_rel"],
                     "native_default_wall_per_sim_second": default["wall_per_sim_second"],
                     "target_error": target, "engines": engines, "fastest_engine_to_1e-6": fastest_loose,
                     "native_over_fastest_1e-6": native_cost / fastest_loose if fastest_loose else None,
                     "native_default_over_fastest_1e-6":
                         default["wall_per_sim_second"] / fastest_loose if fastest_loose else None}
        if fastest_loose:
            say(f"     native to {TIGHT:.0e} (tolerance {used:.0e}) / fastest engine to {LOOSE:.0e}: "
                f"{native_cost / fastest_loose:.2f}; at the case tolerance {options.tolerance:.0e}: "
                f"{default['wall_per_sim_second'] / fastest_loose:.2f}")
    return out


# -- 2b equal error: native against each expert-tuned engine --------------------------------

EQUAL_ERRORS = (1e-6, 1e-8, 1e-10)   # position error / L


def section_equal_error(cfg, state):
    """Native against each engine run as its expert would: for each target
    error, the cheapest of native's tolerance sweep and the cheapest of the
    engine's own knobs (adapters.tune: integrator, steps per output interval,
    iterations) that reach it; costs per output interval (stepping only for
    the engines: EngineRun.per_interval), medians of ``cfg.retime`` runs; 2 s
    and full-length runs of each case."""
    from adapters import tune
    from adapters.compare import compare, errors

    say("\n== 2b. equal error: cost per output interval of native and of each engine at its cheapest setting "
        "(its own knobs) reaching 1e-6, 1e-8, 1e-10 of L ==")
    say("   native: full analysis (positions, velocities, accelerations) at the loosest tolerance of its sweep "
        "that reaches the error; engines: stepping calls only (EngineRun.wall_time / output intervals)")
    out = {}
    for name in CASES:
        full = load_case(name, cfg)
        lengths = {"full": full.end}
        if cfg.case_end is None and full.end > 2.0 + 1e-9:
            lengths = {"2 s": 2.0, "full": full.end}
        for label, end in lengths.items():
            case = full if end == full.end else full.with_time(end, max(1, round(full.steps * end / full.end)))
            model = kinem.compile(case)
            ref = reference_solution(model)
            n = max(case.steps, 1)
            options = kinem.Options.of(case)
            fns = {tol: native(model, options=dataclasses.replace(options, tolerance=tol))
                   for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)}
            for f in fns.values():
                f()   # warm-up
            timed = rounds(fns, cfg.native_repeats)
            nat = {tol: (med / n, errors(model, ref, r.q, r.trajectory)["position_error_rel"])
                   for tol, (med, walls, r) in timed.items()}
            engines = {}
            for e in ENGINES:
                adapter, why = adapter_of(e)
                if adapter is None or adapter.unsupported(model):
                    continue
                pts = []
                for over in tune.grid(adapter):
                    run = adapter.run(model, settings=adapter.settings(over))
                    c = compare(model, ref, run)
                    if c.ok:
                        pts.append({"settings": over, "time_per_interval": run.per_interval,
                                    "position_error_rel": c.position_error_rel})
                engines[e] = (adapter, pts)
            rows = []
            for target in EQUAL_ERRORS:
                row = {"target": target}
                reach = [(cost, tol, err) for tol, (cost, err) in nat.items() if err <= target]
                row["native"] = ({"tolerance": min(reach)[1], "time_per_interval": min(reach)[0],
                                  "position_error_rel": min(reach)[2]} if reach else None)
                for e, (adapter, pts) in engines.items():
                    ok = [p for p in pts if p["position_error_rel"] <= target]
                    if not ok:
                        row[e] = None
                        continue
                    best = dict(min(ok, key=lambda p: p["time_per_interval"]))
                    walls = [best["time_per_interval"]] + [
                        adapter.run(model, settings=adapter.settings(best["settings"])).per_interval
                        for _ in range(cfg.retime - 1)]
                    best["time_per_interval"] = statistics.median(walls)
                    if row["native"]:
                        best["native_over_engine"] = row["native"]["time_per_interval"] / best["time_per_interval"]
                    row[e] = best
                rows.append(row)

                def cell(v, e):
                    if v is None:
                        return f"{e} not reached"
                    x = f" (native/{e} x{v['native_over_engine']:.2f})" if "native_over_engine" in v else ""
                    knobs = ", ".join(f"{k}={s}" for k, s in v.get("settings", {}).items())
                    return f"{e} {1e6 * v['time_per_interval']:.1f} us [{knobs}]{x}"
                nat_cell = (f"native {1e6 * row['native']['time_per_interval']:.1f} us "
                            f"[tol {row['native']['tolerance']:.0e}]" if row["native"] else "native not reached")
                say(f"   {name:15s} {label:5s} <= {target:.0e}: {nat_cell}; "
                    + "; ".join(cell(row[e], e) for e in engines))
            out[f"{name} {label}"] = {"case": name, "end": end, "rows": rows}
    return out
