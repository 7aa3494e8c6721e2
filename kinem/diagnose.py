"""What a (near) singular configuration is: the rank-revealing look at the
dimensionless Jacobian J_s (docs/solver.md) at one configuration.

With J_s = U S V^T, the smallest singular value over the largest is the
conditioning; the left singular vector u of the smallest names the equations
that become dependent (the constraints involved), the right one the
coordinates that become free. The drivers' motion is consistent with the
singular configuration when u . nu_s = 0 (nu_s = nu / scale): then the
motion can continue through it (a bifurcation, e.g. the change point of a
four-bar); otherwise the drivers ask for a motion the mechanism cannot make
(a limit position: dead centre, toggle).
"""
from dataclasses import dataclass

import numpy as np

RANK_TOL = 1e-9       # singular values below this fraction of the largest count as zero
NEAR_SINGULAR = 1e-2   # conditioning below this counts as (near) singular
CONSISTENT = 1e-2      # |u . nu_s| / |nu_s| below this: the drivers' motion fits the singularity
INVOLVED = 0.2         # a row (column) takes part when |u_k| >= INVOLVED max |u|
DENSE_LIMIT = 3000


@dataclass(frozen=True)
class Diagnosis:
    t: float
    conditioning: float
    consistent: bool
    constraints: tuple
    coordinates: tuple

    @property
    def singular(self) -> bool:
        return self.conditioning < NEAR_SINGULAR

    def message(self) -> str:
        kind = ("the drivers' motion fits it (a bifurcation: the branch cannot be told)" if self.consistent
                else "the drivers ask for a motion the mechanism cannot make here (a limit position)")
        return (f"singular configuration at t = {self.t:.6g}: conditioning {self.conditioning:.1e} "
                f"(smallest/largest singular value of the dimensionless Jacobian); {kind}; "
                f"constraints involved: {', '.join(self.constraints)}; free coordinates: {', '.join(self.coordinates)}")


def diagnose(model, q, t) -> Diagnosis:
    if model.n > DENSE_LIMIT:
        return _diagnose_sparse(model, q, t)
    J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)
    if not np.isfinite(J).all():
        return Diagnosis(float(t), 0.0, False, ("(non-finite Jacobian)",), ())
    U, s, Vt = np.linalg.svd(J)
    cond = float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0
    k = len(s) - 1
    u, v = U[:, k] if U.shape[1] > k else U[:, -1], Vt[-1]
    nu = model.nu(t) / model.scale
    norm = np.linalg.norm(nu)
    consistent = bool(norm == 0 or abs(u @ nu) / norm < CONSISTENT)
    rows = np.flatnonzero(np.abs(u) >= INVOLVED * np.abs(u).max())
    cols = np.flatnonzero(np.abs(v) >= INVOLVED * np.abs(v).max())
    owners = tuple(dict.fromkeys(model.row_owner[r] for r in rows))
    return Diagnosis(float(t), cond, consistent, owners, tuple(model.coordinate_names[c] for c in cols))


def _diagnose_sparse(model, q, t) -> Diagnosis:
    """Large models: the sparse LU's smallest pivot only (no SVD)."""
    from .errors import SingularError
    from .linalg import Factor

    try:
        f = Factor(model, model.jac_values(q, t))
        cond = f.pivot_ratio
    except SingularError:
        cond = 0.0
    return Diagnosis(float(t), cond, False, ("(not resolved above 3000 coordinates)",), ())


def rank_analysis(model, q, t=0.0, rows=None):
    """(rank, dependent equation labels) of the dimensionless Jacobian's rows
    (all, or a boolean mask): SVD for the rank, QR with column pivoting of
    the transpose to name the rows that depend on the others."""
    from scipy.linalg import qr

    J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)
    if not np.isfinite(J).all():
        from .errors import AnalysisError

        raise AnalysisError(f"non-finite Jacobian at t = {t:g}: the configuration overflowed")
    labels = np.array(model.row_labels, dtype=object)
    if rows is not None:
        J, labels = J[rows], labels[rows]
    if not J.size:
        return 0, ()
    s = np.linalg.svd(J, compute_uv=False)
    rank = int((s > RANK_TOL * s[0]).sum()) if s.size and s[0] > 0 else 0
    _, _, perm = qr(J.T, pivoting=True, mode="economic")
    order = list(model.row_labels)
    return rank, tuple(sorted(labels[perm[rank:]], key=order.index))
