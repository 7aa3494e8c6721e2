"""Section 5 (what the solver skips) of benchmarks/run.py."""
import dataclasses
import statistics
import subprocess
import sys
import time
from types import SimpleNamespace

import numpy as np

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from coldstart_bench import environments
from common import CASES, ROOT, march_of, native, per_call, rounds, say, step_by_step
import kinem
from kinem import analysis
from kinem.reference import four_bar, rel_error, slider_crank


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
    say("   a) outputs not requested: positions only vs positions, velocities, accelerations (default: compiled march)")
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

    # compiled march vs step by step
    say("   b) compiled march (default, [solver] block = 256) vs step by step (block = 1): per output instant")
    rows = []
    for name in CASES:
        model = state[name]["model"]
        res = rounds({"block": native(model), "step": native(model, options=step_by_step(model))}, cfg.native_repeats)
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
        label = "compiled" if row["march"] == "compiled" else "compiled (not usable)"
        say(f"      {name:15s} {label} {b['us_per_instant']:6.1f} us, {b['iterations_per_instant']:.2f} "
            f"Newton it., {b['jacobians_per_instant']:.2f} Jacobians per instant | step by step "
            f"{st['us_per_instant']:6.1f} us, {st['iterations_per_instant']:.2f} it., {st['jacobians_per_instant']:.2f}"
            f" Jacobians | x{row['ratio_step_block']:.1f} faster")
    say("      (iterations: Newton updates; Jacobians include the one at the converged point for velocities and"
        " accelerations; the compiled march starts a block's far instants from an extrapolation, so they take more"
        " iterations, each a share of one batched pass)")
    out["block_march"] = rows

    # Jacobian reuse
    say("   c) Jacobian reuse (modified Newton, [solver] jacobian_reuse = true) vs full Newton, both step by step"
        " (block = 1; modified Newton exists only there); error vs closed form (kinem.reference)")
    rows = []
    for name in ("slider_crank", "four_bar"):
        model = state[name]["model"]
        step_options = step_by_step(model)
        off, on = (dataclasses.replace(step_options, jacobian_reuse=reuse) for reuse in (False, True))
        res = rounds({"off": native(model, options=off), "on": native(model, options=on)}, cfg.native_repeats)
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
    say("   d) one factorisation per instant serves velocity and acceleration (the step-by-step stages,"
        " kinem.position, velocity and acceleration at each instant; the core's step and march solve both rates"
        " with one LU by construction)")
    model = state["slider_crank"]["model"]

    def stages(again):
        """The stages at every output instant; ``again``: the acceleration factorises once more."""
        def run():
            d = analysis.Data.from_model(model)
            start = time.perf_counter()
            iterations, q = [], []
            for t in model.times:
                analysis.position(model, d, float(t))
                analysis.velocity(model, d)
                if again:
                    d.factor = None
                analysis.acceleration(model, d)
                iterations.append(d.iterations)
                q.append(d.q)
            return time.perf_counter() - start, SimpleNamespace(iterations=np.array(iterations), q=np.array(q),
                                                                factorizations=d.factorizations,
                                                                trajectory=SimpleNamespace(t=model.times))
        return run
    res = rounds({"once": stages(False), "twice": stages(True)}, cfg.native_repeats)
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
    unused = len(families) - sum(built.values())
    out["families"] = {"registered": len(families), "constructed": sum(built.values()),
                       "constructed_classes": sorted(c.__name__ for c, k in built.items() if k),
                       "types_registered": len(REGISTRY), "us_phi": 1e6 * t_phi, "us_jac": 1e6 * t_jac}
    say(f"      slider_crank: {sum(built.values())} of {len(families)} registered families constructed "
        f"({', '.join(out['families']['constructed_classes'])}); {len(REGISTRY)} case-file types registered: "
        f"the core's tables hold only the {sum(built.values())} present, so the {unused} others cost nothing")
    say(f"      model.phi {1e6 * t_phi:.1f} us, model.jac_values {1e6 * t_jac:.1f} us per evaluation (one core call)")

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
