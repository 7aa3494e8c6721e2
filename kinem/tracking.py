"""Carrying the solution from one output instant to the next without ever
changing assembly branch silently (docs/solver.md, "Branches and
singular configurations").

Each output interval is crossed in one step when that is safe, else in
adaptive sub-steps. A step is rejected, and halved, when Newton fails, when
its correction from the predictor exceeds KAPPA times the predicted motion
(a jump towards another solution), when det(J_s) changes sign (the path
crossed a singular configuration, or another branch was reached), or when
the configuration is near-singular. A step that must be smaller than
MIN_STEP of the output interval means the path is stuck at a singular
configuration: ``kinem.diagnose`` then tells a limit position (the analysis
stops with the diagnosis) from a bifurcation the drivers' motion fits, which
is stepped over on the smooth continuation and recorded as an event.
"""
from dataclasses import dataclass, replace

import numpy as np

from . import analysis
from . import native
from .diagnose import diagnose
from .budget import Budget
from .errors import AnalysisError, ConvergenceError, SingularError, WorkLimitError
from .linalg import det_sign, monitor_rows
from .options import Options

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


def singular_pivot(tolerance: float) -> float:
    """Pivot ratio of J_s below which a state is too near a singular
    configuration to trust. Newton stops within sqrt(tolerance) of a singular
    root, where the ratio is 0.4 to 0.6 sqrt(tolerance) (measured on the
    change-point cases); a regular path that only passes close to one, like
    a four-bar 1e-8 from its change point, keeps about 0.4 sqrt(margin)
    (3.9e-5 there). 1.5 sqrt(tolerance) separates the two with a factor of
    about 2.5 either way; normal configurations have 1e-2 to 1."""
    return min(1e-3, 1.5 * tolerance**0.5)


def lagrange(t, T, H, q):
    """q at t (into q) extrapolated through the states H (3, n) at times T
    (3,), oldest first (NaN: none): Lagrange through those within four steps
    of t (the compiled core's, kinem/core/src/accept.rs). Returns the order:
    the points used - 1 (0: no slope to judge a jump by)."""
    q[:], order = native.lagrange(float(t), np.ascontiguousarray(T, float), np.ascontiguousarray(H, float))
    return order


def jump_sizes(q, q_pred, q_last, col_scale):
    """(correction, motion): the largest dimensionless |q - q_pred| and
    |q_pred - q_last| (the compiled core's)."""
    c = np.ascontiguousarray
    return native.jump_sizes(c(q, float), c(q_pred, float), c(q_last, float), c(col_scale, float))


# Why ``rejected`` turns a state down (0: accepted).
NEAR_SINGULAR, DET_FLIP, JUMP = native.NEAR_SINGULAR, native.DET_FLIP, native.JUMP


def rejected(pivot, correction, det, previous_det, corr, move, judge_jump, floor, tolerance, allow_flip):
    """The acceptance test of a tracked state reached in one step from the
    one before it, the one test of the tracker and of the march (the
    compiled core's, kinem/core/src/accept.rs): NEAR_SINGULAR when its pivot
    ratio is below the floor (singular_pivot) or not a number, or when its
    last Newton correction is above REGULAR x sqrt(tolerance): Newton
    converged linearly, to a singular root, where a correction with the
    nearly singular LU can throw q to a configuration that passes the floor
    (docs/solver.md, "Branches and singular configurations"); DET_FLIP
    when det(J_s) changed sign (unless ``allow_flip``: a step over a
    bifurcation), JUMP when its correction from the predictor is above
    KAPPA times the predicted motion plus ten times the tolerance for
    round-off (``jump_sizes``; judged when ``judge_jump``: the predictor
    had a slope), else 0."""
    return native.Why(native.rejected(float(pivot), float(correction), int(det), int(previous_det), float(corr),
                                      float(move), bool(judge_jump), float(floor), float(tolerance), bool(allow_flip)))


def over_steps(step, limit):
    """Step-over sizes across a bifurcation: doubling from twice the stuck
    step until past the near-singular zone, at most ``limit``."""
    size = 2 * step
    while size <= limit:
        yield size
        size *= 2


@dataclass
class State:
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
    def __init__(self, model, data, need_v, need_a, options: Options):
        self.a = analysis
        self.model, self.data = model, data
        self.need_v, self.need_a = need_v, need_a
        self.options = o = options
        self.tol = o.tolerance
        self.history = []       # accepted states, last three kept
        self.events = []        # (t, text): singular configurations passed
        self.substeps = 0       # steps taken beyond one per output interval
        self.pivot_floor = singular_pivot(o.tolerance)
        # every attempt beyond one per output interval, and the time, count (kinem.budget)
        self.budget = data.budget = Budget(model, o)

    # -- one configuration -------------------------------------------------
    def settle(self, t, q_start) -> State:
        """Newton from q_start at t to the corrected q and the factorisation
        there (kinem.analysis.position), its pivot ratio and det sign, and the
        velocity and acceleration when asked (none where Phi_q is singular)."""
        m, d = self.model, self.data
        # modified Newton from the last solve's factorisation (none after a failed one), when the case asks for it
        f = d.factor
        reuse = f if self.options.jacobian_reuse and self.history and f is not None and f.pivot_ratio > 0 else None
        d.q = q_start
        self.a.position(m, d, t, self.tol, self.options.max_iterations, factor=reuse)
        f = d.factor
        qd = qdd = None
        if self.need_v and f.pivot_ratio > 0:
            # rates from the factorisation at the corrected position: to rounding, not to the tolerance
            self.a.velocity(m, d)
            qd = d.qd
            if self.need_a:
                self.a.acceleration(m, d)
                qdd = d.qdd
        return State(t, d.q.copy(), qd, qdd, f.pivot_ratio, f.det_sign, d.iterations, d.residual, d.correction)

    def recent(self):
        """(T (3,), H (3, n)): the last three accepted states' times and q,
        oldest first, NaN times where there are fewer (``lagrange``)."""
        h = self.history[-3:]
        T, H = np.full(3, np.nan), np.zeros((3, self.model.n))
        for i, s in enumerate(h):
            T[3 - len(h) + i], H[3 - len(h) + i] = s.t, s.q
        return T, H

    def predict(self, t):
        """(start, order) at t from the accepted states: Taylor from the last
        one when its rates are known (order 2), else ``lagrange``."""
        last = self.history[-1]
        h = t - last.t
        if last.qd is not None:
            q = last.q + h * last.qd
            return (q if last.qdd is None else q + 0.5 * h * h * last.qdd), 2
        q = np.empty(self.model.n)
        return q, int(lagrange(t, *self.recent(), q))

    def attempt(self, t, allow_flip=False) -> State:
        q_pred, order = self.predict(t)
        s = self.settle(t, q_pred)
        last = self.history[-1]
        corr, move = jump_sizes(s.q, q_pred, last.q, self.model.col_scale)
        why = rejected(s.pivot, s.correction, s.det, last.det, corr, move, order >= 1, self.pivot_floor, self.tol,
                       allow_flip)
        if why == NEAR_SINGULAR:
            raise Rejected(f"{NEAR_SINGULAR.message} (pivot ratio {s.pivot:.1e}, last Newton correction "
                           f"{s.correction:.1e})")
        if why == DET_FLIP:
            raise Rejected(DET_FLIP.message)
        if why == JUMP:
            raise Rejected(f"{JUMP.message} of {corr:.2e} (predicted motion {move:.2e})")
        return s

    # -- the march ---------------------------------------------------------------
    def start(self, t, q0=None) -> State:
        try:
            s = self.settle(t, (self.model.q0 if q0 is None else q0).copy())
        except WorkLimitError:
            raise
        except AnalysisError as e:
            raise type(e)(f"{e}{self.count_problem(self.data.q, t)}") from None
        if s.det == 0:
            d = diagnose(self.model, s.q, t)
            raise SingularError("assembled in a " + d.message())
        m = self.model
        solver = self.data.solver
        if solver is not None and solver.least_squares and not solver.sparse:
            # redundant equations: monitor the det sign of a square subsystem of independent rows
            J = m.assemble(m.jac_values(s.q, t) * m.entry_scale, False)
            self.data.solver = replace(solver, rows=monitor_rows(J))
            s.det = det_sign(J[self.data.solver.rows])
        self.history = [s]
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

    def accept(self, s):
        self.history = (self.history + [s])[-3:]

    def advance(self, target) -> State:
        """The state at the output instant ``target``."""
        h_out = self.h_out = target - self.history[-1].t
        h, budget = h_out, self.budget
        budget.begin(self.history[-1].t, h_out)
        while self.history[-1].t < target:
            last = self.history[-1]
            t1 = last.t + h
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
                h = (t1 - last.t) / 2
                if h < MIN_STEP * h_out:
                    out = self.stuck(last, target, t1 - last.t, why)
                    if out is not None:
                        return out
                    h = max(h_out * MIN_STEP, 1e-300)
                continue
            if t1 != target:
                self.substeps += 1
                budget.spend(t1, step=t1 - last.t)
                if self.options.on_substeps is not None:
                    self.options.on_substeps(self.substeps, t1)
            self.accept(s)
            h = min(2 * h, h_out)
        return self.history[-1]

    def stuck(self, last, target, step, why):
        """No step from ``last`` is accepted: diagnose, then stop or step over."""
        d = diagnose(self.model, last.q, last.t)
        if not d.singular:
            raise ConvergenceError(f"cannot continue beyond t = {last.t:.6g} without a jump: {why}")
        if not d.consistent:
            raise SingularError(d.message())
        # near a bifurcation the drivers' motion fits: the output instant itself may be
        # regular, on this side of it (the drivers reverse just short of it)
        s = self.direct(last, target)
        if s is not None:
            self.events.append((target, "output instant near a singular configuration, solved directly "
                                        f"(pivot ratio {s.pivot:.1e}): " + d.message()))
            self.accept(s)
            return s
        # else continue on the smooth branch
        for size in over_steps(step, 2 * (target - last.t) + step):
            t1 = last.t + size
            if t1 >= target:
                return self.land_on_singular(last, target, d)
            try:
                s = self.attempt(t1, allow_flip=True)
            except WorkLimitError:
                raise
            except (AnalysisError, Rejected):
                self.budget.spend(t1, rejected=True)
                continue
            self.budget.spend(t1)
            self.events.append((last.t, "stepped over a singular configuration on the smooth branch: " + d.message()))
            self.substeps += 1
            self.accept(s)
            return None
        raise SingularError(d.message())

    def land_on_singular(self, before, target, d):
        """The output instant sits on the bifurcation: take the state just
        after it and interpolate between the two neighbours (cubic Hermite
        where rates are known: errors of order (distance)^4 in positions,
        (distance)^2 in accelerations)."""
        step = target - before.t
        for size in over_steps(step / 2, self.h_out):
            try:
                after = self.attempt(target + size, allow_flip=True)
                break
            except WorkLimitError:
                raise
            except (AnalysisError, Rejected):
                self.budget.spend(target + size, rejected=True)
                continue
        else:
            raise SingularError(d.message())
        h = after.t - before.t
        w = (target - before.t) / h
        lerp = lambda a, b: None if a is None else (1 - w) * a + w * b
        v0, v1 = (before.qd, after.qd) if self.need_v else (self.rate(before), self.rate(after))
        h00, h10, h01, h11 = 2 * w**3 - 3 * w**2 + 1, w**3 - 2 * w**2 + w, -2 * w**3 + 3 * w**2, w**3 - w**2
        q = h00 * before.q + h10 * h * v0 + h01 * after.q + h11 * h * v1
        qd = None
        if self.need_v:
            d00, d10, d01, d11 = (6 * w**2 - 6 * w) / h, 3 * w**2 - 4 * w + 1, (-6 * w**2 + 6 * w) / h, 3 * w**2 - 2 * w
            qd = d00 * before.q + d10 * v0 + d01 * after.q + d11 * v1
        s = State(target, self.polish(q, target), qd, lerp(before.qdd, after.qdd), 0.0, after.det,
                  self.data.iterations, self.data.residual)
        self.events.append((target, "output instant on a singular configuration, interpolated between "
                                    f"t = {before.t:.9g} and {after.t:.9g}: " + d.message()))
        self.accept(after)
        return s

    def direct(self, before, t):
        """The state at t solved by Newton from the Taylor predictor at
        ``before``, the last accepted state, when its root is regular (REGULAR: Newton
        converges there quadratically and the pivot ratio is that of a
        configuration, not of a singular one), on the same side of the
        singular configuration as ``before`` (the same sign of det) and no
        jump from the predictor. None otherwise: the instant is then
        interpolated."""
        m, d = self.model, self.data
        try:
            qd, qdd = (before.qd, before.qdd) if self.need_a else self.rates(before)
            h = t - before.t
            q_pred = before.q + h * qd + 0.5 * h * h * qdd
            s = self.settle(t, q_pred)
            if s.det != before.det:
                return None
            corr = np.max(np.abs(d.factor.solve(-m.phi(s.q, t))) / m.col_scale)  # the factorisation at s.q
        except WorkLimitError:
            raise
        except AnalysisError:
            return None
        finally:
            self.budget.spend(t)
        # the acceptance test on one more correction, with a pivot floor REGULAR times lower
        why = rejected(s.pivot, corr, s.det, before.det, *jump_sizes(s.q, q_pred, before.q, m.col_scale), True,
                       REGULAR * self.pivot_floor, self.tol, False)
        return s if why == 0 else None

    def rates(self, state):
        """Velocity and acceleration of a (regular) state."""
        m = self.model
        f = self.a._factor(m, self.data, state.q, state.t)
        qd = f.solve(m.nu(state.t))
        return qd, f.solve(m.gamma(state.q, qd, state.t))

    def rate(self, state):
        """Velocity of a (regular) state, for interpolation when none was asked for."""
        return self.a._factor(self.model, self.data, state.q, state.t).solve(self.model.nu(state.t))

    def polish(self, q, t):
        """Minimum-norm Gauss-Newton steps: Newton without a regular Jacobian."""
        q, self.data.residual = self.a.gauss_newton(self.model, q, t, self.options.max_iterations, self.tol,
                                                    self.budget)
        if not self.data.residual <= self.tol:
            raise ConvergenceError(f"no convergence at the singular configuration t = {t:.6g}")
        return q
