"""LU factorisation and solves of many small dense matrices at once, compiled
with numba (the block march, kinem.march).

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
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
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


@njit(cache=True, nogil=True, error_model="numpy")
def solve(LU, piv, B):
    """X[k] with A[k] X[k] = B[k] (K, n) from factor's result; B is overwritten
    and returned."""
    K, n = LU.shape[0], LU.shape[1]
    for k in range(K):
        a, b = LU[k], B[k]
        for j in range(n):
            p = piv[k, j]
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
    return B


def warm() -> None:
    """Compiles (or loads from the cache) both kernels, so that a timed
    analysis does not pay for it."""
    A = np.eye(2)[None].copy()
    solve(A, factor(A), np.ones((1, 2)))
