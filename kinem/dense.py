"""Assembly, LU factorisation and solves of many small dense matrices at
once, compiled with numba (Model.assemble, the compiled march kinem.loop).

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

from .jit import kernel, trailing_zeros


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
    return factor_into(A, np.empty((A.shape[0], A.shape[1]), np.int32))


@kernel
def factor_into(A, piv):
    """LU of each A[k] (K, n, n) in place, the pivots into piv (K, n)."""
    K, n = A.shape[0], A.shape[1]
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
                r = 1.0 / d
                for i in range(j + 1, n):
                    f = a[i, j] * r
                    a[i, j] = f
                    if f != 0.0:
                        for c in range(j + 1, n):
                            a[i, c] -= f * a[j, c]
    return piv


@kernel
def _solve1(a, piv, b):
    """b <- A^-1 b from one matrix's LU factors a and pivots. Column by
    column (axpy), as LAPACK's getrs: the updates of one column are
    independent, where a row's dot product is one chain of dependent adds
    (measured on 12 x 12: 105 ns against 186 ns)."""
    n = a.shape[0]
    for j in range(n):
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
    for j in range(n):
        x = b[j]
        if x != 0.0:
            for i in range(j + 1, n):
                b[i] -= a[i, j] * x
    for j in range(n - 1, -1, -1):
        x = b[j] / a[j, j]
        b[j] = x
        if x != 0.0:
            for i in range(j):
                b[i] -= a[i, j] * x


@kernel
def solve(LU, piv, B):
    """X[k] with A[k] X[k] = B[k] (K, n) from factor's result; B is overwritten
    and returned."""
    for k in range(LU.shape[0]):
        _solve1(LU[k], piv[k], B[k])
    return B


# Blocks up to this many coordinates are factorised visiting only their
# structural nonzeros (``sparse_factor``): their rows' and columns' patterns
# fit 64-bit masks.
MASK = 64


@kernel
def masks(block, rows, cols, pad, count, size):
    """The patterns of J's diagonal blocks as bit masks (2, count, size):
    [0, c, i] the columns of block c's row i, [1, c, j] the rows of its
    column j (the Jacobian's entries at (block, rows, cols), and the
    padding's diagonal ones at p: block p // size, index p % size)."""
    out = np.zeros((2, count, size), np.uint64)
    one = np.uint64(1)
    for e in range(rows.shape[0]):
        c, i, j = block[e], rows[e], cols[e]
        out[0, c, i] |= one << np.uint64(j)
        out[1, c, j] |= one << np.uint64(i)
    for p in pad:
        c, i = p // size, p % size
        out[0, c, i] |= one << np.uint64(i)
        out[1, c, i] |= one << np.uint64(i)
    return out


@kernel
def sparse_factor(a, piv, rm, cm):
    """factor_into's LU of one matrix a (n <= MASK), visiting only its
    structural nonzeros: rm[i] has the columns of row i, cm[j] the rows of
    column j (bit masks: in, a's pattern; out, the factors', fill
    included). The same pivots, in the same order, and the same
    arithmetic on every nonzero, so the same factors to the bit; on the
    Jacobians of small mechanisms (most entries zero) 3 to 4 times faster."""
    n = a.shape[0]
    one = np.uint64(1)
    for j in range(n):
        bj = one << np.uint64(j)
        p, big = j, abs(a[j, j])
        m = (cm[j] >> np.uint64(j)) >> one  # two shifts: one of 64 bits is undefined
        while m:  # the rows below j with an entry in column j, first to last
            i = j + 1 + trailing_zeros(m)
            m &= m - one
            v = abs(a[i, j])
            if v > big:
                p, big = i, v
        piv[j] = p
        if p != j:
            bp = one << np.uint64(p)
            u = rm[j] | rm[p]
            while u:
                c = trailing_zeros(u)
                u &= u - one
                a[j, c], a[p, c] = a[p, c], a[j, c]
                x = cm[c] & (bj | bp)
                if x == bj or x == bp:
                    cm[c] ^= bj | bp
            rm[j], rm[p] = rm[p], rm[j]
        d = a[j, j]
        if d != 0.0:
            r = 1.0 / d
            upper = rm[j] & ~((bj << one) - one)
            m = (cm[j] >> np.uint64(j)) >> one  # two shifts: one of 64 bits is undefined
            while m:
                i = j + 1 + trailing_zeros(m)
                m &= m - one
                f = a[i, j] * r
                a[i, j] = f
                if f != 0.0:
                    bi = one << np.uint64(i)
                    u = upper
                    while u:
                        c = trailing_zeros(u)
                        u &= u - one
                        a[i, c] -= f * a[j, c]
                        cm[c] |= bi
                    rm[i] |= upper


@kernel
def sparse_solve(a, piv, rm, b):
    """b <- A^-1 b from sparse_factor's factors and row masks, row by row
    over each row's nonzeros."""
    n = a.shape[0]
    one = np.uint64(1)
    for j in range(n):
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
    for i in range(1, n):
        m = rm[i] & ((one << np.uint64(i)) - one)
        s = b[i]
        while m:
            c = trailing_zeros(m)
            m &= m - one
            s -= a[i, c] * b[c]
        b[i] = s
    for i in range(n - 1, -1, -1):
        m = (rm[i] >> np.uint64(i)) >> one
        s = b[i]
        while m:
            c = i + 1 + trailing_zeros(m)
            m &= m - one
            s -= a[i, c] * b[c]
        b[i] = s / a[i, i]


@kernel
def band_factor(AB, piv, kl, ku):
    """LU with partial pivoting of a band matrix in LAPACK's gbtrf storage
    (element (i, j) at AB[kl + ku + i - j, j], kl rows of fill-in space
    above), in place, as LAPACK's gbtf2: the row interchanges into piv (the
    row chosen for column j; 0-based). A zero pivot leaves its column
    unscaled."""
    n, kv = AB.shape[1], kl + ku
    ju = 0
    for j in range(n):
        km = min(kl, n - 1 - j)
        p, big = 0, abs(AB[kv, j])
        for i in range(1, km + 1):
            if abs(AB[kv + i, j]) > big:
                p, big = i, abs(AB[kv + i, j])
        piv[j] = j + p
        if AB[kv + p, j] == 0.0:
            continue
        ju = max(ju, min(j + ku + p, n - 1))
        if p != 0:
            for c in range(j, ju + 1):
                a, b = kv + j - c, kv + j + p - c
                AB[a, c], AB[b, c] = AB[b, c], AB[a, c]
        r = 1.0 / AB[kv, j]
        for i in range(1, km + 1):
            AB[kv + i, j] *= r
        for c in range(j + 1, ju + 1):
            t = AB[kv + j - c, c]
            if t != 0.0:
                for i in range(1, km + 1):
                    AB[kv + j + i - c, c] -= AB[kv + i, j] * t


@kernel
def band_solve(AB, piv, kl, ku, b):
    """b <- A^-1 b from band_factor's result."""
    n, kv = AB.shape[1], kl + ku
    for j in range(n):
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
        km = min(kl, n - 1 - j)
        for i in range(1, km + 1):
            b[j + i] -= AB[kv + i, j] * b[j]
    for j in range(n - 1, -1, -1):
        b[j] /= AB[kv, j]
        for i in range(max(0, j - kv), j):
            b[i] -= AB[kv + i - j, j] * b[j]
