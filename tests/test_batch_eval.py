"""Batched evaluation: every constraint family, the driving functions and the
outlines take a batch of configurations q (..., n), velocities qd (..., n)
and times t (...) (or one t for all), and give the per-instant results
stacked on the leading axes.

The batch does the same arithmetic as one instant, element by element,
except the driving polynomials: a matrix product over the batch instead of
a matrix-vector product, which may sum c_k t^k in another order (and fuse
multiply-adds differently). So results agree to a few ulp of the largest
term: TOL relative to max(1, |value|), as in tests/fd.py; most are equal
bit for bit.
"""
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import given, strategies as st
from hypothesis.extra.numpy import arrays

import kinem
from conftest import ROOT
from kinem.functions import FunctionSet, Harmonic, Poly, Table
from kinem.outline import Outline, OutlineSet

TOL = 1e-12
CASES = sorted(str(p.relative_to(ROOT)) for p in [*ROOT.glob("cases/*.toml"), *ROOT.glob("cases/stress/*.toml")])


@lru_cache(maxsize=None)
def model_of(path):
    return kinem.compile(kinem.load(ROOT / path))


def assert_same(batched, single, what):
    """batched equals the per-instant results stacked, in shape and to TOL."""
    single = np.asarray(single)
    assert batched.shape == single.shape, f"{what}: shape {batched.shape}, per instant {single.shape}"
    if single.size:
        err = float(np.max(np.abs(batched - single)) / max(1.0, float(np.max(np.abs(single)))))
        assert err <= TOL, f"{what}: batch differs from the per-instant results by {err:.1e}"


def check_batch(model, Q, QD, T):
    """Batched phi, Jacobian values, nu, gamma and the dense Jacobians of
    (Q, QD, T) (leading shape S) against one instant at a time."""
    S = T.shape
    index = list(np.ndindex(S))
    stack = lambda f: np.array([f(k) for k in index]).reshape(S + (-1,))
    one = lambda k: (Q[k], QD[k], float(T[k]))
    assert_same(model.phi(Q, T), stack(lambda k: model.phi(Q[k], float(T[k]))), "phi")
    values = model.jac_values(Q, T)
    assert_same(values, stack(lambda k: model.jac_values(Q[k], float(T[k]))), "jac_values")
    assert_same(model.nu(T), stack(lambda k: model.nu(float(T[k]))), "nu")
    assert_same(model.gamma(Q, QD, T), stack(lambda k: model.gamma(*one(k))), "gamma")
    J = model.assemble(values, sparse=False)
    dense = np.array([model.jacobian(Q[k], float(T[k]), sparse=False) for k in index]).reshape(S + (model.m, model.n))
    assert_same(J, dense, "assemble")
    assert_same(model.scaled_residual(model.phi(Q, T)),
                stack(lambda k: model.scaled_residual(model.phi(Q[k], float(T[k])))), "scaled_residual")


def draw_batch(draw, model, shape):
    """Configurations near q0 (up to 0.1 L in x, y, 0.1 rad in angles and
    theta), velocities up to 3 (L or rad per unit time), times over the case's span."""
    n = model.n
    delta = draw(arrays(float, shape + (n,), elements=st.floats(-0.1, 0.1)))
    qd = draw(arrays(float, shape + (n,), elements=st.floats(-3.0, 3.0)))
    t0, t1 = float(model.times[0]), float(model.times[-1])
    t = draw(arrays(float, shape, elements=st.floats(t0, t1)))
    return model.q0 + model.col_scale * delta, model.col_scale * qd, t


@pytest.mark.parametrize("path", CASES)
@given(data=st.data())
def test_batch_equals_instants(path, data):
    model = model_of(path)
    K = data.draw(st.integers(1, 5), label="K")
    check_batch(model, *draw_batch(data.draw, model, (K,)))


@pytest.mark.parametrize("path", ["cases/four_bar.toml", "cases/cam_table41.toml", "cases/pin_in_spline_slot.toml",
                                  "cases/planetary.toml", "cases/stress/parallelogram_redundant.toml"])
def test_two_leading_axes(path):
    model = model_of(path)
    rng = np.random.default_rng(7)
    Q = model.q0 + model.col_scale * rng.uniform(-0.1, 0.1, (2, 3, model.n))
    QD = rng.uniform(-3.0, 3.0, (2, 3, model.n))
    T = rng.uniform(float(model.times[0]), float(model.times[-1]), (2, 3))
    check_batch(model, Q, QD, T)
    assert model.phi(Q, T).shape == (2, 3, model.m)
    assert model.assemble(model.jac_values(Q, T), sparse=False).shape == (2, 3, model.m, model.n)


@pytest.mark.parametrize("path", CASES)
def test_one_time_for_a_batch(path):
    """A batch of configurations at one scalar t: every family broadcasts t."""
    model = model_of(path)
    rng = np.random.default_rng(3)
    Q = model.q0 + model.col_scale * rng.uniform(-0.1, 0.1, (4, model.n))
    QD = rng.uniform(-3.0, 3.0, (4, model.n))
    t = float(model.times[len(model.times) // 2])
    assert_same(model.phi(Q, t), [model.phi(q, t) for q in Q], "phi")
    assert_same(model.jac_values(Q, t), [model.jac_values(q, t) for q in Q], "jac_values")
    assert_same(model.gamma(Q, QD, t), [model.gamma(q, qd, t) for q, qd in zip(Q, QD)], "gamma")


def test_a_batch_of_sparse_jacobians_is_refused():
    model = model_of("cases/four_bar.toml")
    with pytest.raises(ValueError):
        model.assemble(np.zeros((2, model.nnz)), sparse=True)


def test_single_instant_shapes_unchanged():
    for path in CASES:
        model = model_of(path)
        q, t = model.q0, float(model.times[0])
        assert model.phi(q, t).shape == (model.m,)
        assert model.jac_values(q, t).shape == (model.nnz,)
        assert model.nu(t).shape == (model.m,)
        assert model.gamma(q, np.ones(model.n), t).shape == (model.m,)


FUNCS = [Poly((0.3,)), Poly((0.7853981633974483, 1.5, -0.6)), Poly((1.0, -2.0, 0.5, 0.25)),
         Harmonic(1.3, 2.1, 0.2, 0.5), Harmonic(-0.4, 0.7),
         Table((0.0, 0.5, 1.2, 2.0, 3.0), (0.0, 0.3, -0.2, 0.8, 1.0))]


@given(t=arrays(float, st.sampled_from([(1,), (5,), (2, 3)]), elements=st.floats(-1.0, 4.0)),
       order=st.integers(0, 2))
def test_function_set_batch(t, order):
    fs = FunctionSet(FUNCS)
    got = fs(t, order)
    want = np.array([fs(float(x), order) for x in t.ravel()]).reshape(t.shape + (len(FUNCS),))
    assert_same(got, want, f"FunctionSet order {order}")
    assert fs(float(t.flat[0]), order).shape == (len(FUNCS),)


OUTLINES = [Outline.circle(0.8, center=(0.1, -0.2)),
            Outline.spline(np.linspace(0.0, 2 * np.pi, 7), [1.0, 1.2, 1.1, 1.4, 1.3, 1.05, 1.0], periodic=True),
            Outline.spline([-0.5, 0.2, 0.9, 1.7], [1.0, 1.3, 1.2, 1.1], bc="natural", center=(0.3, 0.0))]


@given(theta=arrays(float, st.sampled_from([(1,), (4,), (2, 3)]), elements=st.floats(-20.0, 20.0)))
def test_outline_set_batch(theta):
    """OutlineSet.radius and .curve take theta (..., n_outlines): outline k at theta[..., k]."""
    os_ = OutlineSet(OUTLINES)
    th = theta[..., None] + np.array([0.0, 0.5, -0.3])  # (..., 3): each outline its own angle
    for name in ("radius", "curve"):
        got = getattr(os_, name)(th)
        for part, g in enumerate(got):
            want = np.array([getattr(os_, name)(row)[part] for row in th.reshape(-1, 3)]).reshape(th.shape)
            assert np.array_equal(g, want), f"OutlineSet.{name}[{part}]"
