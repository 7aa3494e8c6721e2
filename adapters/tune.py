"""The sweep that derives each engine's default settings (``kinem engines
--tune``): every combination of the engine's own accuracy knobs (its
adapter's ``knobs``: steps per output interval, integrator, iterations) on
the book's lower-pair cases, each run compared with native at the
reference tolerance (adapters.compare). A setting *meets* the engine's
tolerance when it is within it on every case; the recommended setting is the
cheapest that meets it (cost: stepping seconds per output interval, the
median of ``repeats`` runs, averaged over the cases). The Pareto front is
the settings no other beats on both worst error and cost. Re-run it when an
engine's version changes and copy the recommendation into the adapter's
``defaults`` (docs/engines.md).
"""
import itertools
import statistics
from dataclasses import replace
from pathlib import Path

CASES = ("slider_crank", "four_bar", "quick_return_1", "quick_return_2", "quick_return_3")
QUICK_CASES = ("slider_crank", "four_bar")
QUICK_END = 0.5      # seconds simulated per case with --quick (a smoke run, not a derivation)
REFERENCE_TOLERANCE = 1e-13   # native's reference, as the report's


def _models(names, quick):
    from kinem.solver import solve
    from kinem.case import load
    from kinem.model import compile
    from kinem.options import Options

    root = Path(__file__).resolve().parents[1] / "cases"
    out = []
    for name in names:
        case = load(root / f"{name}.toml")
        if quick:
            case = case.with_time(QUICK_END, max(1, round(QUICK_END * case.steps / case.end)))
        model = compile(case)
        ref = solve(model, options=replace(Options.of(case), tolerance=REFERENCE_TOLERANCE))  # no second compile
        out.append((name, model, ref))
    return out


def grid(adapter):
    """Every combination of the adapter's knobs, as settings overrides; then,
    for an adapter with dt = "auto", each of its ``rate_steps`` (the step
    from the mechanism's rate scale, adapters.base.Adapter.resolve) with its
    other knobs at the defaults."""
    keys = list(adapter.knobs)
    out = [dict(zip(keys, values)) for values in itertools.product(*(adapter.knobs[k] for k in keys))]
    return out + [{"dt": "auto", "rate_step": c} for c in getattr(adapter, "rate_steps", ())]


def sweep(engine, cases=CASES, quick=False, repeats=3, models=None):
    """One point per knob combination: its settings, per-case figures and
    whether it meets the tolerance on every case. Returns
    {"engine", "tolerance", "points", "front", "recommended", "default"}."""
    from . import get
    from .compare import compare, tolerance_of

    adapter = get(engine)
    tol = tolerance_of(adapter)
    models = models or _models(cases if not quick else QUICK_CASES, quick)
    models = [(n, m, r) for n, m, r in models if not adapter.unsupported(m)]
    points = []
    for over in [None] + grid(adapter):          # None: the current defaults
        per_case, meets, costs, worst = {}, True, [], 0.0
        for name, model, ref in models:
            settings = adapter.settings(dict(model.case.engines.get(engine, {}), **(over or {})))
            run = adapter.run(model, settings=settings)
            c = compare(model, ref, run, tol)
            walls = [run.per_interval]
            if c.within_tolerance:      # only settings that count are timed again
                walls += [adapter.run(model, settings=settings).per_interval
                          for _ in range(repeats - 1)]
            cost = statistics.median(walls)
            per_case[name] = {"status": c.label, "within": bool(c.within_tolerance),
                              "position_error_rel": c.position_error_rel, "velocity_error_rel": c.velocity_error_rel,
                              "time_per_interval": cost, "substeps": run.substeps, "notes": list(run.notes)}
            meets &= bool(c.within_tolerance)
            worst = max(worst, c.position_error_rel if c.ok else float("inf"))
            costs.append(cost)
        points.append({"settings": over, "cases": per_case, "meets": meets, "position_error_rel": worst,
                       "time_per_interval": sum(costs) / max(len(costs), 1)})
    default, swept = points[0], points[1:]
    front = pareto(swept)
    ok = [p for p in swept if p["meets"]]
    best = min(ok, key=lambda p: p["time_per_interval"]) if ok else None
    fixed = [p for p in ok if (p["settings"] or {}).get("dt") != "auto"]
    best_fixed = min(fixed, key=lambda p: p["time_per_interval"]) if fixed else None
    ratio = (lambda b: default["time_per_interval"] / b["time_per_interval"] if b else None)
    return {"engine": engine, "version": adapter.version(), "tolerance": tol, "knobs": dict(adapter.knobs),
            "points": swept, "front": front, "recommended": best, "default": default,
            "default_over_recommended": ratio(best), "recommended_fixed": best_fixed,
            "default_over_fixed": ratio(best_fixed)}


def pareto(points, cost="time_per_interval", error="position_error_rel", floor=0.0):
    """Indices of the points that no other point beats on both worst
    position error and cost (finite errors only; a None error or cost never
    counts), cheapest first. ``cost`` and ``error`` name the points' keys
    (the report's points call them "cost" and "error"); errors below
    ``floor`` (rounding noise) count as equal, so only the cheapest of them
    is on the front."""
    inf = float("inf")
    finite = [(p[cost], max(p[error], floor), k) for k, p in enumerate(points)
              if p[error] is not None and p[cost] is not None and p[error] < inf and p[cost] < inf]
    front, best = [], inf
    for c, err, k in sorted(finite):
        if err < best:
            front.append(k)
            best = err
    return front


STEP_KNOB = "substeps"   # the step: the report sweeps it as dt (adapters.base: dt = interval / substeps)
FAMILY_VALUES = 2        # alternatives per knob in the report: the knob's extremes besides the default


def families(adapter, settings, most=FAMILY_VALUES):
    """The knob families of the report's work-precision sweep: settings
    overrides of the adapter's knobs other than the step, the first being
    ``settings``' own values (the defaults' family), then one knob changed at
    a time to at most ``most`` other values of its list (its first and last:
    the cheapest and most careful ends). Each family is swept over dt."""
    names = [k for k in adapter.knobs if k != STEP_KNOB]
    base = {k: settings.get(k) for k in names}
    out = [base]
    for k in names:
        others = [v for v in adapter.knobs[k] if v != base[k]]
        pick = others if len(others) <= most else [others[0], others[-1]][:most]
        out += [dict(base, **{k: v}) for v in pick]
    return out


def text(result) -> str:
    """The sweep as a table: knobs, worst error, cost, verdict, front."""
    e, front = result["engine"], set(result["front"])
    lines = [f"{e} {result['version']}: {len(result['points'])} settings; tolerance "
             + ", ".join(f"{k} {v:.0e}" for k, v in result["tolerance"].items())]
    lines.append(f"  {'settings':44s} {'worst pos/L':>11s} {'us/out':>9s}  verdict")
    rows = [("defaults (now)", result["default"])] + [
        (", ".join(f"{k}={v}" for k, v in p["settings"].items()), p) for p in result["points"]]
    for k, (label, p) in enumerate(rows):
        mark = " *front" if k - 1 in front and k > 0 else ""
        verdict = "meets" if p["meets"] else "misses"
        lines.append(f"  {label:44s} {p['position_error_rel']:11.2e} {1e6 * p['time_per_interval']:9.1f}  "
                     f"{verdict}{mark}")
    best = result["recommended"]
    if best:
        lines.append(f"  recommended (cheapest that meets the tolerance on every case): {best['settings']}, "
                     f"{1e6 * best['time_per_interval']:.1f} us per output interval; the defaults cost "
                     f"{result['default_over_recommended']:.2f}x that")
    else:
        lines.append("  no swept setting meets the tolerance on every case")
    fixed = result.get("recommended_fixed")
    if fixed and fixed is not best:
        lines.append(f"  cheapest fixed step that meets it: {fixed['settings']}, {1e6 * fixed['time_per_interval']:.1f} "
                     f"us per output interval; the defaults cost {result['default_over_fixed']:.2f}x that")
    return "\n".join(lines)
