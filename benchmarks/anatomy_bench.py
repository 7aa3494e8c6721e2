"""Section 6 (anatomy of the slider-crank step) of benchmarks/run.py."""
import cProfile
import io
import pstats
from pathlib import Path

import numpy as np

import sys

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import ROOT, march_of, native, patched, per_call, rounds, say, step_by_step
import kinem


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

    model = state["slider_crank"]["model"]
    med, _, r = rounds({"n": native(model, options=step_by_step(model))}, cfg.native_repeats)["n"]
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
    """The compiled march's time by cProfile groups, its compiled LU and solve
    calls per instant with their cost per matrix, and its family passes.
    Skipped (an empty dict) when kinem has no kinem.dense (issue 23 moves
    the march into the compiled core, kinem._core)."""
    try:
        from kinem import dense
    except ImportError:
        say("   b) compiled march: skipped, kinem.dense is gone (issue 23: the march is in kinem._core)")
        return {}

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
    say(f"   b) compiled march (the default): {1e6 * per_instant:.1f} us per instant ({r.iterations.sum() / n:.2f} Newton"
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
