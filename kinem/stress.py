"""The stress suite (``kinem stress``): situations that break solvers, run
on the native solver and every engine that supports them, each outcome
classified (``Class``, the status of its Outcome):
- singular-detected: native stopped with a singular-configuration diagnosis;
- diverged: no convergence (native) or an engine run that failed;
- nan: non-finite values in the trajectory;
- branch-flip: the trajectory satisfies the constraints (scaled residual
  <= BRANCH_RESIDUAL) yet is far (> BRANCH_ERROR of the size) from the
  reference: a valid motion on another assembly branch;
- inaccurate: a figure outside its tolerance: native's positions farther than
  NATIVE_TOLERANCE of the size from the closed form; an engine's figures
  against the one scale-free table (docs/engines.md: positions / L, angles,
  velocities / V, angular velocities / (V / L), loop closure), each over its
  limit named in the detail;
- accurate: within it.
The reference is the scenario's closed form where one exists (positions),
and the native solution (every figure). Native has an expected class per
scenario (the run exits 1 when it differs); engines are measured, not judged.
"""
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .outcome import Kind, Outcome

NATIVE_TOLERANCE = 1e-8   # of the size: far above the Newton tolerance (1e-12), far below a branch flip
BRANCH_RESIDUAL = 1e-6    # a configuration this close to satisfying the constraints is a valid one
BRANCH_ERROR = 1e-2       # ... and this far from the reference is another branch, not an inaccuracy
STRESS = Path(__file__).resolve().parents[1] / "cases" / "stress"


class Class(Kind):
    """A stress outcome's class; ``failure``: a red cell (an engine's is measured, not judged)."""
    ACCURATE = ("accurate", "within its tolerance")
    SINGULAR = ("singular-detected", "stopped with a singular-configuration diagnosis")
    UNSUPPORTED = ("unsupported", "the engine cannot represent the scenario")
    INACCURATE = ("inaccurate", "a figure outside its tolerance", True)
    BRANCH_FLIP = ("branch-flip", "a valid motion on another assembly branch", True)
    NAN = ("nan", "non-finite values in the trajectory", True)
    DIVERGED = ("diverged", "no convergence, or the engine run failed", True)


@dataclass(frozen=True)
class Scenario:
    group: str
    name: str
    case: dict                  # a case dict (kinem.load_dict)
    expect: Class               # native's expected class
    exact: str | None = None    # name of a closed form in REFERENCES, with its parameters in params
    params: tuple = ()
    engine_settings: dict = field(default_factory=dict)   # engine (or "*": every engine) -> overrides
    engines: bool = True        # False: native only (e.g. a case engines cannot start)


@dataclass(frozen=True)
class Row:
    """A stress Outcome's value: which run, and its figures."""
    group: str
    scenario: str
    engine: str
    error: float                # the larger of position error / L and angle error (rad) (nan when none)
    residual: float             # max scaled residual of the native constraints on the trajectory
    wall_time: float
    exceeded: tuple = ()        # (figure, value, limit) over the tolerance table


def as_dict(o: Outcome) -> dict:
    """An outcome as results.json and ``kinem stress --json`` hold it."""
    r = o.value
    return {"group": r.group, "scenario": r.scenario, "engine": r.engine, "outcome": o.status.value,
            "error": r.error, "residual": r.residual, "wall_time": r.wall_time, "detail": o.detail,
            "exceeded": [{"figure": k, "value": v, "limit": lim} for k, v, lim in r.exceeded]}


def from_dict(d: dict) -> Outcome:
    """``as_dict`` read back (null figures are nan)."""
    num = lambda x: float("nan") if x is None else x
    return Outcome(Class(d["outcome"]), d["detail"],
                   Row(d["group"], d["scenario"], d["engine"], num(d["error"]), num(d["residual"]), d["wall_time"],
                       tuple((e["figure"], e["value"], e["limit"]) for e in d.get("exceeded", ()))))


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
        out.append(Scenario("step-size", f"slider-crank, {n} output steps", _with(base, steps=n), Class.ACCURATE,
                            "slider_crank", (0.5, 2.0, 0.1, 0.3), engines=False))
    for dt in ((1e-2, 1e-3, 1e-4) if quick else (1e-2, 1e-3, 1e-4, 1e-5)):
        out.append(Scenario("step-size", f"slider-crank, engine dt = {dt:g}", _with(base, steps=10), Class.ACCURATE,
                            "slider_crank", (0.5, 2.0, 0.1, 0.3),
                            engine_settings={"*": {"dt": dt}}))
    # length scale: the same mechanism in other units gives the same normalised result
    for s in (1e-3, 1.0, 1e3):
        out.append(Scenario("length-scale", f"slider-crank, lengths x {s:g}",
                            slider_crank_case(0.1 * s, 0.3 * s, 0.02 * s, {"poly": [0.5, 2.0]}, 0.5, end=1.0, steps=100),
                            Class.ACCURATE, "slider_crank", (0.5, 2.0, 0.1 * s, 0.3 * s, 0.02 * s)))
    # Grashof margin s + l - (p + q) = -eps: the four-bar nearly folds once per turn
    for eps in ((1e-2, 1e-5, 1e-8) if quick else (1e-2, 1e-4, 1e-6, 1e-8)):
        out.append(Scenario("grashof-margin", f"four-bar, s + l - (p + q) = -{eps:g}",
                            four_bar_case(1.0, 3.0, 2.0, 2.0 + eps, {"poly": [0.5, 2.0]}, 0.5, end=math.pi, steps=200),
                            Class.ACCURATE, "four_bar", (0.5, 2.0, 1.0, 3.0, 2.0, 2.0 + eps)))
    # the IFToMM N-four-bar through the horizontal position
    for n in ((1, 5, 20) if quick else (1, 2, 5, 10, 20, 40)):
        out.append(Scenario("n-four-bar", f"N-four-bar, N = {n}", n_four_bar(n), Class.ACCURATE, "n_four_bar", (n,)))
    # long runs: native must not drift; engines' drift is measured
    turns = 100 if quick else 10_000
    w = 20 * math.pi  # 10 turns per second keeps engine runs affordable
    out.append(Scenario("long-run", f"slider-crank, {turns} crank turns",
                        slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, w]}, 0.5, end=turns / 10, steps=turns * 8),
                        Class.ACCURATE, "slider_crank", (0.5, w, 0.1, 0.3),
                        engine_settings={"*": {"dt": 1e-3}}))
    # mass ratio 1000:1 (engines only: the kinematics ignore masses)
    heavy = slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, 2.0]}, 0.5, end=1.0, steps=100)
    heavy["bodies"]["slider"] = {**heavy["bodies"]["slider"], "mass": 1000.0}
    heavy["bodies"]["crank"] = {**heavy["bodies"]["crank"], "mass": 1.0}
    heavy["bodies"]["rod"] = {**heavy["bodies"]["rod"], "mass": 1.0}
    out.append(Scenario("mass-ratio", "slider-crank, slider 1000 x rod", heavy, Class.ACCURATE, "slider_crank",
                        (0.5, 2.0, 0.1, 0.3)))
    # singular configurations, branches and redundancy (cases/stress/)
    for name, expect in (("slider_dead_centre", Class.SINGULAR), ("rocker_toggle", Class.SINGULAR),
                         ("change_point", Class.ACCURATE), ("coarse_crank", Class.ACCURATE),
                         ("parallelogram_redundant", Class.ACCURATE), ("double_slider", Class.ACCURATE)):
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


def _deviation(model, traj, exact) -> dict:
    """Against the closed form: the largest position error / L and angle
    error (rad), as the figures of the tolerance table."""
    out = {"position_error_rel": 0.0, "angle_error": 0.0}
    for col, ref in exact.items():
        d = traj[col][: len(ref)] - ref[: len(traj)]
        if col.endswith(".phi"):
            out["angle_error"] = max(out["angle_error"], float(np.abs((d + np.pi) % (2 * np.pi) - np.pi).max()))
        else:
            out["position_error_rel"] = max(out["position_error_rel"], float(np.abs(d).max()) / model.length)
    return out


def classify(figures, residual, tolerance, finite=True):
    """(Class, exceeded): figures {name: value} against tolerance {name:
    limit} (the tolerance table's keys; a figure not measured is not judged);
    exceeded lists (figure, value, limit) of those over."""
    if not finite:
        return Class.NAN, ()
    exceeded = tuple((k, figures[k], limit) for k, limit in tolerance.items()
                     if k in figures and not figures[k] <= limit)
    if not exceeded:
        return Class.ACCURATE, ()
    error = max(figures.get("position_error_rel", 0.0), figures.get("angle_error", 0.0))
    if residual <= BRANCH_RESIDUAL and error > BRANCH_ERROR:
        return Class.BRANCH_FLIP, exceeded
    return Class.INACCURATE, exceeded


def judge(model, native, run, exact, tolerance):
    """An engine's ok EngineRun against the native SolveResult (every figure
    of the tolerance table, adapters.compare) and, where one exists, the
    closed form (positions, angles: the larger counts): (Class, figures,
    residual, exceeded)."""
    from adapters.base import Status
    from adapters.compare import FIGURES, compare

    c = compare(model, native, run, tolerance)
    if c.status is Status.NONFINITE:
        return Class.NAN, {}, float("nan"), ()
    figures = {k: getattr(c, k) for k in FIGURES if np.isfinite(getattr(c, k))}
    if exact is not None:
        for k, v in _deviation(model, run.trajectory, exact).items():
            figures[k] = max(figures.get(k, 0.0), v)
    res = model.kinematic_residual(run.q, run.trajectory.t)
    cls, exceeded = classify(figures, res, tolerance)
    return cls, figures, res, exceeded


def _error(figures) -> float:
    return max(figures.get("position_error_rel", float("nan")), figures.get("angle_error", 0.0))


def _over(exceeded) -> str:
    return "; ".join(f"{k} {v:.2e} > {limit:.0e}" for k, v, limit in exceeded)


def run_one(task) -> Outcome:
    """One scenario on one engine (or native)."""
    from .solver import solve
    from .case import load_dict
    from .model import compile
    from .result import Status

    import warnings

    from .errors import KinemWarning

    s, engine = task
    with warnings.catch_warnings():   # its fast and long runs are on purpose
        warnings.simplefilter("ignore", KinemWarning)
        model = compile(load_dict(s.case, source=f"<stress {s.name}>"))
    start = time.perf_counter()
    native = solve(model)
    wall = time.perf_counter() - start
    nan = float("nan")
    row = lambda **k: Row(s.group, s.name, engine, **{"error": nan, "residual": nan, "wall_time": 0.0, **k})
    exact_at = lambda t: _exact(s, t)
    if engine == "native":
        if native.status == Status.SINGULAR:
            return Outcome(Class.SINGULAR, native.message, row(wall_time=wall))
        if not native.success:
            return Outcome(Class.DIVERGED, native.message, row(wall_time=wall))
        t = native.trajectory.t
        finite = bool(np.isfinite(native.trajectory.data).all())
        # without a closed form native is its own reference: no error figure, only its residual
        exact = exact_at(t)
        dev = _deviation(model, native.trajectory, exact) if exact is not None else {}
        err = max(dev.values()) if dev else nan
        res = model.kinematic_residual(native.q, t)
        cls, exceeded = classify(dev, res, dict.fromkeys(dev, NATIVE_TOLERANCE), finite)
        detail = f"{len(native.events)} event(s), {native.substeps} sub-step(s)"
        return Outcome(cls, "; ".join(x for x in (_over(exceeded), detail) if x),
                       row(error=err, residual=res, wall_time=wall, exceeded=exceeded))
    from adapters import get
    from adapters.base import Status
    from adapters.compare import tolerance_of

    adapter = get(engine)
    reason = adapter.unsupported(model)
    if reason:
        return Outcome(Class.UNSUPPORTED, reason, row())
    if not native.success:
        # start the engine from native's t = 0 state anyway, over the instants native reached
        if len(native.trajectory) == 0:
            return Outcome(Class.DIVERGED, "no assembled start", row())
    overrides = s.engine_settings.get(engine, s.engine_settings.get("*", {}))
    run = adapter.run(model, native.q[0], native.qd[0], adapter.settings(overrides))
    if not run.ok:
        kind = Class.NAN if run.status is Status.NONFINITE else Class.DIVERGED
        return Outcome(kind, run.label, row(wall_time=run.wall_time))
    t = run.trajectory.t
    exact = exact_at(t)
    cls, figures, res, exceeded = judge(model, native, run, exact, tolerance_of(adapter))
    detail = "; ".join(x for x in (_over(exceeded), f"{run.steps} steps") if x)
    return Outcome(cls, detail, row(error=_error(figures) if figures else nan, residual=res,
                                    wall_time=run.wall_time, exceeded=exceeded))


def run(engines=None, quick=False, jobs=None, scheduler=None) -> list:
    """Every scenario on every engine asked for; a list of Outcomes in
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


def misses(outcomes, quick=False) -> list:
    """Native's outcomes that are not its expected class: (outcome, expected Class)."""
    want = expected(quick)
    return [(o, want[o.value.scenario]) for o in outcomes
            if o.value.engine == "native" and o.status is not want[o.value.scenario]]


def grid(outcomes):
    """The outcomes as a grid: ([(group, scenario)], {(scenario, engine): outcome})."""
    names = list(dict.fromkeys((o.value.group, o.value.scenario) for o in outcomes))
    return names, {(o.value.scenario, o.value.engine): o for o in outcomes}


SHORT = {"position_error_rel": "pos", "angle_error": "angle", "velocity_error_rel": "vel",
         "angular_velocity_error_rel": "omega", "constraint_residual": "resid"}   # figure names in a cell


def cell(o) -> str:
    """One outcome as text: its class and the figure farthest over its limit
    (named), else its error (the class alone when there is none); '-' (not run)."""
    if o is None:
        return "-"
    if o.value.exceeded:
        k, v, _ = max(o.value.exceeded, key=lambda x: x[1] / x[2])
        return f"{o.status.value} {SHORT.get(k, k)} {v:.0e}"
    e = o.value.error
    return f"{o.status.value} {e:.0e}" if np.isfinite(e) else o.status.value


def table(outcomes, engines) -> str:
    names, by = grid(outcomes)
    width = max(len(n) for _, n in names) + 2
    lines = [f"{'group':26s}{'scenario':{width}s}" + "".join(f"{e:24s}" for e in engines)]
    for g, n in names:
        lines.append(f"{g:26s}{n:{width}s}" + "".join(f"{cell(by.get((n, e))):24s}" for e in engines))
    return "\n".join(lines)
