"""The stress suite (``kinem stress``): situations that break solvers, run
on the native solver and every engine that supports them, each outcome
classified.

Classes (``classify``):
- singular-detected: native stopped with a singular-configuration diagnosis;
- diverged: no convergence (native) or an engine run that failed;
- nan: non-finite values in the trajectory;
- branch-flip: the trajectory satisfies the constraints (scaled residual
  <= BRANCH_RESIDUAL) yet is far (> BRANCH_ERROR of the size) from the
  reference: a valid motion on another assembly branch;
- inaccurate: farther from the reference than the solver's tolerance
  (native NATIVE_TOLERANCE, an engine its documented position tolerance);
- accurate: within it.
The reference is the scenario's closed form where one exists, else the
native solution. Native has an expected class per scenario (the run exits 1
when it differs); engines are measured, not judged.
"""
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

NATIVE_TOLERANCE = 1e-8   # of the size: far above the Newton tolerance (1e-12), far below a branch flip
BRANCH_RESIDUAL = 1e-6    # a configuration this close to satisfying the constraints is a valid one
BRANCH_ERROR = 1e-2       # ... and this far from the reference is another branch, not an inaccuracy
STRESS = Path(__file__).resolve().parents[1] / "cases" / "stress"


@dataclass(frozen=True)
class Scenario:
    group: str
    name: str
    case: dict                  # a case dict (kinem.load_dict)
    expect: str                 # native's expected class
    exact: str | None = None    # name of a closed form in REFERENCES, with its parameters in params
    params: tuple = ()
    engine_settings: dict = field(default_factory=dict)   # engine (or "*": every engine) -> overrides
    engines: bool = True        # False: native only (e.g. a case engines cannot start)


@dataclass(frozen=True)
class Outcome:
    group: str
    scenario: str
    engine: str
    outcome: str                # a class, or "unsupported: ..."
    error: float                # position error / L against the reference (nan when none)
    residual: float             # max scaled residual of the native constraints on the trajectory
    wall_time: float
    detail: str = ""


def _load(path):
    import tomllib

    return tomllib.loads(Path(path).read_text())


def _with(case, **time_):
    c = dict(case)
    c["time"] = {**case["time"], **time_}
    return c


def scenarios(quick=False) -> list:
    from .reference import four_bar_case, n_four_bar, slider_crank_case

    out = []
    # step size: output steps over three decades (native); engine steps over three to four decades
    base = slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, 2.0]}, 0.5, end=1.0 if quick else 2.0, steps=100)
    steps = (5, 50, 500) if quick else (5, 50, 500, 5000)
    for n in steps:
        out.append(Scenario("step-size", f"slider-crank, {n} output steps", _with(base, steps=n), "accurate",
                            "slider_crank", (0.5, 2.0, 0.1, 0.3), engines=False))
    for dt in ((1e-2, 1e-3, 1e-4) if quick else (1e-2, 1e-3, 1e-4, 1e-5)):
        out.append(Scenario("step-size", f"slider-crank, engine dt = {dt:g}", _with(base, steps=10), "accurate",
                            "slider_crank", (0.5, 2.0, 0.1, 0.3),
                            engine_settings={"*": {"dt": dt}}))
    # length scale: the same mechanism in other units gives the same normalised result
    for s in (1e-3, 1.0, 1e3):
        out.append(Scenario("length-scale", f"slider-crank, lengths x {s:g}",
                            slider_crank_case(0.1 * s, 0.3 * s, 0.02 * s, {"poly": [0.5, 2.0]}, 0.5, end=1.0, steps=100),
                            "accurate", "slider_crank", (0.5, 2.0, 0.1 * s, 0.3 * s, 0.02 * s)))
    # Grashof margin s + l - (p + q) = -eps: the four-bar nearly folds once per turn
    for eps in ((1e-2, 1e-5, 1e-8) if quick else (1e-2, 1e-4, 1e-6, 1e-8)):
        out.append(Scenario("grashof-margin", f"four-bar, s + l - (p + q) = -{eps:g}",
                            four_bar_case(1.0, 3.0, 2.0, 2.0 + eps, {"poly": [0.5, 2.0]}, 0.5, end=math.pi, steps=200),
                            "accurate", "four_bar", (0.5, 2.0, 1.0, 3.0, 2.0, 2.0 + eps)))
    # the IFToMM N-four-bar through the horizontal position
    for n in ((1, 5, 20) if quick else (1, 2, 5, 10, 20, 40)):
        out.append(Scenario("n-four-bar", f"N-four-bar, N = {n}", n_four_bar(n), "accurate", "n_four_bar", (n,)))
    # long runs: native must not drift; engines' drift is measured
    turns = 100 if quick else 10_000
    w = 20 * math.pi  # 10 turns per second keeps engine runs affordable
    out.append(Scenario("long-run", f"slider-crank, {turns} crank turns",
                        slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, w]}, 0.5, end=turns / 10, steps=turns * 8),
                        "accurate", "slider_crank", (0.5, w, 0.1, 0.3),
                        engine_settings={"*": {"dt": 1e-3}}))
    # mass ratio 1000:1 (engines only: the kinematics ignore masses)
    heavy = slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, 2.0]}, 0.5, end=1.0, steps=100)
    heavy["bodies"]["slider"] = {**heavy["bodies"]["slider"], "mass": 1000.0}
    heavy["bodies"]["crank"] = {**heavy["bodies"]["crank"], "mass": 1.0}
    heavy["bodies"]["rod"] = {**heavy["bodies"]["rod"], "mass": 1.0}
    out.append(Scenario("mass-ratio", "slider-crank, slider 1000 x rod", heavy, "accurate", "slider_crank",
                        (0.5, 2.0, 0.1, 0.3)))
    # singular configurations, branches and redundancy (cases/stress/)
    for name, expect in (("slider_dead_centre", "singular-detected"), ("rocker_toggle", "singular-detected"),
                         ("change_point", "accurate"), ("coarse_crank", "accurate"),
                         ("parallelogram_redundant", "accurate"), ("double_slider", "accurate")):
        out.append(Scenario("singular-branch-redundant", name, _load(STRESS / f"{name}.toml"), expect))
    return out


def _exact(s: Scenario, t):
    """Reference positions {column: values} of the closed form, or None."""
    from . import reference as ref

    if s.exact == "slider_crank":
        phi0, w, r, l, *e = s.params
        return {"slider.x": ref.slider_crank(phi0 + w * t, w + 0 * t, 0 * t, r, l, *(e or [0.0]))["x"]}
    if s.exact == "four_bar":
        phi0, w, a, b, c, g = s.params
        return {"rocker.phi": ref.four_bar(phi0 + w * t, w + 0 * t, 0 * t, a, b, c, g)["th4"]}
    if s.exact == "n_four_bar":
        th = math.pi / 2 + 0.5 - t
        return {f"crank{k}.phi": th for k in range(s.params[0] + 1)} | {f"coupler{k}.phi": 0 * t for k in range(s.params[0])}
    return None


def _deviation(model, traj, exact, native):
    """Largest error / L (angles in radians) against the closed form, else native."""
    if exact is not None:
        errs = []
        for col, ref in exact.items():
            d = traj[col][: len(ref)] - ref[: len(traj)]
            if col.endswith(".phi"):
                errs.append(np.abs((d + np.pi) % (2 * np.pi) - np.pi).max())
            else:
                errs.append(np.abs(d).max() / model.length)
        return float(max(errs))
    from adapters.compare import errors

    return float(errors(model, native, native.q, traj)["position_error_rel"]) if native is not None else float("nan")


def classify(error, residual, tolerance, finite=True) -> str:
    if not finite:
        return "nan"
    if error <= tolerance:
        return "accurate"
    if residual <= BRANCH_RESIDUAL and error > BRANCH_ERROR:
        return "branch-flip"
    return "inaccurate"


def run_one(task):
    """One scenario on one engine (or native): an Outcome as a dict."""
    from .solver import solve
    from .case import load_dict
    from .model import compile
    from .result import Status

    s, engine = task
    model = compile(load_dict(s.case, source=f"<stress {s.name}>"))
    start = time.perf_counter()
    native = solve(model)
    wall = time.perf_counter() - start
    exact_at = lambda t: _exact(s, t)
    if engine == "native":
        if native.status == Status.SINGULAR:
            return asdict(Outcome(s.group, s.name, engine, "singular-detected", float("nan"), float("nan"), wall,
                                  native.message))
        if not native.success:
            return asdict(Outcome(s.group, s.name, engine, "diverged", float("nan"), float("nan"), wall, native.message))
        t = native.trajectory.t
        finite = bool(np.isfinite(native.trajectory.data).all())
        # without a closed form native is its own reference: no error figure, only its residual
        err = _deviation(model, native.trajectory, exact_at(t), None) if exact_at(t) is not None else float("nan")
        res = model.kinematic_residual(native.q, t)
        outcome = classify(0.0 if err != err else err, res, NATIVE_TOLERANCE, finite)
        return asdict(Outcome(s.group, s.name, engine, outcome, err, res, wall,
                              f"{len(native.events)} event(s), {native.substeps} sub-step(s)"))
    from adapters import get
    from adapters.base import Status
    from adapters.compare import tolerance_of

    adapter = get(engine)
    reason = adapter.unsupported(model)
    if reason:
        return asdict(Outcome(s.group, s.name, engine, f"unsupported: {reason}", float("nan"), float("nan"), 0.0))
    if not native.success:
        # start the engine from native's t = 0 state anyway, over the instants native reached
        if len(native.trajectory) == 0:
            return asdict(Outcome(s.group, s.name, engine, "diverged", float("nan"), float("nan"), 0.0,
                                  "no assembled start"))
    overrides = s.engine_settings.get(engine, s.engine_settings.get("*", {}))
    run = adapter.run(model, native.q[0], native.qd[0], adapter.settings(overrides), native)
    if not run.ok:
        kind = "nan" if run.status is Status.NONFINITE else "diverged"
        return asdict(Outcome(s.group, s.name, engine, kind, float("nan"), float("nan"), run.wall_time, run.label))
    t = run.trajectory.t
    finite = bool(np.isfinite(run.trajectory.data).all())
    err = _deviation(model, run.trajectory, exact_at(t), native) if finite else float("nan")
    res = model.kinematic_residual(run.q, t) if finite else float("nan")
    tol = tolerance_of(adapter).get("position_error_rel", 1e-6)
    return asdict(Outcome(s.group, s.name, engine, classify(err, res, tol, finite), err, res, run.wall_time,
                          f"{run.steps} steps"))


def run(engines=None, quick=False, jobs=None, scheduler=None) -> list:
    """Every scenario on every engine asked for; a list of Outcome dicts in
    scenario order. jobs: local processes (None: one per core; 0 or 1: this
    process); scheduler: a Dask scheduler address to run on instead."""
    from . import parallel

    if engines is None:
        from adapters import names

        engines = ("native",) + names()
    tasks = [(s, e) for s in scenarios(quick) for e in engines if e == "native" or s.engines]
    return parallel.map(run_one, tasks, jobs, scheduler)


def expected(quick=False) -> dict:
    return {s.name: s.expect for s in scenarios(quick)}


def grid(rows):
    """The outcome rows as a grid: ([(group, scenario)], {(scenario, engine): row})."""
    names = list(dict.fromkeys((r["group"], r["scenario"]) for r in rows))
    return names, {(r["scenario"], r["engine"]): r for r in rows}


def cell(r) -> str:
    """One outcome as text: its class and error, 'unsupported', or '-' (not run)."""
    if r is None:
        return "-"
    if r["outcome"].startswith("unsupported"):
        return "unsupported"
    e = r["error"]
    return f"{r['outcome']} {e:.0e}" if e is not None and np.isfinite(e) else r["outcome"]


def table(rows, engines) -> str:
    names, by = grid(rows)
    width = max(len(n) for _, n in names) + 2
    lines = [f"{'group':26s}{'scenario':{width}s}" + "".join(f"{e:22s}" for e in engines)]
    for g, n in names:
        lines.append(f"{g:26s}{n:{width}s}" + "".join(f"{cell(by.get((n, e))):22s}" for e in engines))
    return "\n".join(lines)
