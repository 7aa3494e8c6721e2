"""Factorisation of the constraint Jacobian: dense LU (LAPACK getrf) for
small models, sparse LU (SuperLU) for large ones. One factorisation at an
output instant serves both the velocity and the acceleration solve."""
import warnings

import numpy as np

from .errors import SingularError

# A pivot below this fraction of the largest one is taken as zero: about
# 1e3 x machine epsilon, so rounding alone cannot trigger it, while a
# Jacobian that has really lost rank gives pivots of order epsilon.
PIVOT_RATIO = 1e-13


class Factor:
    """LU factors of Phi_q with a solve(b) method."""

    def __init__(self, model, values):
        self.sparse = model.sparse
        J = model.assemble(values, self.sparse)
        if self.sparse:
            from scipy.sparse.linalg import splu

            try:
                self.lu = splu(J, permc_spec="COLAMD")
            except RuntimeError as e:
                raise SingularError(f"singular Jacobian ({e})") from None
            pivots = np.abs(self.lu.U.diagonal())
            cols = self.lu.perm_c
        else:
            from scipy.linalg import lu_factor

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self.lu = lu_factor(J, check_finite=False)
            pivots = np.abs(np.diag(self.lu[0]))
            cols = np.arange(model.n)
        big = pivots.max() if pivots.size else 0.0
        small = int(np.argmin(pivots)) if pivots.size else 0
        self.pivot_ratio = pivots[small] / big if big > 0 and np.isfinite(big) else 0.0
        if not np.isfinite(pivots).all() or self.pivot_ratio < PIVOT_RATIO:
            name = model.coordinate_names[cols[small]] if model.n else "?"
            raise SingularError(f"singular Jacobian: pivot ratio {self.pivot_ratio:.1e} "
                                f"at coordinate '{name}'")

    def solve(self, b):
        if self.sparse:
            return self.lu.solve(b)
        from scipy.linalg import lu_solve

        return lu_solve(self.lu, b, check_finite=False)
