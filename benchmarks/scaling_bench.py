"""Sections 3 (scaling) and 4 (batch) of benchmarks/run.py."""
import dataclasses
import statistics
import time

import numpy as np

import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import fast_parity, march_of, native, per_call, rounds, say, step_by_step, timed_with
import kinem
from kinem.batch import merge
from kinem.reference import n_four_bar, slider_crank_case


# -- 3 scaling --------------------------------------------------------------------------------

def chain_case(bodies, steps):
    n = max(1, round((bodies - 2) / 2))
    d = n_four_bar(n)
    # crank 0 from pi/2 + 0.5 turning 0.5 rad: never near the horizontal (singular) position
    d["time"] = {"end": 0.5, "steps": steps}
    return kinem.load_dict(d), n


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
        case, n = chain_case(bodies, cfg.scaling_steps)
        t = time.perf_counter()
        model = kinem.compile(case)
        compile_s = time.perf_counter() - t
        sparse, auto = (dataclasses.replace(kinem.Options.of(case), linear_solver=s) for s in ("sparse", "auto"))
        fns = {"sparse": native(model, options=sparse),
               "C-parity": timed_with(fast_parity, native(model, options=sparse))}
        if not model.sparse:
            fns["auto"] = native(model, options=auto)
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
                     "us_per_body_step": 1e6 * step / (2 * n + 2), "auto_path": "sparse" if model.sparse else "dense",
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
        " (kinem.model.Blocks): the compiled march solves one 12 x 12 LU per variant and instant")
    say("   single: one variant alone at its default (compiled march); sbs: the same solved step by step (block = 1,"
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
        fns = {"single": native(single_model), "sbs": native(single_model, options=single_sbs), "batch": native(model)}
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
