"""The compiled march loop (docs/solver.md, "The march"): Newton-Raphson
position analysis (kinem.newton.settle), the acceptance test and the
velocity and acceleration solves at every output instant, in one compiled
function.

``run`` is the source of the march of every model: kinem.march writes a
module made of it with kinem.newton.settle's statements in place of its
call, those of ``evaluate``, ``factor`` and ``correct`` in place of
settle's operations, and the evaluator calls ``phi_all``, ``jac_all`` and
``gamma_all`` written out for the model's constraint families (each
family's kernel on its slice of the rows); numba compiles that once per
set of families, cached on disk. Here, read as a module, the evaluators
are missing: nothing calls ``run`` from this module itself. The helpers
above the operations are compiled here, once, and imported by every
generated module.
"""
import numpy as np

from kinem.dense import MASK, _solve1, assemble, band_factor, band_solve, factor_into, sparse_factor, sparse_solve
from kinem.jit import kernel
from kinem.newton import NOT_CONVERGED, settle
from kinem.tracking import jump_sizes, lagrange, rejected

# Why ``run`` hands an instant back to the tracker: kinem.tracking's codes, and
# kinem.newton.NOT_CONVERGED.


@kernel
def residual(phi, scale):
    """max |phi_i| / scale_i; a NaN gives NaN."""
    r = 0.0
    for i in range(phi.shape[0]):
        v = abs(phi[i]) / scale[i]
        if v > r or v != v:
            r = v
    return r


@kernel
def rotate(q, angles, E):
    """E[0, j] = exp(i q[0, j]) at the angle columns j: once per configuration
    for every family (kinem.constraints.base.rotations)."""
    for j in angles:
        E[0, j] = np.exp(1j * q[0, j])


@kernel
def factorize(J, piv, band, patterns, rm, cm):
    """LU of J_s: of its diagonal blocks (dense; blocks of up to MASK
    coordinates visiting only their nonzeros, kinem.dense.sparse_factor,
    from their patterns (2, count, size) into the row and column masks rm,
    cm), or banded (kinem.model.Band: band = (kl, ku, size, coupling rows,
    coupling columns); kl < 0: dense)."""
    kl, ku, size = band[0], band[1], band[2]
    if kl < 0:
        if J.shape[1] <= MASK:
            for c in range(J.shape[0]):
                rm[c] = patterns[0, c]
                cm[c] = patterns[1, c]
                sparse_factor(J[c], piv[c], rm[c], cm[c])
        else:
            factor_into(J, piv)
    else:
        band_factor(J[0, :J.shape[1] - 2, :size], piv[0, :size], kl, ku)


@kernel
def lu_solve(J, piv, band, rm, b, row_pos, col_pos, scale, col_scale, x, w):
    """x = Phi_q^-1 b from the LU factors of J_s = diag(1/scale) Phi_q
    diag(col_scale): b's row i at position row_pos[i], x's coordinate j at
    col_pos[j]; w: work. Dense: the diagonal blocks (kinem.model.Blocks;
    rm: their factors' row masks, ``factorize``).
    Banded (kinem.model.Band): the single-entry rows' coordinates first,
    their columns' terms moved to the right side, then the band."""
    kl, ku, size, cr, cs = band
    w[:] = 0.0
    for i in range(row_pos.shape[0]):
        w[row_pos[i]] = b[i] / scale[i]
    if kl < 0:
        s = J.shape[1]
        for c in range(J.shape[0]):
            if s <= MASK:
                sparse_solve(J[c], piv[c], rm[c], w[c * s:(c + 1) * s])
            else:
                _solve1(J[c], piv[c], w[c * s:(c + 1) * s])
    else:
        H = J.shape[1]
        for s in range(x.shape[0] - size):
            w[size + s] /= J[0, H - 2, s]
        for e in range(cr.shape[0]):
            w[cr[e]] -= J[0, H - 1, e] * w[size + cs[e]]
        band_solve(J[0, :H - 2, :size], piv[0, :size], kl, ku, w[:size])
    for j in range(col_pos.shape[0]):
        x[j] = w[col_pos[j]] * col_scale[j]


@kernel
def refine(J, piv, band, rm, phi, row_pos, col_pos, scale, col_scale, dq, w, b, q1, max_step):
    """q1 += -Phi_q^-1 phi from the LU factors, the step limited to max_step
    in dimensionless coordinates: a Newton step, or the final correction.
    Returns the step's size (dimensionless, before the limit)."""
    for i in range(b.shape[0]):
        b[i] = -phi[0, i]
    lu_solve(J, piv, band, rm, b, row_pos, col_pos, scale, col_scale, dq, w)
    big = 0.0
    for j in range(dq.shape[0]):
        big = max(big, abs(dq[j]) / col_scale[j])
    f = min(1.0, max_step / big) if big > 0 else 1.0
    for j in range(dq.shape[0]):
        q1[0, j] += f * dq[j]
    return big


@kernel
def lu_stats(J, piv, band, real, sign):
    """(pivot ratio, sign of det) of J_s from its LU factors: the smallest
    over the largest |pivot| at the ``real`` positions (not padding; 0 when
    any is not finite) and sign times the product of the pivots' and row
    interchanges' signs (kinem.linalg.pivot_ratio, lu_det_sign); banded:
    the single entries count as pivots."""
    kl, ku, size = band[0], band[1], band[2]
    small, big, det = np.inf, 0.0, sign
    if kl < 0:
        C, s = J.shape[0], J.shape[1]
    else:
        C, s = 1, real.shape[0]
    for c in range(C):
        for j in range(s):
            if kl < 0:
                d, swapped = J[c, j, j], piv[c, j] != j
            elif j < size:
                d, swapped = J[0, kl + ku, j], piv[0, j] != j
            else:
                d, swapped = J[0, J.shape[1] - 2, j - size], False
            if swapped:
                det = -det
            if d < 0:
                det = -det
            elif d == 0:
                det = 0
            if real[c * s + j]:
                a = abs(d)
                if not a < np.inf:
                    return 0.0, det
                small, big = min(small, a), max(big, a)
    return (small / big if big > 0 else 0.0), det


# kinem.newton.settle's operations in the march: kinem.march writes their
# statements in place of their calls (``work`` is None: they use run's own
# arrays).
def evaluate(q1, k, work, it):
    """Phi at q1 (1, n) into phi, and its max scaled residual."""
    rotate(q1, angles, E1)
    phi_all(q1, E1, k, A, phi)
    return residual(phi[0], scale)


def factor(q1, work, final):
    """J_s at q1 assembled into J and factorised (always at q1)."""
    rotate(q1, angles, E1)
    jac_all(q1, E1, A, values)
    assemble(values, blk, rows, cols, entry_scale, pad, J)
    factorize(J, piv, band, patterns, rm, cm)
    counts[0] += 1
    counts[1] += 1


def correct(q1, work, limit):
    """q1 -= Phi_q^-1 phi from the LU (``refine``)."""
    return refine(J, piv, band, rm, phi, row_pos, col_pos, scale, col_scale, dq, w, b, q1, limit)


@kernel
def run(times, k, state, A, nu, structure, settings, out):
    """March from the accepted state (q, qd, qdd at state time and det sign)
    over the output instants times[k:], until one is not accepted. From
    k = 0 it first assembles from the estimates in q (Newton from them,
    accepted when its pivot ratio is above the floor: the tracker's start
    takes the rest, with its diagnoses). Each instant: the Taylor
    predictor from the last state, Newton-Raphson with steps limited to
    max_step (dimensionless), the final correction and the LU at the
    corrected q (kinem.newton.settle), its pivot ratio and det sign, the
    acceptance test (kinem.tracking.rejected) and the rates from that LU:
    to rounding, not to the tolerance.

    state: (q, qd, qdd (n,), last (2,): time and det sign, H (3, n), T (3,):
    the last three states' q and t, oldest first, NaN for none), updated to
    the last accepted instant. With ``rates`` (settings) the predictor is
    Taylor's from q, qd, qdd and the rates are solved at every instant;
    without, it extrapolates through H (``lagrange``) and no rate is solved.
    A: the families' arguments (kinem.march). nu: (K, m). structure:
    (entries (block, row, col), entry_scale, row_pos, col_pos, pad, real,
    sign, scale, col_scale, count, size, height, width, band, angles,
    patterns): J_s's diagonal blocks (kinem.model.Blocks; band[0] < 0) or
    its band (kinem.model.Band), stored in J (count, height, width); the
    angle columns, whose exp(i q) the kernels read (``rotate``); the
    blocks' patterns as bit masks (kinem.dense.masks; ``factorize``). settings:
    (tolerance, max iterations, max step, pivot floor, rates). out: (Q, QD,
    QDD (K, n), iterations, residual, pivot (K,), counts (2,): Jacobian
    evaluations and factorisations, added to). Returns (the first instant
    not accepted, or K, and why: 0, NOT_CONVERGED or the tracker's code)."""
    q, qd, qdd, last, H, T = state
    (blk, rows, cols, entry_scale, row_pos, col_pos, pad, real, sign, scale, col_scale, count, size, height, width,
     band, angles, patterns) = structure
    tol, max_it, max_step, floor, rates = settings
    Q, QD, QDD, iterations, residuals, pivots, counts = out
    n, m, K = q.shape[0], scale.shape[0], times.shape[0]
    q1 = np.empty((1, n))
    E1 = np.ones((1, n), np.complex128)
    qd1 = np.empty((1, n))
    phi = np.empty((1, m))
    g = np.empty((1, m))
    values = np.empty((1, rows.shape[0]))
    J = np.empty((count, height, width))
    piv = np.empty((count, size), np.int32)
    rm = np.empty((count, size), np.uint64)
    cm = np.empty((count, size), np.uint64)
    qp = np.empty(n)
    dq = np.empty(n)
    b = np.empty(m)
    w = np.empty(max(count * size, n))
    while k < K:
        t = times[k]
        h = t - last[0]
        judge = k > 0
        if k == 0:  # the assembly: from the estimates in q
            qp[:] = q
        elif rates:
            for j in range(n):
                qp[j] = q[j] + h * qd[j] + 0.5 * h * h * qdd[j]
        else:
            judge = lagrange(t, T, H, qp) >= 1
        for j in range(n):
            q1[0, j] = qp[j]
        it, r, why, last_step = settle(q1, k, None, tol, max_it, max_step, True)
        if why != 0:
            return k, why
        ratio, det = lu_stats(J, piv, band, real, sign)
        corr, move = jump_sizes(q1[0], qp, q, col_scale)
        # the assembly is not tested for a jump or a det flip: it has no state before it
        why = rejected(ratio, last_step, det, det if k == 0 else int(last[1]), corr, move, judge, floor, tol, False)
        if why != 0:
            return k, why
        for j in range(n):
            q[j] = q1[0, j]
        if rates:
            lu_solve(J, piv, band, rm, nu[k], row_pos, col_pos, scale, col_scale, qd, w)
            for j in range(n):
                qd1[0, j] = qd[j]
            gamma_all(q1, qd1, E1, k, A, g)
            lu_solve(J, piv, band, rm, g[0], row_pos, col_pos, scale, col_scale, qdd, w)
            QD[k] = qd
            QDD[k] = qdd
        else:
            for i in range(2):
                T[i] = T[i + 1]
                H[i] = H[i + 1]
            T[2] = t
            H[2] = q
        last[0], last[1] = t, det
        Q[k] = q
        iterations[k], residuals[k], pivots[k] = it, r, ratio
        k += 1
    return k, 0


phi_all = jac_all = gamma_all = None  # written for each model's families (kinem.march)
