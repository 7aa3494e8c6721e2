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
def assemble(values, block, rows, cols, scale, pad, J):
    """Dense Jacobians J (K * C, m, n), overwritten, from their values
    (K, nnz): entry e of instant k, times scale[e], at J[k * C + block[e],
    rows[e], cols[e]] (C = 1: the whole Jacobian; C diagonal blocks:
    kinem.model.Blocks), and 1 on the diagonal at the padding positions
    p (block p // n, index p % n)."""
    K = values.shape[0]
    C, n = J.shape[0] // max(K, 1), J.shape[2]
    J[:] = 0.0
    for k in range(K):
        for e in range(rows.shape[0]):
            J[k * C + block[e], rows[e], cols[e]] = values[k, e] * scale[e]
        for p in pad:
            J[k * C + p // n, p % n, p % n] = 1.0
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
def newton_step(LU, piv, phi, active, scale, col_scale, row_pos, col_pos, max_step, Q):
    """Q[active[a]] += -Phi_q^-1 phi, from the LU factors of the C
    dimensionless diagonal blocks of instant a's Phi_q (LU[a * C + c],
    piv[...]; row i and coordinate j at positions row_pos[i], col_pos[j] of
    the blocks side by side, kinem.model.Blocks), the step limited to
    max_step in dimensionless coordinates. A zero pivot gives a non-finite
    step: that instant's next residual is not finite and it stops iterating."""
    s = LU.shape[1]
    C = LU.shape[0] // max(active.shape[0], 1)
    b = np.zeros(C * s)
    for a in range(active.shape[0]):
        k = active[a]
        b[:] = 0.0
        for i in range(row_pos.shape[0]):
            b[row_pos[i]] = -phi[k, i] / scale[i]
        for c in range(C):
            _solve1(LU[a * C + c], piv[a * C + c], b[c * s: (c + 1) * s])
        size = 0.0
        for j in range(col_pos.shape[0]):
            size = max(size, abs(b[col_pos[j]]))
        f = min(1.0, max_step / size)
        for j in range(col_pos.shape[0]):
            Q[k, j] += f * b[col_pos[j]] * col_scale[j]


def warm(model) -> None:
    """Compiles (or loads from the cache) the kernels for the model's arrays,
    so that a timed analysis does not pay for it."""
    b = model.blocks
    J = assemble(np.zeros((1, model.nnz)), *b.entries, model.entry_scale, b.pad, np.empty((b.count, b.size, b.size)))
    J[:] = np.eye(b.size)
    piv = factor(J)
    solve(J, piv, np.ones((b.count, b.size)))
    phi = np.ones((1, model.m))
    active = converged(phi, model.scale, 0.0, 0, np.zeros(1, bool), np.zeros(1, int), np.zeros(1), np.zeros((1, model.m)))
    newton_step(J, piv, phi, active, model.scale, model.col_scale, b.row_pos, b.col_pos, 0.5, np.zeros((1, model.n)))
