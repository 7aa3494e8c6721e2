"""One comparison of an engine run against the native solution, used by
``kinem compare``, the tests and the report.

Figures (docs/engines.md):
- position_error: max over instants, bodies and named points of the distance
  between engine and native positions (case units); position_error_rel: the
  same divided by the characteristic length L;
- angle_error: max wrapped difference of body angles (rad);
- velocity_error: max over bodies and points of |v_engine - v_native| (case
  units per second); velocity_error_rel: the same divided by the mechanism's
  characteristic speed (the larger of L max|omega| and max|v| of native);
  angular_velocity_error: max |omega difference| (rad/s);
  angular_velocity_error_rel: the same divided by the run's peak angular
  speed (the characteristic speed / L: max|omega|, or max|v| / L when
  larger, so that a slider's bodies have a scale too);
- constraint_residual: max scaled residual |Phi_k(q_engine, t)| / scale_k of
  the native kinematic (non-driving) constraints on the engine's trajectory,
  i.e. loop-closure drift relative to the mechanism size (docs/solver.md).

Costs are per output interval (``time_per_interval``: the engine's stepping
calls; ``overhead_per_interval``: the adapter's own Python around them) and
per simulated second, whatever the engine's steps per interval.
"""
import enum
from dataclasses import asdict, dataclass, field

import numpy as np

from kinem.fingerprint import compact, kind, scaled

from .base import OutOfTime, Status, limited


class Verdict(enum.Enum):
    """A comparison's judgement; ``value`` is what the CLI, JSON and HTML
    show. One rule everywhere (``kinem compare``, the report's cells, JUnit
    and the gate): the members with ``fails`` fail the run."""
    WITHIN = "within tolerance"
    OUTSIDE = "outside tolerance"
    CAPPED = "cannot reach the tolerance within the cost cap"
    UNSUPPORTED = "unsupported"
    FAILED = "failed"
    OUT_OF_TIME = "out of time"   # stopped at --max-seconds (Status.OUT_OF_TIME): a failure, its cause named
    NONE = ""                     # no tolerance given
    SELF = "no independent reference"                     # native checked only against itself
    CONSISTENT = "consistent with the engines' consensus"  # outside against native, but native is the one off
    DISAGREES = "native disagrees with the engines' consensus"

    @property
    def fails(self) -> bool:
        return self in (Verdict.OUTSIDE, Verdict.CAPPED, Verdict.FAILED, Verdict.OUT_OF_TIME, Verdict.DISAGREES)


@dataclass(frozen=True)
class Comparison:
    engine: str
    status: Status
    detail: str = ""
    position_error: float = float("nan")
    position_error_rel: float = float("nan")
    angle_error: float = float("nan")
    velocity_error: float = float("nan")
    velocity_error_rel: float = float("nan")
    angular_velocity_error: float = float("nan")
    angular_velocity_error_rel: float = float("nan")
    acceleration_error_rel: float = float("nan")   # native against its closed form (adapters.references) only
    constraint_residual: float = float("nan")
    wall_time: float = float("nan")
    steps: int = 0
    time_per_step: float = float("nan")
    substeps: int = 0                      # engine steps per output interval
    time_per_interval: float = float("nan")
    overhead_per_interval: float = float("nan")
    time_per_sim_second: float = float("nan")
    within_tolerance: bool | None = None  # None: not applicable (unsupported)
    tolerance: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    version: str = ""
    notes: tuple = ()                      # what the adapter decided on its own (EngineRun.notes)
    estimate: dict = field(default_factory=dict)   # the engine's own error figures (EngineRun.estimate)
    capped: bool = False                   # its self-check still missed the tolerance at the cost cap
    attributed: "Consensus | None" = None  # engines agree, native disagrees (``consensus``)
    independent: bool = True               # native: checked against something else than itself
    intervals: int = 0                     # output intervals simulated
    compact: dict | None = field(default=None, repr=False, compare=False)   # kinem.fingerprint.compact

    @property
    def verdict(self) -> Verdict:
        if self.status is Status.UNSUPPORTED:
            return Verdict.UNSUPPORTED
        if self.status is Status.OUT_OF_TIME:
            return Verdict.OUT_OF_TIME
        if self.status is not Status.OK:
            return Verdict.FAILED
        if self.engine == "native":
            if self.attributed is not None:
                return Verdict.DISAGREES
            if not self.independent:
                return Verdict.SELF
            return Verdict.WITHIN if self.within_tolerance else Verdict.OUTSIDE
        if self.within_tolerance is None:
            return Verdict.NONE
        if self.within_tolerance:
            return Verdict.WITHIN
        if self.attributed is not None:
            return Verdict.CONSISTENT
        return Verdict.CAPPED if self.capped else Verdict.OUTSIDE

    @property
    def steps_per_interval(self) -> float:
        """Engine steps per output interval, every attempt counted (refinements included)."""
        return self.steps / self.intervals if self.intervals else float(self.substeps)

    @property
    def cost_per_interval(self) -> float:
        """The whole run's wall time per output interval: stepping and the adapter's own Python."""
        return self.time_per_interval + (self.overhead_per_interval if np.isfinite(self.overhead_per_interval)
                                         else 0.0)

    @property
    def verdict_text(self) -> str:
        """The verdict with what it rests on: the figures over their limits
        (and, at the cost cap, what the best reached cost)."""
        v = self.verdict
        if v in (Verdict.OUTSIDE, Verdict.CAPPED):
            over = "; ".join(f"{k} {x:.2e} > {limit:.0e}" for k, x, limit in self.exceeded)
            cost = f" ({self.substeps} steps per interval, {1e6 * self.time_per_interval:.3g} us per interval)"
            return f"{v.value}: {over}" + (cost if v is Verdict.CAPPED else "")
        if v is Verdict.WITHIN and self.engine != "native":
            return f"{v.value} at {self.steps_per_interval:.3g} steps per interval (every attempt)"
        if v in (Verdict.DISAGREES, Verdict.CONSISTENT):
            return f"{v.value}: {self.attributed.text}"
        return v.value

    @property
    def label(self) -> str:
        return self.status.label(self.detail)

    @property
    def ok(self) -> bool:
        return self.status is Status.OK

    @property
    def exceeded(self) -> tuple:
        """(figure, value, limit) of every figure above its tolerance."""
        return tuple((k, getattr(self, k), v) for k, v in self.tolerance.items() if getattr(self, k) > v)

    def as_dict(self) -> dict:
        """JSON-ready: ``status`` the one-string label, ``outcome`` its kind."""
        d = {k: v for k, v in asdict(self).items() if k not in ("detail", "compact")}
        d["attributed"] = None if self.attributed is None else asdict(self.attributed)
        d = dict(d, status=self.label, outcome=self.status.value, verdict=self.verdict.value,
                 verdict_text=self.verdict_text, steps_per_interval=self.steps_per_interval,
                 cost_per_interval=self.cost_per_interval,
                 exceeded=[{"figure": k, "value": x, "limit": limit} for k, x, limit in self.exceeded])
        # a figure not computed is null, never NaN (no JSON number): a row not run has no cost either
        return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in d.items()}


FIGURES = ("position_error", "position_error_rel", "angle_error", "velocity_error", "velocity_error_rel",
           "angular_velocity_error", "angular_velocity_error_rel", "constraint_residual")


def _xy(traj, names):
    return np.stack([traj[f"{n}.x"] + 1j * traj[f"{n}.y"] for n in names], axis=1)


def _vxy(traj, names):
    return np.stack([traj[f"{n}.vx"] + 1j * traj[f"{n}.vy"] for n in names], axis=1)


def speed(model, traj) -> float:
    """The run's peak speed V = max(L max|omega|, max|v|) over bodies and
    named points (the scale of velocities; V / L of angular velocities)."""
    items = list(model.body_names) + list(model.point_names)
    v = np.abs(_vxy(traj, items)).max()
    w = max(float(np.abs(traj[f"{b}.omega"]).max()) for b in model.body_names)
    return max(model.length * w, float(v), 1e-300)


def errors(model, native, q, traj) -> dict:
    """Error figures of a trajectory (q raw coordinates, traj named columns)
    against the native SolveResult, over the instants both have."""
    nt = min(len(traj), len(native.trajectory))
    ref = native.trajectory
    items = list(model.body_names) + list(model.point_names)
    pos = np.abs(_xy(traj, items)[:nt] - _xy(ref, items)[:nt]).max()
    bodies = model.body_names
    dphi = np.stack([traj[f"{b}.phi"][:nt] - ref[f"{b}.phi"][:nt] for b in bodies])
    angle = np.abs((dphi + np.pi) % (2 * np.pi) - np.pi).max()
    out = {"position_error": float(pos), "position_error_rel": float(pos / model.length), "angle_error": float(angle)}
    if f"{bodies[0]}.vx" in traj and f"{bodies[0]}.vx" in ref:
        v_ref = _vxy(ref, items)[:nt]
        out["velocity_error"] = float(np.abs(_vxy(traj, items)[:nt] - v_ref).max())
        w_ref = np.stack([ref[f"{b}.omega"][:nt] for b in bodies])
        v = speed(model, ref)
        out["velocity_error_rel"] = out["velocity_error"] / v
        dw = np.stack([traj[f"{b}.omega"][:nt] for b in bodies]) - w_ref
        out["angular_velocity_error"] = float(np.abs(dw).max())
        out["angular_velocity_error_rel"] = out["angular_velocity_error"] * model.length / v
    out["constraint_residual"] = model.kinematic_residual(q[:nt], ref.t[:nt])
    return out


FIGURE_OF = {"position": "position_error_rel", "angle": "angle_error", "velocity": "velocity_error_rel",
             "angular_velocity": "angular_velocity_error_rel"}   # a column's kind -> its judged figure


@dataclass(frozen=True)
class Consensus:
    """Two or more engines agree with each other within their tolerances and
    all disagree with native the same way: native is the one off."""
    figure: str          # the judged figure (FIGURE_OF), e.g. velocity_error_rel
    value: float         # native against the engines' mean, scale-free
    column: str          # where it is largest
    t: float | None
    engines: tuple       # the engines that agree
    spread: float        # their largest disagreement with each other, same unit

    @property
    def text(self) -> str:
        when = "" if self.t is None else f" at t = {self.t:.6g} s"
        return (f"{self.figure} {self.value:.2e} ({self.column}{when}) against {', '.join(self.engines)}, "
                f"which agree within {self.spread:.1e}")


def consensus(trajectories, tolerances, figures, length, v) -> Consensus | None:
    """Whether native disagrees with the engines' consensus, from the runs'
    trajectories at the same instants (``{engine: {"t": [...], "columns":
    {name: values}}}``, native's included), their tolerances and their
    figures against native. For one judged figure, it holds when at least
    two engines (those with a tolerance on it and a trajectory) agree with
    each other within the sum of their tolerances at every instant and
    column, each is outside its own tolerance against native, and native
    lies further from their mean than any of them. The figure returned is
    the one native is furthest off, relative to the tightest limit."""
    native = trajectories.get("native")
    if native is None:
        return None
    best, ratio = None, 0.0
    for k, fig in FIGURE_OF.items():
        names = [e for e in trajectories if e != "native" and fig in (tolerances.get(e) or {})
                 and (figures.get(e) or {}).get(fig) is not None]
        if len(names) < 2 or any(figures[e][fig] <= tolerances[e][fig] for e in names):
            continue
        cols = [c for c in native["columns"] if kind(c) == k and all(c in trajectories[e]["columns"] for e in names)]
        if not cols:
            continue
        runs = {e: {c: np.asarray(trajectories[e]["columns"][c], float) for c in cols} for e in names}
        spread, agree = 0.0, True
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                d = max(float(scaled(c, runs[a][c] - runs[b][c], length, v).max()) for c in cols)
                spread = max(spread, d)
                agree &= d <= tolerances[a][fig] + tolerances[b][fig]
        if not agree:
            continue
        mean = {c: np.mean([runs[e][c] for e in names], axis=0) for c in cols}
        off = {c: scaled(c, np.asarray(native["columns"][c], float) - mean[c], length, v) for c in cols}
        column = max(cols, key=lambda c: off[c].max())
        value = float(off[column].max())
        cloud = max(float(scaled(c, runs[e][c] - mean[c], length, v).max()) for e in names for c in cols)
        limit = min(tolerances[e][fig] for e in names)
        if value <= max(cloud, limit) or value / limit <= ratio:
            continue
        at = int(np.argmax(off[column]))
        t = native.get("t")
        best, ratio = Consensus(fig, value, column, None if t is None else float(t[at]), tuple(names), spread), \
            value / limit
    return best


def costs(run, end) -> dict:
    """An EngineRun's cost figures: per engine step, per output interval, per simulated second."""
    n = max(run.intervals, 1)
    return dict(wall_time=run.wall_time, steps=run.steps, substeps=run.substeps, intervals=run.intervals,
                time_per_step=run.wall_time / max(run.steps, 1), time_per_interval=run.wall_time / n,
                overhead_per_interval=run.overhead / n,
                time_per_sim_second=run.wall_time / end if end else float("nan"))


def compare(model, native, run, tolerance=None) -> Comparison:
    """An EngineRun against the native SolveResult. tolerance: dict of limits
    on the figures (keys: FIGURES; None: no verdict)."""
    unknown = set(tolerance or {}) - set(FIGURES)
    if unknown:
        raise ValueError(f"{run.engine}: tolerance on unknown figures {sorted(unknown)}; figures: {FIGURES}")
    base = dict(engine=run.engine, status=run.status, detail=run.detail, settings=dict(run.settings),
                version=run.version, tolerance=dict(tolerance or {}), notes=tuple(run.notes),
                estimate=dict(run.estimate), capped=bool(run.capped),
                **costs(run, model.case.end))
    if run.status is Status.UNSUPPORTED:
        return Comparison(**base)
    if not run.ok:
        return Comparison(**base, within_tolerance=False)
    e = errors(model, native, run.q, run.trajectory)
    if not all(np.isfinite(v) for v in e.values()):
        return Comparison(**dict(base, status=Status.NONFINITE, detail="non-finite trajectory"),
                          within_tolerance=False)
    within = all(e.get(k, 0.0) <= v for k, v in (tolerance or {}).items())
    return Comparison(**base, **e, within_tolerance=within, compact=compact(model, run.trajectory))


def attribute(model, native, rows) -> list:
    """rows with the engines' consensus applied (``consensus``): when it
    holds, native's row DISAGREES and the agreeing engines' rows are
    CONSISTENT (both carry the Consensus). native: the native SolveResult."""
    from dataclasses import replace

    ok = [r for r in rows if r.engine != "native" and r.ok and r.compact is not None]
    if len(ok) < 2:   # no consensus without two engines (``consensus``): native's columns are not made for it
        return list(rows)
    trajs = {"native": compact(model, native.trajectory), **{r.engine: r.compact for r in ok}}
    c = consensus(trajs, {r.engine: r.tolerance for r in ok}, {r.engine: asdict(r) for r in ok},
                  model.length, speed(model, native.trajectory))
    if c is None:
        return list(rows)
    return [replace(r, attributed=c) if r.engine == "native" or r.engine in c.engines else r for r in rows]


def native_row(model, native, options=None) -> Comparison:
    """The native solver's own row: its residual, wall time and instants
    (an output interval is one native step), the options it was solved
    with (kinem.Options; default the case's), and its figures against the
    case's closed form where it has one (adapters.references: positions,
    velocities and accelerations within references.LIMITS, the last named
    in the detail), else no figure: nothing independent checked it
    (Verdict.SELF), never a zero against itself. The closed form is not
    begun past options.max_seconds (``engines_deadline``): the row is then
    out of time (Status.OUT_OF_TIME), its figures not computed."""
    import time

    from kinem.budget import out_of_time
    from kinem.linalg import choose
    from kinem.options import Options
    from kinem.result import Status as SolveStatus

    from .references import CLOSED_FORMS, LIMITS, closed_form, error

    options = Options.of(model.case) if options is None else options
    res = model.kinematic_residual(native.q, native.trajectory.t)
    steps = len(native.iterations)
    n = max(steps - 1, 1)
    limit = engines_deadline(options)
    late = native.success and model.case.name in CLOSED_FORMS and limit is not None and time.time() > limit[1]
    cf = None
    checked, detail, within = {}, "" if native.success else native.message, native.success
    if late:
        detail, within = f"{out_of_time(limit[0])} before its check against the closed form", False
    elif native.success:
        try:
            with limited(limit):   # a closed form that loops over the instants looks at it (in_time)
                cf = closed_form(model, native)
        except OutOfTime as e:
            late, detail, within = True, f"{e.detail} of its check against the closed form", False
    if cf is not None:
        f = error(model, native.trajectory, cf)
        # the report's limits (LIMITS' keys are results.json's) on this row's own figures
        limits = {"position_error_rel": LIMITS["position_error_rel"],
                  "velocity_error_rel": LIMITS["reference_velocity_error_rel"],
                  "acceleration_error_rel": LIMITS["reference_acceleration_error_rel"]}
        checked = dict(position_error=f.position, position_error_rel=f.position_rel, velocity_error=f.velocity,
                       velocity_error_rel=f.velocity_rel, acceleration_error_rel=f.acceleration_rel,
                       tolerance=limits)
        within = all(checked[k] <= limit for k, limit in limits.items())
        detail = f"against the {cf.label}; accelerations {f.acceleration_rel:.2e} of the peak"
    late = late or native.status is SolveStatus.OUT_OF_TIME   # native's own solve stopped by the limit
    return Comparison(engine="native", status=Status.OUT_OF_TIME if late else
                      Status.OK if native.success else Status.FAILED,
                      detail=detail, independent=cf is not None, intervals=n,
                      constraint_residual=res, wall_time=native.wall_time, steps=steps, substeps=1,
                      time_per_step=native.wall_time / max(steps, 1), time_per_interval=native.wall_time / n,
                      overhead_per_interval=0.0, time_per_sim_second=native.wall_time / model.case.end,
                      within_tolerance=within,
                      settings={"tolerance": options.tolerance, "max_iterations": options.max_iterations,
                                "linear_solver": "sparse" if choose(model, options).sparse else "dense"},
                      **checked)


def tolerance_of(adapter) -> dict:
    """The adapter's documented tolerance (limits on the figures above)."""
    return dict(adapter.tolerance)


def run_engine(model, native, name, overrides=None, limit=None) -> Comparison:
    """Builds, runs and compares one engine. Settings: the adapter's defaults,
    then the case's [engines.<name>] table, then ``overrides``; ``limit``:
    the run's time limit (adapters.base.Adapter.run)."""
    from . import case_settings, get

    adapter = get(name)
    reason = adapter.unsupported(model)
    if reason:
        return Comparison(engine=name, status=Status.UNSUPPORTED, detail=reason, version=adapter.version())
    run = adapter.run(model, settings=case_settings(model, name, overrides), limit=limit)   # its own start
    return compare(model, native, run, tolerance_of(adapter))


def _run_engine(task):
    return run_engine(*task)


def engines_deadline(options):
    """The engines' runs' share of ``options.max_seconds`` (counted from
    options.started, as native's solves): (seconds, the time.time() instant
    it ends; the same on a Dask worker of this machine) or None."""
    import time

    if options is None or options.max_seconds is None:
        return None
    started = options.started if options.started is not None else time.perf_counter()
    return options.max_seconds, time.time() + started + options.max_seconds - time.perf_counter()


def run_case(model, engines, overrides=None, scheduler=None, options=None):
    """Native solution (solved with ``options``, kinem.Options; default the
    case's) and one Comparison per engine ('native' included when asked);
    the engines' runs end at options.max_seconds too (``engines_deadline``).
    overrides: engine name -> settings. The engines run in this process, or
    on the workers of a Dask scheduler (an address)."""
    from kinem import parallel
    from kinem.budget import check_solutions
    from kinem.solver import solve

    from . import check_case

    check_case(model.case)
    if scheduler is not None:   # its form before native's solve; it is connected to when the engines' runs begin
        parallel.check_address(scheduler)
    check_solutions(model, 1 + sum(n != "native" for n in engines), "compare", "fewer instants (--steps) or engines")
    native = solve(model, options=options)
    limit = engines_deadline(options)
    todo = [(model, native, n, (overrides or {}).get(n), limit) for n in engines if n != "native" and native.success]
    done = iter(parallel.map(_run_engine, todo, jobs=0, scheduler=scheduler))
    rows = []
    for name in engines:
        if name == "native":
            rows.append(native_row(model, native, options))
        elif not native.success:
            rows.append(Comparison(engine=name, status=Status.FAILED, detail=f"no native reference ({native.message})"))
        else:
            rows.append(next(done))
    return native, attribute(model, native, rows) if native.success else rows


def table(case_name, length, unit, rows) -> str:
    head = (f"case {case_name} (L = {length:.4g} {unit})".rstrip() + "\n"
            f"{'engine':8s} {'status':10s} {'pos err':>9s} {'pos/L':>9s} {'angle':>9s} {'vel/V':>9s} "
            f"{'omega/W':>9s} {'resid':>9s} {'steps/out':>9s} {'us/out':>8s} {'stepping':>8s}  verdict")
    lines = [head]
    for r in rows:
        if r.status is not Status.OK:
            lines.append(f"{r.engine:8s} {r.label}")
            continue
        figures = [r.position_error, r.position_error_rel, r.angle_error, r.velocity_error_rel,
                   r.angular_velocity_error_rel]
        shown = (" ".join("      n/a" if x != x else f"{x:9.2e}" for x in figures)
                 if r.engine != "native" or r.independent else f"{'(' + Verdict.SELF.value + ')':49s}")
        lines.append(f"{r.engine:8s} {r.label:10s} {shown} "
                     f"{r.constraint_residual:9.2e} {r.steps_per_interval:9.3g} {1e6 * r.cost_per_interval:8.1f} "
                     f"{1e6 * r.time_per_interval:8.1f}  {r.verdict_text}")
        lines += [f"{'':8s} note: {n}" for n in r.notes]
        if r.engine == "native" and r.independent:
            lines.append(f"{'':8s} note: {r.detail}")
    lines.append("vel/V, omega/W: velocity and angular-velocity errors over the run's peak speed V and peak "
                 "angular speed W (docs/engines.md, Tolerances); native against the case's closed form "
                 "(adapters.references; angles as the arc they move a point at L, so 'angle' is n/a), else "
                 "no independent reference here (kinem report also uses equivalence groups and the engines' "
                 "consensus); steps/out: engine steps per output interval, every attempt counted; us/out: the "
                 "whole run's wall time per output interval (the adapter's Python included; native: one solve "
                 "per output instant); stepping: the engine's stepping calls alone")
    return "\n".join(lines)
