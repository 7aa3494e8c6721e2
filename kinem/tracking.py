"""Carrying the solution from one output instant to the next without ever
changing assembly branch silently (docs/solver.md, "Branches and
singular configurations"): the tracker's policy around the core's step.

Each output interval is crossed in one step when that is safe, else in
adaptive sub-steps. The step is the compiled core's (kinem.native: the
model's ``Plan.step`` on kinem's own LU, or ``native.step`` on this
analysis's operations, kinem.analysis.Steps, for another linear solver, a
trace or modified Newton): the predictor, Newton, the acceptance test and
the rates, on the one ``MarchState`` the march (kinem.march) carries on too.
A step is rejected, and halved, when Newton fails, when its correction from
the predictor exceeds KAPPA times the predicted motion (a jump towards
another solution), when det(J_s) changes sign (the path crossed a singular
configuration, or another branch was reached), or when the configuration is
near-singular. A step that must be smaller than MIN_STEP of the output
interval means the path is stuck at a singular configuration:
``kinem.diagnose`` then tells a limit position (the analysis stops with the
diagnosis) from a bifurcation the drivers' motion fits, which is stepped
over on the smooth continuation and recorded as an event.

What stays here: the policy (halving, stepping over, landing on an output
instant); the assembly's diagnosis when the core's assembly fails (the
step-by-step kinem.analysis.position, whose error names the worst
constraint or the singular coordinate); the det sign of a least-squares
model's monitored rows (kinem.linalg.monitor_rows: the core has no QR); the
interpolation onto an output instant that sits on a bifurcation and the
minimum-norm Gauss-Newton that polishes it (kinem.analysis.gauss_newton:
Phi_q is singular there, the core's LU has no minimum-norm solve).
"""
from dataclasses import dataclass, replace

import numpy as np

from . import analysis
from . import native
from .diagnose import diagnose
from .budget import Budget
from .errors import AnalysisError, ConvergenceError, SingularError, WorkLimitError
from .linalg import det_sign, monitor_rows
from .native import Mode, Why
from .options import Options, singular_pivot  # noqa: F401 (kinem.tracking.singular_pivot)

KAPPA = native.KAPPA    # a correction above half the predicted motion is a jump, not a refinement
MIN_STEP = 1e-5        # of the output interval: below it the path is stuck at a singular point
# An output instant near a singular configuration is solved directly (not interpolated)
# when one more Newton correction after convergence is below REGULAR x sqrt(tolerance)
# (dimensionless) and its pivot ratio above REGULAR x singular_pivot(tolerance). At a singular
# root Newton converges linearly: it stops about sqrt(tolerance) from it and each further
# correction halves that distance (measured 4.5e-7 at the change point, tolerance 1e-12); when
# it starts so close that the correction passes, the pivot ratio is of the order of that
# distance (1e-11 there). At a regular root the correction is rounding over the conditioning
# and the pivot ratio that of the configuration: 1e-10 and 3.8e-7 for a four-bar 1e-6 (in
# crank angle) from its change point.
REGULAR = native.REGULAR


# Why the core's step turns a state down (kinem.native.Why; 0: accepted).
NEAR_SINGULAR, DET_FLIP, JUMP = Why.NEAR_SINGULAR, Why.DET_FLIP, Why.JUMP


def over_steps(step, limit):
    """Step-over sizes across a bifurcation: doubling from twice the stuck
    step until past the near-singular zone, at most ``limit``."""
    size = 2 * step
    while size <= limit:
        yield size
        size *= 2


@dataclass
class State:
    """What an output instant records: the accepted state and its step's figures."""
    t: float
    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None
    pivot: float
    det: int
    iterations: int
    residual: float
    correction: float = 0.0  # the last Newton correction (the core's settle)


class Rejected(Exception):
    pass


class Tracker:
    def __init__(self, model, data, need_v, need_a, options: Options, state=None, budget=None):
        """``state``: the run's kinem.native.MarchState (default: a new one at
        the model's estimates); ``budget``: its kinem.budget.Budget (default:
        a new one, its clock started now)."""
        self.model, self.data = model, data
        self.need_v, self.need_a = need_v, need_a
        self.options = o = options
        self.tol = o.tolerance
        self.events = []        # (t, text): singular configurations passed
        self.substeps = 0       # steps taken beyond one per output interval
        # the last accepted state, the march's too (kinem.march), and what the core's step is given
        self.state = native.MarchState(model.q0) if state is None else state
        self.last = None        # the record of the last accepted state (State)
        self.settings = o.step_settings[bool(need_v)]
        self.pivot_floor = self.settings[3]
        solver = data.solver
        # the core's operations where its LU is the solver and no trace or modified Newton asks for Python's
        core = solver is not None and solver.core and data.trace is None and not o.jacobian_reuse
        self.plan = model.plan if core else None
        # every attempt beyond one per output interval, and the time, count (kinem.budget)
        self.budget = data.budget = Budget(model, o) if budget is None else budget

    # -- one step, by the core ---------------------------------------------
    def step(self, t, mode=Mode.TRACK, state=None, floor=None):
        """The core's step to t from ``state`` (the tracker's), by ``mode``
        (kinem.native.Mode), pivot floor ``floor`` (default singular_pivot):
        its Outcome, the state moved to t when accepted. The data records
        the solve (q, iterations, residual, last correction, counts)."""
        m, d = self.model, self.data
        st = self.state if state is None else state
        settings = self.settings if floor is None else self.settings[:3] + (floor,) + self.settings[4:]
        if self.plan is not None:
            self.budget.check(t)
            o = self.plan.step(st, float(t), settings, int(mode))
            d.jacobian_evaluations += o.counts[0]
            d.factorizations += o.counts[1]
            if o.why != Why.ACCEPTED:   # the worst constraint where it stopped, for a failure's message
                r = m.scaled_residual(m.phi(o.q, t))
                d.worst_row = int(np.argmax(r)) if r.size else 0
        else:
            # modified Newton from the last solve's factorisation (none after a failed one), when asked for
            f = d.factor
            reuse = f if self.options.jacobian_reuse and np.isfinite(st.t) and f is not None and f.pivot_ratio > 0 \
                else None
            ops = analysis.Steps(m, d, None, t, reuse, False)
            d.factor = None
            o = native.step(ops, m.core, st, float(t), settings, int(mode))
            if o.why != Why.NOT_CONVERGED:
                d.factor = ops.f
        d.q, d.t = o.q, t
        d.iterations, d.residual, d.correction = o.iterations, o.residual, o.correction
        return o

    def record(self, o) -> State:
        """The record of the state the step ``o`` was accepted into."""
        st = self.state
        qd = st.qd if self.need_v else None
        self.last = State(st.t, st.q, qd, st.qdd if qd is not None and self.need_a else None, o.pivot, o.det,
                          o.iterations, o.residual, o.correction)
        return self.last

    def attempt(self, t, allow_flip=False) -> State:
        """One step to t (over a bifurcation: ``allow_flip``): its record, or Rejected / an AnalysisError."""
        o = self.step(t, Mode.OVER if allow_flip else Mode.TRACK)
        why = Why(o.why)
        if why == Why.ACCEPTED:
            return self.record(o)
        if why == Why.NOT_CONVERGED:
            raise analysis.not_converged(self.model, self.data, self.tol)
        if why == NEAR_SINGULAR:
            raise Rejected(f"{why.message} (pivot ratio {o.pivot:.1e}, last Newton correction {o.correction:.1e})")
        if why == JUMP:
            raise Rejected(f"{why.message} of {o.corr:.2e} (predicted motion {o.motion:.2e})")
        raise Rejected(why.message)

    # -- the march ---------------------------------------------------------------
    def start(self, t, q0=None) -> State:
        m, d = self.model, self.data
        q0 = np.asarray(m.q0 if q0 is None else q0, dtype=float)
        self.state.restart(q0)
        try:
            o = self.step(t, Mode.ASSEMBLE)
            if o.why != Why.ACCEPTED:
                # the step-by-step analysis's diagnosis: the worst constraint, or the singular coordinate
                d.q = q0.copy()
                analysis.position(m, d, t, self.tol, self.options.max_iterations)
        except WorkLimitError:
            raise
        except AnalysisError as e:
            raise type(e)(f"{e}{self.count_problem(d.q, t)}") from None
        if o.why != Why.ACCEPTED:   # converged, with Phi_q singular there
            raise SingularError("assembled in a " + diagnose(m, d.q, t).message())
        s = self.record(o)
        solver = d.solver
        if solver is not None and solver.least_squares and not solver.sparse:
            # redundant equations: monitor the det sign of a square subsystem of independent rows
            J = m.assemble(m.jac_values(s.q, t) * m.entry_scale, False)
            d.solver = replace(solver, rows=monitor_rows(J))
            s.det = self.state.det = det_sign(J[d.solver.rows])
        return s

    def count_problem(self, q, t) -> str:
        """Why an assembly fails, when the count of independent equations is wrong."""
        from .diagnose import DENSE_LIMIT, rank_analysis

        m = self.model
        if m.n > DENSE_LIMIT or not np.isfinite(q).all() or not np.isfinite(m.jac_values(q, t)).all():
            return ""
        rank, dependent = rank_analysis(m, q, t)
        text = ""
        if rank < m.n:
            text += (f"; the Jacobian has rank {rank} for {m.n} coordinates: {m.n - rank} degree(s) of freedom "
                     f"left after the drivers (add {m.n - rank} driving equation(s)), or the estimate is a "
                     "singular configuration")
        if dependent:
            text += f"; dependent equations: {', '.join(dependent)}"
        if m.m > m.n and rank == m.n:
            text += f"; {m.m} equations for {m.n} coordinates: {m.m - m.n} redundant, and not consistent here"
        return text

    def advance(self, target) -> State:
        """The state at the output instant ``target``."""
        st = self.state
        h_out = self.h_out = target - st.t
        h, budget = h_out, self.budget
        budget.begin(st.t, h_out)
        s = self.last
        while st.t < target:
            t0 = st.t
            t1 = t0 + h
            if t1 >= target - 1e-9 * h_out:
                t1 = target
            try:
                s = self.attempt(t1)
            except WorkLimitError:
                raise
            except (AnalysisError, Rejected) as why:
                budget.spend(t1, rejected=True)
                if self.data.trace is not None:
                    self.data.trace.append((t1, "rejected", self.data.iterations, self.data.residual, str(why)))
                h = (t1 - t0) / 2
                if h < MIN_STEP * h_out:
                    out = self.stuck(target, t1 - t0, why)
                    if out is not None:
                        return out
                    h = max(h_out * MIN_STEP, 1e-300)
                continue
            if t1 != target:
                self.substeps += 1
                budget.spend(t1, step=t1 - t0)
                if self.options.on_substeps is not None:
                    self.options.on_substeps(self.substeps, t1)
            h = min(2 * h, h_out)
        return s

    def stuck(self, target, step, why):
        """No step from the last accepted state is accepted: diagnose, then stop or step over."""
        last = self.state.copy()
        d = diagnose(self.model, last.q, last.t)
        if not d.singular:
            raise ConvergenceError(f"cannot continue beyond t = {last.t:.6g} without a jump: {why}")
        if not d.consistent:
            raise SingularError(d.message())
        # near a bifurcation the drivers' motion fits: the output instant itself may be
        # regular, on this side of it (the drivers reverse just short of it)
        s = self.direct(target)
        if s is not None:
            self.events.append((target, "output instant near a singular configuration, solved directly "
                                        f"(pivot ratio {s.pivot:.1e}): " + d.message()))
            return s
        # else continue on the smooth branch
        for size in over_steps(step, 2 * (target - last.t) + step):
            t1 = last.t + size
            if t1 >= target:
                return self.land_on_singular(last, target, d)
            try:
                self.attempt(t1, allow_flip=True)
            except WorkLimitError:
                raise
            except (AnalysisError, Rejected):
                self.budget.spend(t1, rejected=True)
                continue
            self.budget.spend(t1)
            self.events.append((last.t, "stepped over a singular configuration on the smooth branch: " + d.message()))
            self.substeps += 1
            return None
        raise SingularError(d.message())

    def land_on_singular(self, before, target, d):
        """The output instant sits on the bifurcation: take the state just
        after it (``before``: the state before it, a kinem.native.MarchState)
        and interpolate between the two neighbours (cubic Hermite where rates
        are known: errors of order (distance)^4 in positions, (distance)^2 in
        accelerations)."""
        step = target - before.t
        for size in over_steps(step / 2, self.h_out):
            try:
                self.attempt(target + size, allow_flip=True)
                break
            except WorkLimitError:
                raise
            except (AnalysisError, Rejected):
                self.budget.spend(target + size, rejected=True)
                continue
        else:
            raise SingularError(d.message())
        after, iterations = self.state.copy(), self.data.iterations
        for s in (before, after):
            if s.qd is None:
                # velocities for the interpolation, none having been asked for: the core's rates at the state
                if self.step(s.t, Mode.RATES, state=s).why != Why.ACCEPTED:
                    raise SingularError(d.message())
        h = after.t - before.t
        w = (target - before.t) / h
        v0, v1 = before.qd, after.qd
        h00, h10, h01, h11 = 2 * w**3 - 3 * w**2 + 1, w**3 - 2 * w**2 + w, -2 * w**3 + 3 * w**2, w**3 - w**2
        q = h00 * before.q + h10 * h * v0 + h01 * after.q + h11 * h * v1
        qd = qdd = None
        if self.need_v:
            d00, d10, d01, d11 = (6 * w**2 - 6 * w) / h, 3 * w**2 - 4 * w + 1, (-6 * w**2 + 6 * w) / h, 3 * w**2 - 2 * w
            qd = d00 * before.q + d10 * v0 + d01 * after.q + d11 * v1
            if self.need_a:
                qdd = (1 - w) * before.qdd + w * after.qdd
        s = State(target, self.polish(q, target), qd, qdd, 0.0, after.det, iterations, self.data.residual)
        self.events.append((target, "output instant on a singular configuration, interpolated between "
                                    f"t = {before.t:.9g} and {after.t:.9g}: " + d.message()))
        return s

    def direct(self, t):
        """The state at t solved by the core's step from the Taylor
        predictor at the last accepted state (Mode.DIRECT), when its root is
        regular (REGULAR: one more Newton correction below REGULAR
        sqrt(tolerance), and a pivot ratio above REGULAR times the floor,
        that of a configuration, not of a singular one), on the same side of
        the singular configuration (the same sign of det) and no jump from
        the predictor: its record, the state moved to it. None otherwise:
        the instant is then interpolated."""
        try:
            o = self.step(t, Mode.DIRECT, floor=REGULAR * self.pivot_floor)
        except WorkLimitError:
            raise
        except AnalysisError:
            return None
        finally:
            self.budget.spend(t)
        return self.record(o) if o.why == Why.ACCEPTED else None

    def polish(self, q, t):
        """Minimum-norm Gauss-Newton steps: Newton without a regular Jacobian."""
        q, self.data.residual = analysis.gauss_newton(self.model, q, t, self.options.max_iterations, self.tol,
                                                      self.budget)
        if not self.data.residual <= self.tol:
            raise ConvergenceError(f"no convergence at the singular configuration t = {t:.6g}")
        return q
