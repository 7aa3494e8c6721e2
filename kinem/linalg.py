"""Factorisation of the constraint Jacobian: dense LU (LAPACK getrf) for
small models, sparse LU (SuperLU) for large ones. One factorisation at an
output instant serves both the velocity and the acceleration solve.

The factorised matrix is the dimensionless Jacobian
    J_s = diag(1/scale) Phi_q diag(col_scale)
(rows divided by their residual scale, length columns multiplied by the
characteristic length L), so that its pivots mean the same whatever the
units: ``pivot_ratio`` (smallest over largest |U_kk|) is the cheap
conditioning figure recorded at every instant, and ``det_sign`` the sign of
det(J_s), which flips when the configuration passes through a singular one.

These figures of LAPACK's, SuperLU's and QR's factors are computed here;
those of kinem's own LU (``Solver.core``) come from the core (kinem.native.Lu),
as every step's do (kinem/core/src/step.rs).

A model with more equations than coordinates (redundant but consistent
constraints) is solved in the least-squares sense: dense QR of J_s, or the
normal equations J_s^T J_s with sparse LU. Its pivots are those of R (their
square roots for the normal equations). Its determinant sign is that of the square subsystem of
n independent rows chosen at the assembled configuration (``monitor_rows``),
the system of its square twin, so that a least-squares model's branch is
guarded as its twin's is (dense models; a sparse one reports +1 and is
guarded by the jump test alone).
"""
from dataclasses import dataclass
import weakref

import numpy as np

from . import native
from .errors import SingularError
from .model import DENSE_LIMIT, parity
from .options import Options

# A pivot below this fraction of the largest one is taken as zero: about
# 1e3 x machine epsilon, so rounding alone cannot trigger it, while a
# Jacobian that has really lost rank gives pivots of order epsilon (the
# core's step takes it too: kinem/core/src/step.rs, SINGULAR).
PIVOT_RATIO = native.SINGULAR


def pivot_ratio(diag) -> np.ndarray:
    """Smallest over largest |pivot| along the last axis (one LU or a batch);
    0 when the pivots are all zero or not all finite."""
    pivots = np.abs(diag)
    big = pivots.max(axis=-1, initial=0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((big > 0) & np.isfinite(pivots).all(axis=-1), pivots.min(axis=-1, initial=np.inf) / big, 0.0)


def lu_det_sign(diag, piv) -> np.ndarray:
    """Sign of det from LAPACK getrf's U diagonal and row interchanges (along
    the last axis: one LU or a batch)."""
    swaps = np.count_nonzero(piv != np.arange(piv.shape[-1]), axis=-1)
    return np.prod(np.sign(diag), axis=-1).astype(int) * (1 - 2 * (swaps % 2))


def monitor_rows(J) -> np.ndarray:
    """Rows of a dimensionless Jacobian J (m x n, m > n, full column rank)
    forming its best-conditioned square subsystem as QR with column pivoting
    of J^T orders them: the first n, in their original order."""
    from scipy.linalg import qr

    J = J.toarray() if hasattr(J, "toarray") else J
    _, perm = qr(J.T, pivoting=True, mode="r")
    return np.sort(perm[:J.shape[1]])


def det_sign(J) -> int:
    """Sign of det of a square (dense or sparse) matrix from its LU."""
    from scipy.linalg.lapack import dgetrf

    lu, piv, _ = dgetrf(J.toarray() if hasattr(J, "toarray") else J)
    return int(lu_det_sign(np.diag(lu), piv))


@dataclass(frozen=True)
class Solver:
    """The linear solver of an analysis, chosen once (``choose``): kinem's
    own LU (``core``: the march's), dense LAPACK LU, sparse LU, or least
    squares (dense QR, or sparse normal equations) for a model with
    redundant equations, whose det sign is that of its ``rows``
    (``monitor_rows``; None: +1)."""
    sparse: bool
    least_squares: bool
    rows: np.ndarray | None = None
    core: bool = False


def choose(model, options) -> Solver:
    """The linear solver for a model under ``options`` (kinem.options.Options,
    as solve was given them): kinem's own LU where the model
    has a plan (kinem.model.Model.plan) and the options do not ask for
    another; SuperLU for a large model without one or when asked for;
    LAPACK for ``dense`` where there is no plan."""

    kind = options.linear_solver
    per = _CHOSEN.setdefault(model, {})   # a solve asks at every call: chosen once per model and kind
    if kind not in per:
        least_squares = model.m > model.n
        core = not least_squares and kind != "sparse" and model.plan is not None
        sparse = not core and (model.n > DENSE_LIMIT if kind == "auto" else kind == "sparse")
        per[kind] = Solver(sparse, least_squares, core=core)
    return per[kind]


_CHOSEN = weakref.WeakKeyDictionary()   # model -> {linear_solver: Solver}


class Factor:
    """LU factors of the dimensionless Phi_q with a solve(b) for Phi_q x = b,
    by the ``solver`` chosen for the analysis (``choose``)."""

    def __init__(self, model, values, solver: Solver | None = None):
        solver = choose(model, Options()) if solver is None else solver
        self.sparse, self.core = solver.sparse, solver.core
        self.least_squares = solver.least_squares
        if self.core:
            self.lu = model.plan.factor(np.ascontiguousarray(values, dtype=float))
            self.pivot_ratio = float(self.lu.pivot_ratio)
            if self.pivot_ratio < PIVOT_RATIO:
                at = self.lu.smallest
                name = "?" if at is None else model.coordinate_names[at]
                raise SingularError(f"singular Jacobian: pivot ratio {self.pivot_ratio:.1e} at coordinate '{name}'")
            return
        self.row = 1.0 / model.scale
        self.col = model.col_scale
        J = model.assemble(values * model.entry_scale, self.sparse)
        self._rows, self._J = solver.rows, J
        if self.least_squares:
            diag = self._qr(J)
            cols = np.arange(model.n)
            self._perms = None
        elif self.sparse:
            from scipy.sparse.linalg import splu

            try:
                self.lu = splu(J, permc_spec="COLAMD")
            except RuntimeError as e:
                raise SingularError(f"singular Jacobian ({e})") from None
            diag = self.lu.U.diagonal()
            cols = self.lu.perm_c
            self._perms = (self.lu.perm_r, self.lu.perm_c)
        else:
            from scipy.linalg.lapack import dgetrf  # LAPACK directly: scipy's wrapper checks cost more here

            lu, piv, _ = dgetrf(J, overwrite_a=True)
            self.lu = (lu, piv)
            diag = np.diag(lu)
            cols = np.arange(model.n)
            self._perms = None
        self.pivot_ratio = float(pivot_ratio(diag))
        self._diag = diag
        if self.pivot_ratio < PIVOT_RATIO:
            small = int(np.argmin(np.abs(diag))) if diag.size else 0
            name = model.coordinate_names[cols[small]] if model.n else "?"
            raise SingularError(f"singular Jacobian: pivot ratio {self.pivot_ratio:.1e} "
                                f"at coordinate '{name}'")

    def _qr(self, J):
        if self.sparse:
            from scipy.sparse.linalg import splu

            self.J = J.tocsr()
            try:
                self.lu = splu((J.T @ J).tocsc(), permc_spec="COLAMD")
            except RuntimeError as e:
                raise SingularError(f"singular Jacobian ({e})") from None
            return np.sqrt(np.abs(self.lu.U.diagonal()))
        from scipy.linalg import qr

        self.lu = qr(J, mode="economic", check_finite=False)
        return np.diag(self.lu[1])

    @property
    def det_sign(self) -> int:
        if self.core:
            return int(self.lu.det_sign)
        if self.least_squares:
            return 1 if self._rows is None else det_sign(self._J[self._rows])
        if self._perms is None:
            return int(lu_det_sign(self._diag, self.lu[1]))
        return int(np.prod(np.sign(self._diag))) * parity(self._perms[0]) * parity(self._perms[1])

    def solve(self, b):
        if self.core:
            return self.lu.solve(np.ascontiguousarray(b, dtype=float))
        b = b * self.row
        if self.least_squares:
            if self.sparse:
                x = self.lu.solve(self.J.T @ b)
            else:
                from scipy.linalg import solve_triangular

                Q, R = self.lu
                x = solve_triangular(R, Q.T @ b, check_finite=False)
        elif self.sparse:
            x = self.lu.solve(b)
        else:
            from scipy.linalg.lapack import dgetrs

            x, _ = dgetrs(*self.lu, b)
        return x * self.col
