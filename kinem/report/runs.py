"""One run of the report: a case on the native solver or on one engine, at
its default settings (the "main" run) or at one point of the work-precision
sweep. ``run_task`` executes in a worker process and returns a plain dict
(picklable, JSON-ready apart from the plot series); engines are imported only
there.

Every figure is measured against the reference solution: the native solver
at REFERENCE_TOLERANCE (cached per process and case file).
"""
import dataclasses
import statistics
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from adapters.base import Reason, Status

from ..outcome import Kind
from ..fingerprint import compact

REFERENCE_TOLERANCE = 1e-13  # scaled residual; about 500 machine epsilons of L
REFERENCE_LABEL = "native at the reference tolerance"  # what a run's figures are against, unless it says otherwise


class Reference(Kind):
    """What a run's position figures are against (results.json
    "reference_kind"; "reference" names it in full)."""
    NATIVE = ("native", REFERENCE_LABEL)
    CLOSED_FORM = ("closed-form", "a closed form of kinem.reference")
    GROUP = ("equivalence", "the case's equivalence group")

FRAMES = 120                 # instants of the animation (native and every engine at the same ones)
PATH_INSTANTS = 480          # instants of the named points' paths drawn in the plane
ERROR_KEYS = ("position_error", "position_error_rel", "angle_error", "velocity_error", "velocity_error_rel",
              "angular_velocity_error", "angular_velocity_error_rel", "constraint_residual")   # adapters.compare.FIGURES
# native's rates against its closed form (adapters.references): velocities, accelerations / the peak
INDEPENDENT_KEYS = ("reference_velocity_error", "reference_velocity_error_rel", "reference_acceleration_error",
                    "reference_acceleration_error_rel")


@dataclass(frozen=True)
class Task:
    path: str
    engine: str                 # "native" or an engine of the registry (adapters.REGISTRY)
    knob: str | None = None     # None: main run; "tolerance" (native) or "dt" (engines): a sweep point
    value: float | None = None
    repeats: int = 1            # native runs timed; the median wall time is kept
    point: tuple = ()           # engines: sorted (key, value) overrides of a sweep point over several knobs
                                # (its knob family and dt); empty: the knob alone, on the defaults


def _model(path):
    from kinem.case import load
    from kinem.model import compile

    return compile(load(path))


@lru_cache(maxsize=8)
def reference(path):
    """(model at the case's tolerance, reference SolveResult, its tolerance).
    Falls back to the case's own tolerance when 1e-13 cannot be reached."""
    from kinem.solver import solve

    from kinem.options import Options

    model = _model(path)
    ref = solve(model, options=dataclasses.replace(Options.of(model.case), tolerance=REFERENCE_TOLERANCE))
    if ref.success:
        return model, ref, REFERENCE_TOLERANCE
    return model, solve(model), Options.of(model.case).tolerance


def _blank(task, outcome, detail="", **extra):
    """A run's row: outcome an adapters.base.Status (its value is stored as
    ``outcome``; ``status`` is the one-string label shown to people)."""
    status = outcome.label(detail)
    reason = [detail.kind, detail.why] if isinstance(detail, Reason) else None
    out = {"engine": task.engine, "knob": task.knob, "value": task.value, "status": status,
           "outcome": outcome.value, "detail": detail,
           "requested": {}, "settings": {}, "version": "", "within_tolerance": None, "tolerance": {},
           "wall_time": None, "time_per_step": None, "time_per_interval": None, "overhead_per_interval": None,
           "cost_per_interval": None, "steps_per_interval": None,
           "wall_per_sim_second": None, "counts": {}, "reference": REFERENCE_LABEL,
           "reference_kind": Reference.NATIVE.value,
           "knobs": dict(task.point) or ({task.knob: task.value} if task.knob else {}), "trajectory": None,
           "verdict": _verdict_of(outcome), "estimate": {}, "reason": reason, "attributed": None}
    out.update({k: None for k in ERROR_KEYS + INDEPENDENT_KEYS})
    out.update(extra)
    return out


def _verdict_of(outcome):
    """A run's verdict before any comparison (adapters.compare.Verdict values)."""
    from adapters.compare import Verdict

    if outcome is Status.UNSUPPORTED:
        return Verdict.UNSUPPORTED.value
    if outcome is Status.OUT_OF_TIME:
        return Verdict.OUT_OF_TIME.value
    return Verdict.FAILED.value if outcome.failure else Verdict.NONE.value


def _finite(x):
    return float(x) if x is not None and np.isfinite(x) else None


def key_columns(model):
    """The trajectory columns plotted: x and y of every moving named point the
    report draws (drawing.plotted_points), else x, y and phi of every moving body."""
    from adapters.base import grounded

    from .drawing import plotted_points

    fixed = grounded(model)
    items = [p.name for p in plotted_points(model) if p.body not in fixed]
    if items:
        return [f"{n}.{c}" for n in items for c in ("x", "y")]
    return [f"{b}.{c}" for b in model.body_names if b not in fixed for c in ("x", "y", "phi")]


def sample(n, limit):
    """Indices of at most ``limit`` instants spread evenly over n, first and last included."""
    return np.unique(np.round(np.linspace(0, n - 1, min(n, limit))).astype(int))


def error_series(model, ref, traj):
    """Position error per instant: max over bodies and named points of the
    distance to the reference, divided by L."""
    nt = min(len(traj), len(ref.trajectory))
    items = list(model.body_names) + list(model.point_names)
    xy = [np.abs((traj[f"{n}.x"][:nt] - ref.trajectory[f"{n}.x"][:nt])
                 + 1j * (traj[f"{n}.y"][:nt] - ref.trajectory[f"{n}.y"][:nt])) for n in items]
    return (np.max(xy, axis=0) / model.length).tolist()


def _series(model, ref, traj, q, with_reference=False):
    """What the page draws of one run: the key columns, the error per instant,
    the coordinates at the animation's frames (and, for native, the reference's
    key columns and the denser coordinates the point paths are drawn from)."""
    cols = key_columns(model)
    q = np.asarray(q)
    idx = sample(len(q), FRAMES)
    out = {"t": traj.t.tolist(), "error": error_series(model, ref, traj),
           "columns": {c: traj[c].tolist() for c in cols},
           "frames": {"t": traj.t[idx].tolist(), "q": q[idx].tolist()}}
    if with_reference:
        out["reference"] = {c: ref.trajectory[c].tolist() for c in cols}
        out["path_q"] = q[sample(len(q), PATH_INSTANTS)].tolist()
    return out


def run_native(task):
    from adapters.compare import Verdict, errors, speed
    from kinem.solver import solve

    from ..linalg import choose
    from ..march import usable
    from ..options import Options

    model, ref, ref_tol = reference(task.path)
    options = Options.of(model.case)
    if task.knob is not None:   # a tolerance of the sweep: the same model, other options
        options = dataclasses.replace(options, tolerance=task.value)
    walls, r = [], None
    for _ in range(max(1, task.repeats)):
        r = solve(model, options=options)
        walls.append(r.wall_time)
    wall = statistics.median(walls)
    steps = len(r.iterations)
    settings = {"tolerance": options.tolerance, "max_iterations": options.max_iterations,
                "linear_solver": "sparse" if choose(model, options).sparse else "dense",
                "block": options.block if usable(model, False, len(model.times), options) else 1}
    counts = {"instants": steps, "newton_iterations": int(r.iterations.sum()),
              "jacobian_evaluations": int(r.jacobian_evaluations), "factorizations": int(r.factorizations)}
    base = dict(requested=settings, settings=settings, version=_version("kinem"), counts=counts, wall_time=wall,
                knobs={"tolerance": options.tolerance},
                repeats=len(walls), time_per_step=wall / max(steps, 1), time_per_interval=wall / max(steps - 1, 1),
                overhead_per_interval=0.0, cost_per_interval=wall / max(steps - 1, 1), steps_per_interval=1.0,
                wall_per_sim_second=wall / model.case.end)
    if not r.success:
        return _blank(task, Status.FAILED, r.message, **base)
    e = errors(model, ref, r.q, r.trajectory)
    out = _blank(task, Status.OK, **base, **{k: _finite(e.get(k)) for k in ERROR_KEYS})
    out["within_tolerance"] = True
    out["verdict"] = Verdict.WITHIN.value if task.knob is not None else Verdict.SELF.value
    if task.knob is None:
        out["trajectory"] = compact(model, r.trajectory)
        out["speed"] = speed(model, ref.trajectory)
        out["series"] = _series(model, ref, r.trajectory, r.q, with_reference=True)
        out["reference_tolerance"] = ref_tol
        _independent(model, ref, r.trajectory, out)
    return out


def _independent(model, ref, traj, out):
    """The main native run against the case's closed form
    (adapters.references) where it has one: its positions (or bodies'
    coordinates), velocities and accelerations, each within its limit
    (references.LIMITS) or the verdict is outside tolerance, the figure
    named; the named points of its equivalence group into the series
    (kinem.report.equivalence)."""
    from adapters.compare import Verdict

    from adapters.references import LIMITS, closed_form, error

    cf = closed_form(model, ref)
    if cf is not None:
        f = error(model, traj, cf)
        out.update(position_error=_finite(f.position), position_error_rel=_finite(f.position_rel),
                   reference_velocity_error=_finite(f.velocity), reference_velocity_error_rel=_finite(f.velocity_rel),
                   reference_acceleration_error=_finite(f.acceleration),
                   reference_acceleration_error_rel=_finite(f.acceleration_rel),
                   reference=cf.label, reference_kind=Reference.CLOSED_FORM.value, tolerance=dict(LIMITS))
        within = all(out[k] is not None and out[k] <= limit for k, limit in LIMITS.items())
        out.update(within_tolerance=within, verdict=(Verdict.WITHIN if within else Verdict.OUTSIDE).value)
    eq = model.case.equivalent
    if eq is not None:
        pick = lambda tr: {n: [tr[f"{n}.x"].tolist(), tr[f"{n}.y"].tolist()] for n in eq.points}  # noqa: E731
        out["series"]["points"] = {"t": ref.trajectory.t.tolist(), "reference": pick(ref.trajectory),
                                   "run": pick(traj)}


def run_engine(task):
    from adapters import case_settings, get
    from adapters.compare import compare, tolerance_of

    try:
        adapter = get(task.engine)
        version = adapter.version()
    except Exception as e:  # noqa: BLE001 - a missing or broken adapter is a report row, not a crash
        return _blank(task, Status.FAILED, f"import error: {type(e).__name__}: {e}", import_failed=True)
    model, ref, _ = reference(task.path)
    if not ref.success:
        return _blank(task, Status.FAILED, "no native reference (" + ref.message + ")", version=version)
    reason = adapter.unsupported(model)
    if reason:
        return _blank(task, Status.UNSUPPORTED, reason, version=version)
    overrides = dict(task.point)
    if task.knob is not None and not overrides:
        overrides[task.knob] = task.value
    settings = case_settings(model, task.engine, overrides)
    try:
        run = adapter.run(model, settings=settings)   # its own start (adapters.base.start), not native's
    except Exception as e:  # noqa: BLE001 - adapters should not raise; record it if one does
        return _blank(task, Status.FAILED, f"{type(e).__name__}: {e}", version=version, requested=_plain(settings),
                      knobs=_knobs(adapter, settings, settings))
    c = compare(model, ref, run, tolerance_of(adapter))
    out = _blank(task, c.status, c.detail, version=run.version or version, requested=_plain(settings),
                 settings=_plain(run.settings or settings),
                 within_tolerance=c.within_tolerance, tolerance=_plain(c.tolerance),
                 wall_time=_finite(run.wall_time), counts={"steps": int(run.steps), "substeps": int(run.substeps)})
    out["time_per_step"] = _finite(run.wall_time / run.steps) if run.steps else None
    out["time_per_interval"] = _finite(c.time_per_interval)
    out["overhead_per_interval"] = _finite(c.overhead_per_interval)
    out["cost_per_interval"] = _finite(c.cost_per_interval)
    out["steps_per_interval"] = _finite(c.steps_per_interval)
    out["wall_per_sim_second"] = _finite(run.wall_time / model.case.end)
    out["knobs"] = _knobs(adapter, settings, run.settings or settings)
    out["verdict"] = c.verdict.value
    out["estimate"] = {k: _finite(v) for k, v in c.estimate.items()}
    if task.knob is None:   # the main run: the knob families its sweep covers (adapters.tune)
        from adapters.tune import families

        out["families"] = [_plain(f) for f in families(adapter, run.settings or settings)]
    if c.status is Status.OK:
        out.update({k: _finite(getattr(c, k)) for k in ERROR_KEYS})
        if task.knob is None:
            out["trajectory"] = c.compact
            out["series"] = _series(model, ref, run.trajectory, run.q)
    return out


def step(r):
    """An engine row's step dt: the requested one, or the one the engine
    resolved (dt = "auto"); None without either."""
    for dt in ((r.get("requested") or {}).get("dt"), (r.get("settings") or {}).get("dt")):
        if isinstance(dt, (int, float)) and not isinstance(dt, bool):
            return dt
    return None


def _knobs(adapter, requested, used):
    """A run's full knob setting: the requested step dt and the values of the
    adapter's other accuracy knobs (adapters.tune.families) it ran with, or
    "auto" where it was asked to choose."""
    from adapters.tune import STEP_KNOB

    out = {"dt": requested.get("dt")}
    # a knob asked as "auto" stays "auto": the value it resolved to (after a retry, say pymunk's 100
    # iterations) would make the point look like the explicit family of that value, and the gate would
    # compare a run of two attempts with a run of one
    out.update({k: "auto" if requested.get(k) == "auto" else used.get(k) for k in adapter.knobs if k != STEP_KNOB})
    return _plain(out)


def run_task(task: Task) -> dict:
    """Runs one task; never raises (an unexpected error is a failed row)."""
    start = time.perf_counter()
    try:
        out = run_native(task) if task.engine == "native" else run_engine(task)
    except Exception as e:  # noqa: BLE001
        out = _blank(task, Status.FAILED, f"internal error: {type(e).__name__}: {e}")
    out["path"] = task.path
    out["elapsed"] = time.perf_counter() - start
    return out


def _plain(d):
    """Settings as JSON values (tuples to lists, numpy scalars to floats)."""
    def conv(v):
        if isinstance(v, dict):
            return {str(k): conv(x) for k, x in v.items()}
        if isinstance(v, (list, tuple, np.ndarray)):
            return [conv(x) for x in v]
        if isinstance(v, np.generic):
            return v.item()
        return v if isinstance(v, (str, int, float, bool)) or v is None else str(v)
    return conv(dict(d or {}))


def _version(name):
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return ""
