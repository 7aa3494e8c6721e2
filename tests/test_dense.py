"""The compiled batched LU (kinem/dense.py) against LAPACK (scipy), and the
compiled march's final Newton correction against closed-form kinematics."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.linalg
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import kinem
from closed_form import slider_crank
from kinem import dense, march
from kinem.linalg import lu_det_sign, pivot_ratio

CASES = Path(__file__).resolve().parents[1] / "cases"
entries = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=False)


@settings(max_examples=60)
@given(st.integers(1, 13).flatmap(lambda n: arrays(np.float64, (3, n, n), elements=entries)))
def test_factor_and_solve_match_lapack(A):
    """Same pivots as getrf (same elimination, rounding aside) and solves to
    the accuracy the conditioning allows: |x - x_lapack| <= 1e3 eps cond |x|
    (backward-stable LU: residual ~ n eps |A||x|, amplified by cond)."""
    K, n, _ = A.shape
    LU = A.copy()
    piv = dense.factor(LU)
    b = np.arange(1.0, n + 1)
    X = dense.solve(LU, piv, np.tile(b, (K, 1)))
    for k in range(K):
        cond = np.linalg.cond(A[k])
        if not np.isfinite(cond) or cond > 1e10:
            continue  # near-singular: pivot choice and solution are rounding-dependent
        lu, p = scipy.linalg.lu_factor(A[k])
        if np.array_equal(piv[k], p):
            assert np.allclose(LU[k], lu, rtol=1e-9, atol=1e-9 * np.abs(A[k]).max())
        else:
            # an exact tie between candidate pivots (repeated entries, e.g. 115.875 in rows
            # [a, a, a], [a, 0, a], [0, a, a]): getrf's blocked elimination may round one
            # candidate a few ulps apart and take the other. Either row is a valid partial
            # pivot, so U's diagonal magnitudes agree to rounding (1e-12: a few ulps per
            # elimination step); the solve and determinant checks below apply as before.
            assert np.allclose(np.abs(np.diag(LU[k])), np.abs(np.diag(lu)), rtol=1e-12)
        x = scipy.linalg.lu_solve((lu, p), b)
        assert np.linalg.norm(X[k] - x) <= 1e3 * np.finfo(float).eps * cond * np.linalg.norm(x)
        diag = np.diag(LU[k])
        assert lu_det_sign(diag, piv[k]) == np.sign(np.linalg.det(A[k]))


@st.composite
def sparse_matrices(draw):
    """Jacobian-like sparse matrices: a few entries a row, many of them +-1
    (exact ties between candidate pivots), some zero after elimination."""
    n = draw(st.integers(1, dense.MASK))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    values = np.array([1.0, -1.0, 0.5, 2.0, rng.normal(), -rng.normal()])
    A = np.where(rng.random((n, n)) < 3.0 / n, rng.choice(values, size=(n, n)), 0.0)
    A[np.arange(n), rng.permutation(n)] = rng.choice([1.0, -1.0, 3.0], size=n)
    if draw(st.booleans()):
        A[rng.integers(n)] = 0.0  # a zero row: singular, a zero pivot somewhere
    return A


@settings(max_examples=150, deadline=None)
@given(sparse_matrices())
def test_sparse_factor_is_factor_into_to_the_bit(A):
    """The masked LU (dense.sparse_factor) makes factor_into's pivot choices,
    ties included, and its arithmetic on every nonzero: the same factors
    and pivots to the bit, so the pivot ratio and det sign do not depend on
    which one the march takes. Its solve sums in another order: the same
    solution to rounding (1e3 eps cond, as against LAPACK above)."""
    n = A.shape[0]
    LU, piv = A[None].copy(), np.zeros((1, n), np.int32)
    dense.factor_into(LU, piv)
    pattern = np.argwhere(A != 0)
    m = dense.masks(np.zeros(len(pattern), np.intp), pattern[:, 0].astype(np.intp), pattern[:, 1].astype(np.intp),
                    np.empty(0, np.intp), 1, n)
    a, p, rm, cm = A.copy(), np.zeros(n, np.int32), m[0, 0].copy(), m[1, 0].copy()
    dense.sparse_factor(a, p, rm, cm)
    assert np.array_equal(p, piv[0])
    assert np.array_equal(a, LU[0], equal_nan=True)
    for i in range(n):  # the masks cover the factors' nonzeros
        cols = [c for c in range(n) if int(rm[i]) >> c & 1]
        assert set(np.flatnonzero(a[i])) <= set(cols)
    cond = np.linalg.cond(A)
    if np.isfinite(cond) and cond < 1e10:
        b = np.arange(1.0, n + 1)
        x, y = b.copy(), b.copy()
        dense._solve1(LU[0], piv[0], x)
        dense.sparse_solve(a, p, rm, y)
        assert np.linalg.norm(x - y) <= 1e3 * np.finfo(float).eps * cond * np.linalg.norm(x)


def test_a_zero_pivot_gives_pivot_ratio_zero_without_error():
    A = np.array([[[1.0, 2.0], [2.0, 4.0]]])
    piv = dense.factor(A)
    assert pivot_ratio(np.diagonal(A, axis1=1, axis2=2))[0] == 0.0
    with np.errstate(all="ignore"):
        x = dense.solve(A, piv, np.ones((1, 2)))
    assert not np.isfinite(x).all()


def test_final_correction_makes_a_loose_tolerance_accurate():
    """One Newton correction after convergence squares the error: at
    tolerance 1e-6 the positions of the book's slider-crank come out within
    1e-9 of the closed form (about tol^2 times the Jacobian's conditioning,
    ~1e2 here, with margin), where without it they would be ~1e-6 off."""
    case = replace(kinem.load(CASES / "slider_crank.toml"), tolerance=1e-6)
    model = kinem.compile(case)
    assert march.usable(model, False, len(model.times))
    r = kinem.solve(model)
    assert r.success and r.residual.max() > 1e-9  # Newton really stopped early somewhere
    t = r.trajectory.t
    ref = slider_crank(5.76 - 1.2 * t + np.pi, np.full_like(t, -1.2), np.zeros_like(t), 200.0, 500.0, 0.0)
    assert np.abs(r.trajectory["slider.x"] - ref["x"]).max() / 500.0 <= 1e-9


def test_short_runs_go_step_by_step():
    """Below MIN_INSTANTS output instants the compiled march is not used (the
    compiled kernels would cost more to load than they save): the run equals
    the step-by-step one exactly."""
    case = replace(kinem.load(CASES / "four_bar.toml"), steps=march.MIN_INSTANTS - 2)
    a = kinem.solve(kinem.compile(case))
    b = kinem.solve(kinem.compile(replace(case, block=1)))
    assert np.array_equal(a.q, b.q) and np.array_equal(a.iterations, b.iterations)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 25), st.integers(0, 3), st.integers(0, 4), st.integers(0, 2**31 - 1))
def test_band_lu_is_lapacks_gbtrf(n, kl, ku, seed):
    """kinem.dense.band_factor makes LAPACK's dgbtrf pivot choices and U
    diagonal, and band_solve solves the system (to 1e-8 of |b| where the
    matrix's condition number is below 1e8: rounding times the conditioning)."""
    from scipy.linalg.lapack import dgbtrf

    rng = np.random.default_rng(seed)
    A = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            A[i, j] = rng.normal() if rng.random() > 0.2 else 0.0
    AB = np.zeros((2 * kl + ku + 1, n))
    i, j = np.nonzero(A)
    AB[kl + ku + i - j, j] = A[i, j]
    lapack, ipiv, info = dgbtrf(AB.copy(), kl, ku)
    piv = np.zeros(n, np.int32)
    dense.band_factor(AB, piv, kl, ku)
    if info == 0:
        np.testing.assert_array_equal(piv, ipiv)
        np.testing.assert_allclose(AB[kl + ku], lapack[kl + ku], rtol=1e-10, atol=1e-12)
        if np.linalg.cond(A) < 1e8:
            b = rng.normal(size=n)
            x = b.copy()
            dense.band_solve(AB, piv, kl, ku, x)
            assert np.allclose(A @ x, b, atol=1e-8 * np.abs(b).max())
