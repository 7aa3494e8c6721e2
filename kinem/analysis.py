"""Position, velocity and acceleration analysis (Sec. 4.3), as free functions
on a Model and a separate mutable Data; ``kinem.solver.solve`` runs them over
the output instants.

Position: Newton-Raphson on Phi(q, t) = 0 (Eqs. 4.41, 4.42), converged when
every scaled residual |Phi_k| / scale_k <= tolerance (docs/solver.md): the
one Newton of kinem (the compiled core's ``settle``, kinem/core/src/newton.rs)
on this module's operations (``Steps``), for any linear solver. Velocity: Phi_q qd = nu. Acceleration: Phi_q qdd = gamma.
The Jacobian at the corrected q is factorised once and serves both solves.

These are the step-by-step stages of the public API (kinem.position,
velocity, acceleration) and the tracker's diagnosis of a failed assembly;
a solve's steps are the core's (kinem/core/src/step.rs), which
runs on ``Steps`` where the linear solver is not the core's own LU.
"""
from dataclasses import dataclass

import numpy as np

from .errors import ConvergenceError, SingularError
from . import native
from .linalg import Factor, Solver
from .options import Options

MAX_STEP = native.MAX_STEP  # Newton steps' limit, dimensionless (kinem/core/src/newton.rs)


@dataclass
class Data:
    """Mutable solver state at one instant."""
    q: np.ndarray
    t: float = 0.0
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    factor: Factor | None = None        # LU of Phi_q at (q, t) after a position solve
    iterations: int = 0                 # Newton iterations of the last position solve
    residual: float = np.inf            # its final max scaled residual
    correction: float = 0.0             # its last Newton correction (the core's settle)
    worst_row: int = 0
    jacobian_evaluations: int = 0
    factorizations: int = 0
    trace: list | None = None           # when a list: (t, what, iteration, scaled residual, detail) records
    solver: Solver | None = None        # the linear solver (kinem.linalg.choose; None: the case's)
    budget: object | None = None        # the run's kinem.budget.Budget: Newton iterations check its time

    def __post_init__(self):
        if not isinstance(self.q, np.ndarray) and hasattr(self.q, "q0"):
            raise TypeError("Data(q, ...) takes coordinates; for a model's initial state use "
                            "kinem.Data.from_model(model)")

    @classmethod
    def from_model(cls, model, trace=False) -> "Data":
        """The state at the model's initial estimate (the case's q of every body), t = 0."""
        return cls(q=model.q0.copy(), trace=[] if trace else None)


def _factor(model, data, q, t, angles=None) -> Factor:
    """The factorisation at q (its Jacobian with ``angles``' e^{i q} where
    given: the core's Angles, as a step holds them)."""
    data.jacobian_evaluations += 1
    data.factorizations += 1
    values = model.jac_values(q, t) if angles is None else angles.jac(q, t)
    return Factor(model, values, data.solver)


# Jacobian reuse (modified Newton): a factorisation from a nearby
# configuration is kept while it shrinks the residual by at least this
# factor per iteration, for at most REUSE_ITERATIONS iterations.
REUSE_RATE = 0.5
REUSE_ITERATIONS = 4


class MinimumNorm:
    """Minimum-norm least-squares solves with Phi_q at one configuration
    (dimensionless, as kinem.linalg.Factor): defined where Phi_q is
    rank-deficient or not square."""

    def __init__(self, model, q, t):
        self.model = model
        self.J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)

    def solve(self, b):
        m = self.model
        if not np.isfinite(self.J).all():  # overflowed: lstsq's SVD would not converge; the residual says it failed
            return np.full(m.n, np.nan)
        return m.col_scale * np.linalg.lstsq(self.J, b / m.scale, rcond=None)[0]


class Singular:
    """The final factorisation of a position solve where Phi_q is singular
    (kinem.linalg.PIVOT_RATIO): pivot ratio 0, det sign 0, no solve."""
    pivot_ratio, det_sign = 0.0, 0

    def __init__(self, error):
        self.error = error

    def solve(self, b):
        raise self.error


class Steps:
    """The core's ``settle`` operations step by step, on q (updated in
    place): Phi and the factorisation at q with the analysis's linear
    solver, Jacobian reuse (modified Newton: ``reuse``, a factorisation from
    a nearby configuration, kept while it shrinks the residual by REUSE_RATE
    per iteration, at most REUSE_ITERATIONS times) and the trace. The core's
    step (kinem.native.step: predictor, acceptance test, rates) runs on them
    too, through ``start``, ``stats``, ``solve`` and ``probe``: what a
    linear solver other than the core's own LU answers."""

    def __init__(self, model, data, q, t, reuse, minimum_norm):
        self.model, self.data, self.q, self.t = model, data, q, t
        self.reuse, self.minimum_norm = reuse, minimum_norm
        self.phi = self.f = None
        self.r = self.previous = np.inf
        self.reused = 0
        # e^{i q} as the core's march holds it (turned after a correction): the same figures, to the bit
        self.angles = model.core.angles()

    @property
    def col_scale(self):
        return self.model.col_scale

    def start(self, q, t):
        """A solve from q at t (the core's step)."""
        self.q, self.t = np.array(q, dtype=float), t
        self.angles.start()
        self.r = self.previous = np.inf
        self.reused = 0

    def stats(self):
        """(pivot ratio, det sign) of the factorisation at hand (0, 0 where singular)."""
        return float(self.f.pivot_ratio), int(self.f.det_sign)

    def solve(self, b):
        """x with Phi_q x = b by the factorisation at hand."""
        return np.ascontiguousarray(self.f.solve(b), dtype=float)

    def probe(self):
        """The size of one more Newton correction at q with the factorisation at hand (q unchanged)."""
        dq = self.f.solve(-self.angles.phi(self.q, self.t))
        return float(np.max(np.abs(dq) / self.model.col_scale)) if dq.size else 0.0

    def evaluate(self, it):
        """Phi at q and its max scaled residual; a Newton iteration's (it >= 0)
        is recorded: worst row, trace."""
        m, d = self.model, self.data
        if d.budget is not None and it >= 0:
            if self.minimum_norm:
                d.budget.spend(self.t)   # a least-squares step counts as an attempt
            else:
                d.budget.check(self.t)
        self.phi = self.angles.phi(self.q, self.t)
        r = m.scaled_residual(self.phi)
        worst = int(np.argmax(r)) if r.size else 0
        residual = float(r[worst]) if r.size else 0.0
        if it >= 0:
            self.r, d.worst_row = residual, worst
            if d.trace is not None:
                d.trace.append((self.t, "newton", it, residual, m.row_labels[worst] if r.size else ""))
        return residual

    def factor(self, last):
        """The factorisation at q (``last``: the one left at the end, always fresh)."""
        m, d = self.model, self.data
        if self.minimum_norm:
            self.f = MinimumNorm(m, self.q, self.t)
        elif last or self.reuse is None or self.reused >= REUSE_ITERATIONS or self.r > REUSE_RATE * self.previous:
            self.reuse = None  # full Newton from here on: a fresh Jacobian every iteration
            try:
                self.f = _factor(m, d, self.q, self.t, self.angles)
            except SingularError as e:
                if not last:
                    raise
                self.f = Singular(e)
        else:
            self.f, self.reused = self.reuse, self.reused + 1
        self.previous = self.r

    def correct(self, limit):
        """q -= Phi_q^-1 Phi with the factorisation at hand, limited to ``limit``
        (dimensionless); returns the step's size before the limit (0: none,
        where the final factorisation is singular)."""
        if isinstance(self.f, Singular):
            return 0.0
        dq = self.f.solve(-self.phi)
        size = float(np.max(np.abs(dq) / self.model.col_scale)) if dq.size else 0.0
        if size > limit:
            dq *= limit / size
        self.q += dq
        return size


def _checked(what, model, data, t=None, rates=False):
    """InputError naming the argument of the public function ``what`` when
    model, data (its q, and its qd when ``rates``) or t is not what it needs."""
    from .errors import InputError

    n = getattr(model, "n", None)
    if not isinstance(n, int) or not hasattr(model, "phi"):
        raise InputError(f"{what}: model {type(model).__name__}: expected a kinem.Model (kinem.compile(case))")
    if not isinstance(data, Data):
        raise InputError(f"{what}: data {type(data).__name__}: expected a kinem.Data (kinem.Data.from_model(model))")
    for name in ("q", "qd") if rates else ("q",):
        v = getattr(data, name)
        if not isinstance(v, np.ndarray) or v.shape != (n,) or v.dtype.kind not in "fiu":
            shape = getattr(v, "shape", type(v).__name__)
            raise InputError(f"{what}: data.{name} of shape {shape}: expected {n} numbers (the model's coordinates)")
    if t is not None and not (isinstance(t, (int, float, np.number)) and np.isfinite(t)):
        raise InputError(f"{what}: t {t!r:.40}: expected a finite time")


def position(model, data: Data, t: float, tolerance=None, max_iterations=None, factor=None,
             minimum_norm=False, finish=True) -> None:
    """Newton-Raphson from data.q to Phi(q, t) = 0, steps limited to MAX_STEP
    (the core's settle), then (``finish``) the final correction and the
    factorisation at the corrected q in data.factor (a ``Singular`` one
    where Phi_q is singular there) for the rate solves.
    ``factor``: a factorisation of Phi_q at a nearby configuration to start
    with (modified Newton); a fresh one is made as soon as it converges slowly.
    ``minimum_norm``: Gauss-Newton (``MinimumNorm`` steps, not limited)."""
    _checked("position", model, data, t)
    tol = Options.tolerance if tolerance is None else tolerance   # the defaults of Options, not the case's
    max_it = Options.max_iterations if max_iterations is None else max_iterations
    Options(tolerance=tol, max_iterations=max_it)   # checked as the options are (InputError)
    q = np.array(data.q, dtype=float)
    data.t = t
    data.factor = None
    steps = Steps(model, data, q, t, factor, minimum_norm)
    try:
        data.iterations, data.residual, converged, data.correction = native.settle(
            steps, tol, max_it, np.inf if minimum_norm else MAX_STEP, finish)
    finally:
        data.q = q
    if not converged:
        raise not_converged(model, data, tol)
    if finish:
        data.factor = steps.f


def not_converged(model, data: Data, tolerance) -> ConvergenceError:
    """The error of a position solve that did not converge (data: its
    iterations, residual and worst row)."""
    return ConvergenceError(f"no convergence after {data.iterations} iterations: scaled residual "
                            f"{data.residual:.2e} (tolerance {tolerance:.1e}), largest in constraint "
                            f"'{model.row_owner[data.worst_row]}' ({model.row_labels[data.worst_row]})")


def gauss_newton(model, q, t, max_iterations=None, tolerance=None, budget=None):
    """Minimum-norm least-squares Newton steps on the dimensionless system:
    converges where Phi_q is rank-deficient or not square (redundant
    constraints, a singular configuration), each spent from ``budget`` (a
    kinem.budget.Budget) when given. Returns (q, max scaled residual)."""
    data = Data(q=np.array(q, dtype=float), budget=budget)
    try:
        position(model, data, t, tolerance, max_iterations or None, minimum_norm=True, finish=False)
    except ConvergenceError:
        pass
    return data.q, data.residual


def factorize(model, data: Data) -> None:
    """Factorise Phi_q at data.q for the velocity and acceleration solves."""
    _checked("factorize", model, data, getattr(data, "t", None))   # (data checked first)
    data.factor = _factor(model, data, data.q, data.t)


def velocity(model, data: Data) -> None:
    """qd from Phi_q qd = nu (Eq. 3.13)."""
    _checked("velocity", model, data, getattr(data, "t", None))
    if data.factor is None:
        factorize(model, data)
    data.qd = data.factor.solve(model.nu(data.t))


def acceleration(model, data: Data) -> None:
    """qdd from Phi_q qdd = gamma (Eq. 3.15); needs data.qd."""
    _checked("acceleration", model, data, getattr(data, "t", None), rates=True)
    if data.factor is None:
        factorize(model, data)
    data.qdd = data.factor.solve(model.gamma(data.q, data.qd, data.t))
