"""Position, velocity and acceleration analysis (Sec. 4.3), as free functions
on a Model and a separate mutable Data; ``kinem.solver.solve`` runs them over
the output instants.

Position: Newton-Raphson on Phi(q, t) = 0 (Eqs. 4.41, 4.42), converged when
every scaled residual |Phi_k| / scale_k <= tolerance (docs/solver.md).
Velocity: Phi_q qd = nu. Acceleration: Phi_q qdd = gamma. The Jacobian at the
converged q is factorised once and serves both solves.
"""
from dataclasses import dataclass

import numpy as np

from .diagnose import explain_assembly
from .errors import ConvergenceError, InputError
from .linalg import Factor, Solver


# Newton steps are limited to this length in dimensionless coordinates
# (lengths over L, angles in radians): a rough estimate never sends the
# assembly many turns away, and tracking steps are far shorter anyway.
MAX_STEP = 0.5


@dataclass
class Data:
    """Mutable solver state at one instant."""
    q: np.ndarray
    t: float = 0.0
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    factor: Factor | None = None        # LU of Phi_q at the converged (q, t)
    newton_factor: Factor | None = None  # LU at the last Newton iterate
    iterations: int = 0                 # Newton iterations of the last position solve
    residual: float = np.inf            # its final max scaled residual
    phi: np.ndarray | None = None       # Phi at the converged q (for ``refine``)
    worst_row: int = 0
    jacobian_evaluations: int = 0
    factorizations: int = 0
    trace: list | None = None           # when a list: (t, what, iteration, scaled residual, detail) records
    solver: Solver | None = None        # the linear solver (kinem.linalg.choose; None: the case's)

    def __post_init__(self):
        if not isinstance(self.q, np.ndarray) and hasattr(self.q, "q0"):
            raise TypeError("Data(q, ...) takes coordinates; for a model's initial state use "
                            "kinem.Data.from_model(model)")

    @classmethod
    def from_model(cls, model, trace=False) -> "Data":
        """The state at the model's initial estimate (the case's q of every body), t = 0."""
        return cls(q=model.q0.copy(), trace=[] if trace else None)


def _factor(model, data, q, t) -> Factor:
    data.jacobian_evaluations += 1
    data.factorizations += 1
    return Factor(model, model.jac_values(q, t), data.solver)


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


def position(model, data: Data, t: float, tolerance=None, max_iterations=None, factor=None,
             minimum_norm=False) -> None:
    """Newton-Raphson from data.q to Phi(q, t) = 0, steps limited to MAX_STEP.
    ``factor``: a factorisation of Phi_q at a nearby configuration to start
    with (modified Newton); a fresh one is made as soon as it converges slowly.
    ``minimum_norm``: Gauss-Newton (``MinimumNorm`` steps, not limited)."""
    tol = model.case.tolerance if tolerance is None else tolerance
    max_it = model.case.max_iterations if max_iterations is None else max_iterations
    q = data.q.copy()
    data.t = t
    data.factor = None
    previous = np.inf
    for it in range(max_it + 1):
        phi = model.phi(q, t)
        r = model.scaled_residual(phi)
        worst = int(np.argmax(r)) if r.size else 0
        data.residual, data.worst_row, data.iterations = float(r[worst]) if r.size else 0.0, worst, it
        if data.trace is not None:
            data.trace.append((t, "newton", it, data.residual, model.row_labels[worst] if r.size else ""))
        if not np.isfinite(data.residual):
            break
        if data.residual <= tol:
            data.q, data.phi = q, phi
            return
        if it == max_it:
            break
        if minimum_norm:
            f = MinimumNorm(model, q, t)
        elif factor is None or it >= REUSE_ITERATIONS or data.residual > REUSE_RATE * previous:
            factor = None  # full Newton from here on: a fresh Jacobian every iteration
            f = data.newton_factor = _factor(model, data, q, t)
        else:
            f = factor
        previous = data.residual
        dq = f.solve(-phi)
        size = np.max(np.abs(dq) / model.col_scale)
        if size > MAX_STEP and not minimum_norm:
            dq *= MAX_STEP / size
        q += dq
    data.q = q
    raise ConvergenceError(f"no convergence after {data.iterations} iterations: scaled residual "
                           f"{data.residual:.2e} (tolerance {tol:.1e}), largest in constraint "
                           f"'{model.row_owner[data.worst_row]}' ({model.row_labels[data.worst_row]})")


def gauss_newton(model, q, t, max_iterations=None, tolerance=None):
    """Minimum-norm least-squares Newton steps on the dimensionless system:
    converges where Phi_q is rank-deficient or not square (redundant
    constraints, a singular configuration). Returns (q, max scaled residual)."""
    data = Data(q=np.array(q, dtype=float))
    try:
        position(model, data, t, tolerance, max_iterations or None, minimum_norm=True)
    except ConvergenceError:
        pass
    return data.q, data.residual


def factorize(model, data: Data) -> None:
    """Factorise Phi_q at the converged data.q for the velocity and acceleration solves."""
    data.factor = _factor(model, data, data.q, data.t)


def refine(data: Data, factor) -> None:
    """One more Newton correction at the converged q with a factorisation at
    hand (the one at q, or the last iterate's): the position error falls
    from about the tolerance to about its square for one solve. The reported
    residual stays that of the converged iterate, an upper bound."""
    data.q = data.q + factor.solve(-data.phi)


def velocity(model, data: Data) -> None:
    """qd from Phi_q qd = nu (Eq. 3.13)."""
    if data.factor is None:
        factorize(model, data)
    data.qd = data.factor.solve(model.nu(data.t))


def acceleration(model, data: Data) -> None:
    """qdd from Phi_q qdd = gamma (Eq. 3.15); needs data.qd."""
    if data.factor is None:
        factorize(model, data)
    data.qdd = data.factor.solve(model.gamma(data.q, data.qd, data.t))


def check_square(model) -> None:
    """Kinematic analysis needs at least as many equations as coordinates
    (Sec. 4.3); more are accepted when they are consistent (redundant
    constraints, solved in the least-squares sense)."""
    if model.m < model.n:
        gap = model.n - model.m
        why = explain_assembly(model, float(model.times[0]))  # names the driving equations and the DOF
        raise InputError(f"{model.case.source}: {model.m} equations for {model.n} coordinates: "
                         f"{gap} equation{'s' * (gap != 1)} missing" + (f"; {why}" if why else
                                                                        " (add drivers or constraints)"))


def __getattr__(name):
    """``solve`` lives in kinem.solver, on top of the stages; the old import
    path ``from kinem.analysis import solve`` still finds it."""
    if name == "solve":
        from .solver import solve

        return solve
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
