"""Position, velocity and acceleration analysis (Sec. 4.3), as free functions
on a Model and a separate mutable Data; ``solve`` runs them over the output
instants.

Position: Newton-Raphson on Phi(q, t) = 0 (Eqs. 4.41, 4.42), converged when
every scaled residual |Phi_k| / scale_k <= tolerance (docs/solver.md).
Velocity: Phi_q qd = nu. Acceleration: Phi_q qdd = gamma. The Jacobian at the
converged q is factorised once and serves both solves.
"""
import time
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from . import jit
from .diagnose import explain_assembly
from .errors import AnalysisError, ConvergenceError, InputError, SingularError
from .linalg import Factor, preload
from .result import OUTPUTS, SolveResult, Status, trajectory


# Newton steps are limited to this length in dimensionless coordinates
# (lengths over L, angles in radians): a rough estimate never sends the
# assembly many turns away, and tracking steps are far shorter anyway.
MAX_STEP = 0.5
# Step-by-step runs with instants x (100 + coordinates) up to this run their
# kernels interpreted in a process without numba (``interpret``). Measured on
# N-four-bar chains in new processes: an interpreted instant costs about
# (100 + n) x 15 us more than a compiled one, and loading numba costs about
# 0.37 s, i.e. 25,000 x 15 us.
INTERPRET_WORK = 25_000


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


def _factor(model, data, q, t) -> Factor:
    data.jacobian_evaluations += 1
    data.factorizations += 1
    return Factor(model, model.jac_values(q, t))


# Jacobian reuse (modified Newton): a factorisation from a nearby
# configuration is kept while it shrinks the residual by at least this
# factor per iteration, for at most REUSE_ITERATIONS iterations.
REUSE_RATE = 0.5
REUSE_ITERATIONS = 4


def position(model, data: Data, t: float, tolerance=None, max_iterations=None, factor=None) -> None:
    """Newton-Raphson from data.q to Phi(q, t) = 0, steps limited to MAX_STEP.
    ``factor``: a factorisation of Phi_q at a nearby configuration to start
    with (modified Newton); a fresh one is made as soon as it converges slowly."""
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
        if factor is None or it >= REUSE_ITERATIONS or data.residual > REUSE_RATE * previous:
            factor = None  # full Newton from here on: a fresh Jacobian every iteration
            f = data.newton_factor = _factor(model, data, q, t)
        else:
            f = factor
        previous = data.residual
        dq = f.solve(-phi)
        size = np.max(np.abs(dq) / model.col_scale)
        if size > MAX_STEP:
            dq *= MAX_STEP / size
        q += dq
    data.q = q
    raise ConvergenceError(f"no convergence after {data.iterations} iterations: scaled residual "
                           f"{data.residual:.2e} (tolerance {tol:.1e}), largest in constraint "
                           f"'{model.row_owner[data.worst_row]}' ({model.row_labels[data.worst_row]})")


def gauss_newton(model, q, t, max_iterations=None):
    """Minimum-norm least-squares Newton steps on the dimensionless system:
    converges where Phi_q is rank-deficient or not square (redundant
    constraints, a singular configuration). Returns (q, max scaled residual)."""
    tol = model.case.tolerance
    for _ in range((max_iterations or model.case.max_iterations) + 1):
        phi = model.phi(q, t)
        r = float(model.scaled_residual(phi).max()) if model.m else 0.0
        if r <= tol or not np.isfinite(r):
            break
        J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)
        if not np.isfinite(J).all():  # overflowed: lstsq's SVD would not converge; the residual says it failed
            break
        q = q + model.col_scale * np.linalg.lstsq(J, -phi / model.scale, rcond=None)[0]
    return q, r


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


def interpret(model, blocks: bool, instants: int) -> bool:
    """Whether a run's kernels should run interpreted (kinem.jit): a short
    step-by-step run in a process that has not loaded numba costs less that
    way than numba's start-up (INTERPRET_WORK)."""
    return not blocks and not jit.loaded() and instants * (100 + model.n) <= INTERPRET_WORK


def solve(model, outputs=OUTPUTS, times=None, trace=False) -> SolveResult:
    """Position (and, when asked, velocity and acceleration) analysis at every
    output instant, on the branch the assembly found (kinem.tracking). Never
    raises for an analysis failure: the result says when and why (success
    False) and holds the instants solved before it."""
    from .march import Block, usable
    from .tracking import Tracker

    check_square(model)
    outputs = tuple(o for o in OUTPUTS if o in outputs)
    if "positions" not in outputs:
        outputs = ("positions",) + outputs
    need_a = "accelerations" in outputs
    need_v = need_a or "velocities" in outputs
    times = model.times if times is None else np.asarray(times, dtype=float)
    nt = len(times)
    Q = np.empty((nt, model.n))
    QD = np.empty((nt, model.n)) if need_v else None
    QDD = np.empty((nt, model.n)) if need_a else None
    iters, resid, cond = np.zeros(nt, dtype=int), np.zeros(nt), np.zeros(nt)
    data = Data(q=model.q0.copy(), trace=[] if trace else None)
    tracker = Tracker(model, data, need_v, need_a)
    status, message = Status.SUCCESS, ""
    blocks = usable(model, trace, nt)
    with jit.interpreted() if interpret(model, blocks, nt) else nullcontext():
        preload(model, blocks)  # one-time imports, not part of the analysis's wall time
        start = time.perf_counter()
        block = Block(model, tracker) if blocks else None
        k = 0
        try:
            while k < nt:
                if block is not None and k > 0:
                    got = block.advance(times[k: k + block.size])
                    n = len(got)
                    block.next_size(got)
                    if n:
                        iters[k:k + n], resid[k:k + n], cond[k:k + n], Q[k:k + n] = (
                            got.iterations, got.residual, got.pivot, got.q)
                        if need_v:
                            QD[k:k + n] = got.qd
                            if need_a:
                                QDD[k:k + n] = got.qdd
                        k += n
                        continue
                s = tracker.start(times[0]) if k == 0 else tracker.advance(times[k])
                iters[k], resid[k], cond[k], Q[k] = s.iterations, s.residual, s.pivot, s.q
                if trace:
                    data.trace.append((times[k], "instant", s.iterations, s.residual, f"pivot ratio {s.pivot:.3e}"))
                if need_v:
                    QD[k] = s.qd
                    if need_a:
                        QDD[k] = s.qdd
                k += 1
        except AnalysisError as e:
            status = Status.SINGULAR if isinstance(e, SingularError) else Status.NOT_CONVERGED
            what = "assembly at" if k == 0 else "step to"
            why = explain_assembly(model, times[0]) if k == 0 else ""  # the root cause, in the user's terms
            message = f"{what} t = {times[k]:.6g} (instant {k} of {nt - 1}): {why + '; ' if why else ''}{e}"
    wall = time.perf_counter() - start
    n_ok = k
    ok = status == Status.SUCCESS
    traj = trajectory(model, times[:n_ok], Q[:n_ok], None if QD is None else QD[:n_ok],
                      None if QDD is None else QDD[:n_ok])
    return SolveResult(
        success=ok, status=status, message=message or "all instants solved",
        trajectory=traj, q=Q[:n_ok], qd=None if QD is None else QD[:n_ok],
        qdd=None if QDD is None else QDD[:n_ok], iterations=iters[:n_ok], residual=resid[:n_ok],
        conditioning=cond[:n_ok], substeps=tracker.substeps, events=tuple(tracker.events),
        trace=tuple(data.trace or ()),
        jacobian_evaluations=data.jacobian_evaluations, factorizations=data.factorizations,
        wall_time=wall, t_fail=None if ok else float(times[n_ok]),
        failed_constraint=None if ok or status == Status.SINGULAR else model.row_owner[data.worst_row],
    )
