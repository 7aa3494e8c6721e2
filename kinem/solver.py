"""``solve``: the analysis of a compiled Model over its output instants
(docs/solver.md), on top of the stages (kinem.analysis), the tracker
(kinem.tracking) and the march (kinem.march, the compiled core's loop); nothing below imports
it. Its options (kinem.options.Options) are passed to it, not compiled into
the Model: changing a tolerance never recompiles. kinem.front's ``solve``
(``kinem.solve``) sits above it and kinem.variants, and dispatches to either."""
import math
import time

import numpy as np

from . import native
from .analysis import Data
from .budget import Budget
from .branches import pins, violation
from .diagnose import contact_hint, explain_assembly
from .errors import AnalysisError, InputError, OutOfTimeError, SingularError, WorkLimitError
from .linalg import choose
from .march import March, usable
from .margins import MARGINS, margins
from .model import Model
from .options import Options
from .result import OUTPUTS, SolveResult, Status, Trajectory, stacked, trajectory
from .tracking import Tracker

def _floats(name, value, expected):
    """value as a float array (InputError naming ``name`` otherwise)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):   # (OverflowError: a whole number no float holds)
        raise InputError(f"solve: {name} {value!r:.80}: expected {expected}") from None


def _checked_times(times):
    """times as a float array: one or more finite, strictly increasing instants (InputError otherwise)."""
    if times is None:
        return None
    if type(times) is np.ndarray and times.dtype == np.float64 and times.ndim == 1 and native.increasing(times):
        return times   # the usual call: checked in one pass by the core
    t = _floats("times", times, "a sequence of numbers")
    # increasing strictly between finite ends: every instant finite (a NaN fails the comparison)
    if t.ndim == 1 and len(t) and math.isfinite(t[0]) and math.isfinite(t[-1]) and \
            np.count_nonzero(t[1:] > t[:-1]) == len(t) - 1:
        return t
    if t.ndim != 1 or not len(t) or not np.isfinite(t).all():
        raise InputError(f"solve: times of shape {t.shape}: expected one or more finite instants in a 1-D sequence")
    if len(t) > 1 and not (t[1:] > t[:-1]).all():
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise InputError(f"solve: times must increase strictly: times[{k + 1}] = {t[k + 1]:g} "
                         f"after times[{k}] = {t[k]:g}")
    return t


def _checked_model(model, what="solve") -> None:
    """InputError unless model is a compiled kinem.Model (``what``: the function it was given to)."""
    if not isinstance(model, Model):
        raise InputError(f"{what}: model {type(model).__name__}: expected a kinem.Model (kinem.compile(case))")


def _checked_q0(model, q0):
    """q0 as n finite floats (InputError otherwise), or None."""
    if q0 is None:
        return None
    q = _floats("q0", q0, f"{model.n} numbers")
    if q.shape != (model.n,) or not np.isfinite(q).all():
        raise InputError(f"solve: q0 of shape {q.shape}: expected {model.n} finite numbers (the model's coordinates)")
    return q


def solve(model, outputs=OUTPUTS, times=None, trace=False, options: Options | None = None,
          q0=None) -> SolveResult:
    """Position (and, when asked, velocity and acceleration) analysis at every
    output instant (``times``, default the case's), on the branch the
    assembly found (kinem.tracking), with ``options`` (default: the case's
    [solver] section). Never raises for an analysis failure: the result says
    when and why (success False) and holds the instants solved before it.

    ``q0``: the estimate to assemble from at ``times[0]`` (default the case's
    ``model.q0``); a run continued from a solved state passes that state, so a
    long run can be solved in pieces (``kinem solve`` does: kinem.stream).
    ``kinem.solve`` (kinem.front) also solves variants together."""
    _checked_model(model)
    times = _checked_times(times)   # None: the model's
    options = model.options if options is None else options
    if not isinstance(options, Options):
        raise InputError(f"solve: options {type(options).__name__}: expected a kinem.Options")
    q0 = _checked_q0(model, q0)
    want_margins = False
    if not (type(outputs) is tuple and outputs == OUTPUTS):   # all of them (the default) needs no check
        outputs = (outputs,) if isinstance(outputs, str) else outputs
        # none given is refused, not read as positions
        if not isinstance(outputs, (tuple, list)) or not outputs or \
                not all(isinstance(o, str) and o in OUTPUTS + (MARGINS,) for o in outputs):
            raise InputError(f"solve: outputs {outputs!r:.80}: expected a sequence of one or more of "
                             f"{', '.join(OUTPUTS + (MARGINS,))}")
        want_margins = MARGINS in outputs
        outputs = tuple(o for o in OUTPUTS if o in outputs)
        if "positions" not in outputs:
            outputs = ("positions",) + outputs
    check_square(model)
    need_a = "accelerations" in outputs
    need_v = need_a or "velocities" in outputs
    times = model.times if times is None else times
    nt = len(times)
    X = np.empty((3 if need_v else 1, nt, model.n))  # Q (QD, QDD): one array for the march (kinem.march)
    figures, ints = np.zeros((2, nt)), np.zeros(nt + 2, np.int64)
    iters, resid, cond = ints[:nt], figures[0], figures[1]
    budget = Budget(model, options)   # the run's work and clock (kinem.budget), from now
    state = native.MarchState(model.q0 if q0 is None else q0)   # the estimates to assemble from
    status, message = Status.SUCCESS, ""
    start = time.perf_counter()
    march = March(model, state, budget, times, X, figures, ints, options, need_v) \
        if usable(model, trace, nt, options) else None
    # made before the march: after a core march of many instants Python's caches are cold and the same
    # statements take twice as long (docs/benchmarks.md "Fixed cost (item 6), session 21")
    traj, pinned = stacked(model, times, X if need_a or not need_v else X[:2]), q0 is None and pins(model)
    tracker = data = None   # made for the instants the march hands back (all of them without it)
    k = 0
    try:
        while k < nt:
            if march is not None:
                k = march.advance(k)
                if k == nt:
                    break
            if tracker is None:
                Q, QD, QDD = X[0], X[1] if need_v else None, X[2] if need_a else None
                data = Data(q=model.q0.copy(), trace=[] if trace else None, solver=choose(model, options))
                tracker = Tracker(model, data, need_v, need_a, options, state, budget)
            s = tracker.start(times[0], q0) if k == 0 else tracker.advance(times[k])
            iters[k], resid[k], cond[k], Q[k] = s.iterations, s.residual, s.pivot, s.q
            if trace:
                data.trace.append((times[k], "instant", s.iterations, s.residual, f"pivot ratio {s.pivot:.3e}"))
            if need_v:
                QD[k] = s.qd
                if need_a:
                    QDD[k] = s.qdd
            k += 1
    except AnalysisError as e:
        if getattr(e, "instant", None) is not None:   # the march's instants before it are solved
            k = e.instant
        status = Status.SINGULAR if isinstance(e, SingularError) else \
            Status.OUT_OF_TIME if isinstance(e, OutOfTimeError) else Status.NOT_CONVERGED
        limit = isinstance(e, WorkLimitError)
        what = "stopped at" if limit else "assembly at" if k == 0 else "step to"
        # the root cause, in the user's terms (a limit names its own)
        why = explain_assembly(model, times[0], tolerance=options.tolerance) if k == 0 and not limit else ""
        if k == 0 and not limit and (hint := contact_hint(model)):
            why = f"{why}; {hint}" if why else hint
        message = f"{what} t = {times[k]:.6g} (instant {k} of {nt - 1}): {why + '; ' if why else ''}{e}"
    if pinned and k and (pin := violation(model, X[0, 0])):   # the branch the case pins (kinem.branches)
        status, message, k = Status.WRONG_BRANCH, f"assembly at t = {times[0]:.6g}: {pin[1]}", 0
    wall = time.perf_counter() - start
    n_ok = k
    ok = status is Status.SUCCESS
    t_fail = None if ok else float(times[n_ok])
    # the instants solved, read-only (views of X made after it is): the trajectory's columns are made from them
    X.setflags(write=False)
    Q, QD, QDD = X[0, :n_ok], X[1, :n_ok] if need_v else None, X[2, :n_ok] if need_a else None
    if n_ok < nt:
        times, iters, resid, cond = times[:n_ok], iters[:n_ok], resid[:n_ok], cond[:n_ok]
        traj = trajectory(model, times, Q, QD, QDD)
    moves = ()
    if want_margins:   # kinem.margins: columns after the trajectory's own
        names, values, moves = margins(model, Q, times)
        traj = Trajectory(traj.t, traj.columns + names, np.hstack([traj.data, values]))
    evaluations, factorizations = int(ints[-2]), int(ints[-1])   # the march's
    if data is not None:
        evaluations, factorizations = evaluations + data.jacobian_evaluations, factorizations + data.factorizations
    return SolveResult.of({
        "success": ok, "status": status, "message": message or "all instants solved",
        "trajectory": traj, "q": Q, "qd": QD, "qdd": QDD, "iterations": iters, "residual": resid,
        "conditioning": cond, "substeps": 0 if tracker is None else tracker.substeps,
        "events": () if tracker is None else tuple(tracker.events),
        "trace": tuple(data.trace or ()) if data else (),
        "jacobian_evaluations": evaluations, "factorizations": factorizations,
        "wall_time": wall, "t_fail": t_fail, "attempts": budget.attempts, "margin_moves": moves,
        "failed_constraint": pin[0] if status is Status.WRONG_BRANCH else None if ok or status is Status.SINGULAR
        else model.row_owner[0 if data is None else data.worst_row],
        "model": model,
    })


def check_square(model) -> None:
    """Kinematic analysis needs one driving equation per degree of freedom
    (Sec. 4.3): fewer (fewer equations than coordinates) or more (counted
    where there are more equations than coordinates) is bad input, named with
    the mobility (kinem.diagnose.driver_count). More equations than
    coordinates are accepted when they are consistent (redundant
    constraints, solved in the least-squares sense)."""
    if model.m == model.n:
        return
    from .diagnose import driver_count

    # fewer: the ranks where the equations settle; more: as estimated (redundant constraints that
    # hold only in the configuration drawn, a parallelogram's third crank, keep their mobility there)
    counted = driver_count(model, float(model.times[0]), settle=model.m < model.n)
    why = counted[1] if counted is not None else ""
    if model.m < model.n:
        gap = model.n - model.m
        raise InputError(f"{model.case.source}: {model.m} equations for {model.n} coordinates: "
                         f"{gap} equation{'s' * (gap != 1)} missing" + (f"; {why}" if why else
                                                                        " (add drivers or constraints)"))
    if why.startswith("too many"):
        raise InputError(f"{model.case.source}: {model.m} equations for {model.n} coordinates: {why}")
