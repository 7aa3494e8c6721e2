"""The compiled core (kinem._core, kinem/core) against the families' numba
kernels, and its refusal of malformed tables.

The cross-check is temporary (issue 23): it holds while the numba kernels
are still in the tree (the compiled march uses them until it is replaced)
and is skipped once they are gone (no Family.phi). For every constraint type, on random models
(tests/test_jacobians.py's builders, every kind of driving function and
outline) and random batches of configurations (angles and theta well beyond
2 pi, times beyond the function tables), Model.phi, jac_values, nu and
gamma, which evaluate through the core, equal the families' numba kernels
(Family.phi, jac, nu, gamma) to TOL relative to max(1, |value|): the same
equations, evaluated in a slightly different order (e^{i q} by sin_cos
instead of numpy's exp, a few products associated differently).

A malformed table (an index out of range, a column of the wrong length, a
missing column, a malformed function or outline table) raises
kinem.errors.CoreError when the core is built, never a crash.
"""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import kinem
from kinem._core import KINDS, Core
from kinem.errors import CoreError
from kinem.functions import FunctionTable
from kinem.constraints.base import Family
from kinem.outline import OutlineTable
from test_jacobians import BUILDERS, END, random_model

# the families' numba kernels, while they exist
numba_kernels = pytest.mark.skipif(not hasattr(Family, "phi"), reason="the families' numba kernels are gone")

TOL = 1e-12
FLAGS = {"point", "relative", "carrier"}  # int64 columns that are flags, not indices
# columns that index a body's x column: the kernels read c + 1 and c + 2 too
BODY_COLUMNS = {"revolute": {"ci", "cj"}, "line": {"ca", "cb"}, "distance": {"ci", "cj"},
                "rack-pinion": {"ci", "cj"}, "point-on-curve": {"cc", "cb"}, "cam-roller": {"cc", "cj"},
                "cam-flat": {"cc", "cj"}, "simple": set(), "gear": set()}


def numba_values(model, Q, QD, T):
    """phi, Jacobian values, nu and gamma by the families' numba kernels."""
    cat = lambda parts: np.concatenate(parts, axis=-1)
    nu = np.zeros(T.shape + (model.m,))
    for k in model.time_dependent:
        f = model.families[k]
        nu[..., model.offsets[k]: model.offsets[k] + f.n_rows] = f.nu(T)
    return (cat([f.phi(Q, T) for f in model.families]), cat([f.jac(Q, T) for f in model.families]), nu,
            cat([f.gamma(Q, QD, T) for f in model.families]))


def assert_close(core, numba, what):
    assert core.shape == numba.shape, f"{what}: shape {core.shape}, numba {numba.shape}"
    if numba.size:
        err = float(np.max(np.abs(core - numba) / np.maximum(1.0, np.abs(numba))))
        assert err <= TOL, f"{what}: the core differs from the numba kernels by {err:.1e}"


def random_batch(draw, model):
    """K configurations: x, y in [-2, 2], angles and theta in [-20, 20]; velocities, times beyond the tables."""
    K = draw(st.integers(1, 4), label="K")
    Q = draw(arrays(float, (K, model.n), elements=st.floats(-20.0, 20.0)))
    body = np.arange(model.n) < model.n - len(model.artificial)
    Q[:, body & (np.arange(model.n) % 3 != 2)] /= 10.0
    QD = draw(arrays(float, (K, model.n), elements=st.floats(-3.0, 3.0)))
    T = draw(arrays(float, (K,), elements=st.floats(-1.0, END + 1.0)))
    return Q, QD, T


def check(model, Q, QD, T):
    phi, jac, nu, gamma = numba_values(model, Q, QD, T)
    assert_close(model.phi(Q, T), phi, "phi")
    assert_close(model.jac_values(Q, T), jac, "jac_values")
    assert_close(model.nu(T), nu, "nu")
    assert_close(model.gamma(Q, QD, T), gamma, "gamma")
    # one instant: the same values
    assert_close(model.phi(Q[0], float(T[0])), phi[0], "phi (one instant)")
    assert_close(model.jac_values(Q[0], float(T[0])), jac[0], "jac_values (one instant)")
    assert_close(model.nu(float(T[0])), nu[0], "nu (one instant)")
    assert_close(model.gamma(Q[0], QD[0], float(T[0])), gamma[0], "gamma (one instant)")


@settings(max_examples=1)
@given(data=st.data())
def test_every_kind_is_covered(data):
    """The builders' types reach every family kind of the core."""
    kinds = {kind for ctype in BUILDERS for kind, _ in parts_of(random_model(data.draw, ctype))[0]}
    assert kinds == set(KINDS)


@numba_kernels
@pytest.mark.parametrize("ctype", sorted(BUILDERS))
@given(data=st.data())
def test_core_equals_numba_kernels(ctype, data):
    model = random_model(data.draw, ctype)
    check(model, *random_batch(data.draw, model))


@numba_kernels
@given(data=st.data())
def test_core_equals_numba_kernels_on_mixed_models(data):
    """Several types in one model: every family's rows and Jacobian entries at its offsets."""
    types = data.draw(st.lists(st.sampled_from(sorted(BUILDERS)), min_size=2, max_size=5, unique=True))
    cons = [dict(BUILDERS[t](data.draw), type=t) for t in types for _ in range(data.draw(st.integers(1, 2)))]
    model = kinem.compile(kinem.load_dict({
        "name": "mixed", "time": {"end": END, "steps": 3},
        "bodies": {f"b{k}": {"q": [0.0, 0.0, 0.0]} for k in range(3)}, "constraints": cons}))
    check(model, *random_batch(data.draw, model))


# -- malformed tables ----------------------------------------------------------

def parts_of(model):
    """Model.core's arguments after n (as kinem.model.compile makes them):
    the families' tables, the functions, the outlines, the angle columns."""
    functions, outlines = FunctionTable(), OutlineTable()
    tables = [f.table(functions, outlines) for f in model.families]
    bodies, art = len(model.case.bodies), len(model.artificial)
    angles = np.concatenate([3 * np.arange(bodies) + 2, 3 * bodies + np.arange(art)]).astype(np.int64)
    return tables, functions.arrays(), outlines.arrays(), angles


def build(model, tables, functions=None, outlines=None):
    _, f, o, angles = parts_of(model)
    return Core(model.n, tables, f if functions is None else functions, o if outlines is None else outlines, angles)


def corrupted(tables, k, column, value):
    """tables with family k's column replaced by value."""
    kind, cols = tables[k]
    out = list(tables)
    out[k] = (kind, dict(cols, **{column: value}))
    return out


@pytest.mark.parametrize("ctype", sorted(BUILDERS))
@given(data=st.data())
def test_malformed_tables_raise_core_error(ctype, data):
    model = random_model(data.draw, ctype)
    tables, functions, outlines, _ = parts_of(model)
    core = build(model, tables)  # the model's own tables are accepted, and are the model's core
    q, t = np.linspace(-1.0, 1.0, model.n), 0.4
    np.testing.assert_array_equal(core.phi(q[None], np.array([t]))[0], model.phi(q, t))
    np.testing.assert_array_equal(core.jac(q[None], np.array([t]))[0], model.jac_values(q, t))
    n, nf, no = model.n, len(functions["kind"]), len(outlines["first"])
    for k, (kind, cols) in enumerate(tables):
        for name, col in cols.items():
            if col.size:  # one entry fewer: the columns' lengths differ
                with pytest.raises(CoreError):
                    build(model, corrupted(tables, k, name, col[:-1]))
            rest = {c: v for c, v in cols.items() if c != name}  # a missing column
            with pytest.raises(CoreError):
                build(model, [(kd, rest) if j == k else (kd, cs) for j, (kd, cs) in enumerate(tables)])
            if col.dtype != np.int64 or name in FLAGS or not col.size:
                continue
            bound = {"f": nf, "outline": no}.get(name, n - 2 if name in BODY_COLUMNS[kind] else n)
            for bad in (-1, bound, bound + 7, 2**62):
                c = col.copy()
                c[data.draw(st.integers(0, len(c) - 1))] = bad
                with pytest.raises(CoreError, match=name):
                    build(model, corrupted(tables, k, name, c))
            c = col.copy()
            c[0] = bound - 1  # the largest index allowed
            build(model, corrupted(tables, k, name, c))


def test_unknown_kind_and_malformed_functions_and_outlines_raise_core_error():
    model = kinem.compile(kinem.load_dict({
        "name": "x", "time": {"end": 1.0, "steps": 1},
        "bodies": {"a": {"q": [0, 0, 0]}, "b": {"q": [0, 0, 0]}},
        "constraints": [{"type": "ground", "body": "a"},
                        {"type": "driver", "body": "b", "coord": "phi", "d": {"table": {"t": [0, 0.5, 1, 2],
                                                                                        "value": [0, 1, 0, 1]}}},
                        {"type": "cam-point", "cam": "a", "follower": "b", "sj": [0.0, 0.0], "theta": 0.1,
                         "outline": {"circle": {"radius": 1.0}}}]}))
    tables, functions, outlines, angles = parts_of(model)
    with pytest.raises(CoreError, match="unknown family kind"):
        build(model, [("no-such-kind", tables[0][1])] + tables[1:])
    f = dict(functions, start=functions["start"] + 1)  # beyond data
    with pytest.raises(CoreError):
        build(model, tables, functions=f)
    f = dict(functions, data=functions["data"][:-1])  # the spline's coefficients cut short
    with pytest.raises(CoreError):
        build(model, tables, functions=f)
    f = dict(functions, kind=np.full_like(functions["kind"], 7))
    with pytest.raises(CoreError):
        build(model, tables, functions=f)
    o = dict(outlines, coef=outlines["coef"][:-1])
    with pytest.raises(CoreError):
        build(model, tables, outlines=o)
    o = dict(outlines, last=outlines["last"] + 1)  # beyond the pieces
    with pytest.raises(CoreError):
        build(model, tables, outlines=o)
    o = dict(outlines, span=-outlines["span"])
    with pytest.raises(CoreError):
        build(model, tables, outlines=o)
    with pytest.raises(CoreError):
        Core(model.n, tables, functions, outlines, np.append(angles, model.n))
