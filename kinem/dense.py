"""LU factorisation and solves of many small dense matrices at once, and the
block Newton's convergence test and step, compiled with numba (the block
march, kinem.march).

Calling LAPACK once per 12 x 12 matrix costs 1 to 2 us of call overhead per
matrix (scipy's getrf/getrs wrappers, numpy's batched solve), about ten times
the arithmetic. These loops do the arithmetic only. The elimination is
LAPACK getf2's: partial pivoting on the first largest |entry| of the column,
whole-row interchanges, and pivot indices 0-based as in scipy's getrf, so
kinem.linalg.pivot_ratio and lu_det_sign read the result as they read
LAPACK's. Rounding differs from LAPACK's blocked order by a few ulps.

Compiled on first use and cached beside this file (numba ``cache=True``); a
zero pivot leaves its column unscaled and makes the pivot ratio 0.
"""
import numpy as np

from .jit import kernel


@kernel
def assemble(values, rows, cols, scale, J):
    """Dense Jacobians J (K, m, n), overwritten, from their values (K, nnz)
    in the pattern (rows, cols), each entry multiplied by scale[e]."""
    J[:] = 0.0
    for k in range(values.shape[0]):
        for e in range(rows.shape[0]):
            J[k, rows[e], cols[e]] = values[k, e] * scale[e]
    return J


@kernel
def factor(A):
    """LU of each A[k] (K, n, n) in place; returns the pivots (K, n)."""
    K, n = A.shape[0], A.shape[1]
    piv = np.empty((K, n), np.int32)
    for k in range(K):
        a = A[k]
        for j in range(n):
            p, big = j, abs(a[j, j])
            for i in range(j + 1, n):
                if abs(a[i, j]) > big:
                    p, big = i, abs(a[i, j])
            piv[k, j] = p
            if p != j:
                for c in range(n):
                    a[j, c], a[p, c] = a[p, c], a[j, c]
            d = a[j, j]
            if d != 0.0:
                for i in range(j + 1, n):
                    f = a[i, j] / d
                    a[i, j] = f
                    if f != 0.0:
                        for c in range(j + 1, n):
                            a[i, c] -= f * a[j, c]
    return piv


@kernel
def _solve1(a, piv, b):
    """b <- A^-1 b from one matrix's LU factors a and pivots."""
    n = a.shape[0]
    for j in range(n):
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
    for i in range(1, n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@kernel
def solve(LU, piv, B):
    """X[k] with A[k] X[k] = B[k] (K, n) from factor's result; B is overwritten
    and returned."""
    for k in range(LU.shape[0]):
        _solve1(LU[k], piv[k], B[k])
    return B


@kernel
def converged(phi, scale, tol, it, done, iterations, residual, final):
    """One convergence test of the block Newton (kinem.march): the instants
    not yet done whose max |phi_i| / scale_i is <= tol are marked done, with
    the iteration count, that residual and phi recorded. Returns the indices
    of the instants to iterate on: not done, residual finite."""
    K, m = phi.shape
    active = np.empty(K, np.intp)
    count = 0
    for k in range(K):
        if done[k]:
            continue
        r = 0.0
        for i in range(m):
            v = abs(phi[k, i]) / scale[i]
            if v > r or v != v:  # a nan stays
                r = v
        if r <= tol:
            done[k], iterations[k], residual[k] = True, it, r
            final[k] = phi[k]
        elif r < np.inf:
            active[count] = k
            count += 1
    return active[:count]


@kernel
def newton_step(LU, piv, phi, active, scale, col_scale, max_step, Q):
    """Q[active[a]] += -Phi_q^-1 phi (Phi_q's dimensionless LU factors in
    LU[a], piv[a]), the step limited to max_step in dimensionless
    coordinates. A zero pivot gives a non-finite step: that instant's next
    residual is not finite and it stops iterating."""
    n = Q.shape[1]
    b = np.empty(n)
    for a in range(active.shape[0]):
        k = active[a]
        for i in range(n):
            b[i] = -phi[k, i] / scale[i]
        _solve1(LU[a], piv[a], b)
        size = 0.0
        for i in range(n):
            size = max(size, abs(b[i]))
        f = min(1.0, max_step / size)
        for i in range(n):
            Q[k, i] += f * b[i] * col_scale[i]


def warm() -> None:
    """Compiles (or loads from the cache) the kernels, so that a timed
    analysis does not pay for it."""
    A = assemble(np.ones((1, 2)), np.arange(2), np.arange(2), np.ones(2), np.empty((1, 2, 2)))
    solve(A, factor(A), np.ones((1, 2)))
