"""Issue 14's targets, each printed as a ratio of timings taken in this same
run, with the machine's load average (docs/benchmarks.md, "Issue 14").

    python benchmarks/issue14_bench.py [--quick] [--json FILE]

  peers    full analysis (positions, velocities, accelerations of every
           point) per output instant, in-process, warm, model compiled (and
           the linkage built) beforehand: kinem vs pylinkage 1.3's numba path
           (``Linkage.step_fast_with_kinematics``) on a slider-crank, a
           four-bar with a coupler point and Theo Jansen's leg (500 instants,
           benchmarks/peers.py), and vs the hand-tight C slider-crank
           (the floor; ``peers.floor_slider_crank``)
  rates    velocities and accelerations against the closed forms at the
           default tolerance, relative to their peak
  fixed    the cost of a solve beyond its per-instant work: the intercept of
           its time over 64 to 1,024 instants
  scaling  N-four-bar chains: t(10,000 bodies) / t(1,000), us per body-step
  batch    1,000 merged slider-crank variants: us per variant-step

Needs pylinkage (``pip install -e .[bench]``); without it the peer ratios
are skipped and said so.
"""
import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np

sys.dont_write_bytecode = True   # a benchmark writes nothing in the tree: no bytecode of what it imports
from common import FIXED_INSTANTS, fixed_cost, load, rounds, say, timed  # puts the repository root on sys.path
import peers

import kinem
from kinem.reference import four_bar, slider_crank


def section_peers(repeats):
    say("\n== peers: full analysis per output instant (500 instants, warm) ==")
    try:
        import pylinkage  # noqa: F401
        have = True
    except ImportError:
        have = False
        say("   pylinkage is not installed (pip install -e .[bench]): peer ratios skipped")
    out = {}
    for name, make in (("slider-crank", peers.slider_crank_case), ("four-bar", peers.four_bar_case),
                       ("jansen", peers.jansen_case)):
        model = kinem.compile(kinem.load_dict(make()))
        walls = []  # each solve's own wall time (its loop): the timed ones' median, as for the whole call

        def solve(m=model, walls=walls):
            start = time.perf_counter()
            r = kinem.solve(m)
            walls.append(r.wall_time)
            return time.perf_counter() - start, r

        fns = {"kinem": solve}
        if have:
            link, _ = peers.pylinkage_linkage(name)
            fns["pylinkage"] = timed(lambda k=link: k.step_fast_with_kinematics(iterations=peers.INSTANTS))
            fns["pylinkage+build"] = timed(lambda n=name: peers.pylinkage_run(n))
        if name == "slider-crank":
            fns["floor"] = timed(peers.floor_slider_crank)
        for f in fns.values():
            f()  # warm: compiled kernels loaded
        res = rounds(fns, repeats, warm=True)
        r = res["kinem"][2]
        assert r.success, r.message
        us = {k: 1e6 * v[0] / peers.INSTANTS for k, v in res.items()}
        timed_walls = walls[2::2]  # after the warm-up call, each round's untimed call, then its timed one
        row = {"us_per_instant": us, "kinem_loop_us": 1e6 * statistics.median(timed_walls) / len(r.iterations),
               "newton_per_instant": float(r.iterations.mean())}
        line = f"   {name:13s} kinem {us['kinem']:6.2f} us ({row['kinem_loop_us']:.2f} in the loop, " \
               f"{row['newton_per_instant']:.2f} Newton iterations)"
        if have:
            row["kinem_over_pylinkage"] = us["kinem"] / us["pylinkage"]
            line += f"; pylinkage {us['pylinkage']:.2f} us ({us['pylinkage+build']:.2f} with building): " \
                    f"x{row['kinem_over_pylinkage']:.2f}"
        if "floor" in us:
            row["kinem_over_floor"] = us["kinem"] / us["floor"]
            line += f"; floor {us['floor']:.2f} us: x{row['kinem_over_floor']:.2f}"
        say(line)
        out[name] = row
    return out


def section_rates():
    say("\n== rates: velocities and accelerations vs closed forms, default tolerance, relative to their peak ==")
    out = {}
    r = kinem.solve(kinem.compile(kinem.load_dict(peers.slider_crank_case())))
    t = r.trajectory.t
    ref = slider_crank(peers.PHI0 + peers.OMEGA * t, peers.OMEGA + 0 * t, 0 * t, peers.R, peers.L_ROD)
    T = r.trajectory
    out["slider-crank"] = {"velocity": _rel(T["slider.vx"], ref["vx"]), "acceleration": _rel(T["slider.ax"], ref["ax"])}
    r = kinem.solve(kinem.compile(kinem.load_dict(peers.four_bar_case())))
    t, T = r.trajectory.t, r.trajectory
    ref = four_bar(peers.PHI0 + peers.OMEGA * t, peers.OMEGA + 0 * t, 0 * t, peers.FA, peers.FB, peers.FC, peers.FG)
    out["four-bar"] = {"velocity": max(_rel(T["rocker.omega"], ref["w4"]), _rel(T["coupler.omega"], ref["w3"])),
                       "acceleration": max(_rel(T["rocker.alpha"], ref["a4"]), _rel(T["coupler.alpha"], ref["a3"]))}
    for k, v in out.items():
        say(f"   {k:13s} velocities {v['velocity']:.1e}, accelerations {v['acceleration']:.1e}")
    return out


def _rel(got, ref):
    return float(np.abs(got - ref).max() / np.abs(ref).max())


def section_fixed(repeats):
    say("\n== fixed cost of a solve: intercept of the whole kinem.solve call's time over "
        f"{', '.join(map(str, FIXED_INSTANTS))} output instants (least squares; each the median of "
        "10 solves in a row, rounds interleaved), slider-crank ==")
    return fixed_cost(kinem.load_dict(peers.slider_crank_case()), 2 * repeats)


def section_scaling(bodies, steps, repeats):
    from scaling_bench import chain_case

    say(f"\n== scaling: N-four-bar chains, {steps} output steps, default options ==")
    out = {}
    for b in bodies:
        case, n = chain_case(b, steps)
        model = kinem.compile(case)
        res = rounds({"solve": timed(lambda m=model: kinem.solve(m))}, repeats if b < 5000 else max(2, repeats // 2),
                     warm=True)
        r = res["solve"][2]
        assert r.success, r.message
        per = res["solve"][0] / len(r.iterations)
        out[b] = {"us_per_step": 1e6 * per, "us_per_body_step": 1e6 * per / (2 * n + 2)}
        say(f"   {2 * n + 2:6d} bodies: {1e6 * per:10.1f} us/step, {out[b]['us_per_body_step']:.2f} us/body-step")
    if 10000 in out and 1000 in out:
        out["ratio_10000_1000"] = out[10000]["us_per_step"] / out[1000]["us_per_step"]
    return out


def section_batch(b, steps, repeats):
    from scaling_bench import variants
    from kinem.batch import merge

    say(f"\n== batch: {b} slider-crank variants merged, {steps} output steps ==")
    model = kinem.compile(merge(variants(b, steps)))
    res = rounds({"batch": timed(lambda: kinem.solve(model))}, max(2, repeats // 2), warm=True)
    r = res["batch"][2]
    assert r.success, r.message
    per = res["batch"][0] / (len(r.iterations) * b)
    say(f"   {1e6 * per:.3f} us per variant-step")
    return {"us_per_variant_step": 1e6 * per}


def targets(res):
    out = []

    def add(name, figure, ratio, goal):
        met = ratio is not None and ratio <= goal
        out.append({"target": name, "figure": figure, "ratio": ratio, "goal": goal, "met": met})

    for name, row in res.get("peers", {}).items():
        x = row.get("kinem_over_pylinkage")
        if x is not None:
            add(f"{name}: kinem <= pylinkage per instant", f"x{x:.2f}", x, 1.0)
        if "kinem_over_floor" in row:
            add(f"{name}: kinem <= 2 x hand-tight floor", f"x{row['kinem_over_floor']:.2f}", row["kinem_over_floor"], 2.0)
    sc = res.get("scaling", {})
    if "ratio_10000_1000" in sc:
        add("scaling t(10,000)/t(1,000) <= 11", f"{sc['ratio_10000_1000']:.2f}", sc["ratio_10000_1000"], 11.0)
        per = [v["us_per_body_step"] for k, v in sc.items() if isinstance(k, int) and k >= 100]
        if per:
            add("cost per body-step roughly constant 100..10,000 (max/min <= 2)",
                f"{min(per):.2f}..{max(per):.2f} us", max(per) / min(per), 2.0)
    if "batch" in res:
        v = res["batch"]["us_per_variant_step"]
        add("batch of 1,000: <= 0.5 us per variant-step", f"{v:.3f} us", v / 0.5, 1.0)
    for k, v in res.get("rates", {}).items():
        worst = max(v.values())
        add(f"{k}: rates within 1e-13 of peak", f"{worst:.1e}", worst / 1e-13, 1.0)
    if "fixed" in res:
        f = res["fixed"]["fixed_us"]
        add("fixed cost <= 50 us", f"{f:.0f} us", f / 50, 1.0)
    say(f"\n== targets (issue 14; goals, not test assertions); load average {load()} ==")
    for t in out:
        say(f"   [{'MET' if t['met'] else 'NOT MET':7s}] {t['target']}: {t['figure']}"
            + ("" if t["met"] or t["ratio"] is None else f" (gap x{t['ratio'] / t['goal']:.2f})"))
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="fewer repeats, no 10,000-body chain")
    p.add_argument("--json", metavar="FILE")
    a = p.parse_args(argv)
    repeats = 3 if a.quick else 7
    say(f"issue 14 benchmarks ({'quick' if a.quick else 'full'}); load average {load()}; "
        f"{os.cpu_count()} cores; Python {sys.version.split()[0]}")
    res = {"load_start": load()}
    res["peers"] = section_peers(repeats)
    res["rates"] = section_rates()
    res["fixed"] = section_fixed(repeats)
    res["scaling"] = section_scaling((100, 1000) if a.quick else (100, 1000, 10000), 8, repeats)
    res["batch"] = section_batch(1000, 100, repeats)
    res["targets"] = targets(res)
    res["load_end"] = load()
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1, default=str)


if __name__ == "__main__":
    main()
