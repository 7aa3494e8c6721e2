"""The compiled core (kinem._core, kinem/core): every family kind is
reached by the test models (whose Jacobian, nu and gamma the
finite-difference tests check: tests/test_jacobians.py), a malformed table
(an index out of range, a column of the wrong length, a missing column, a
malformed function or outline table) raises kinem.errors.CoreError when the
core is built, and a panic inside the core comes back as CoreError with a
one-line message, never an abort.

(While the numba kernels existed, this file also held the core equal to
them to 1e-12 on random models of every type: that cross-check ran before
they were deleted, see the history of this file.)
"""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import kinem
from kinem._core import KINDS, Core
from kinem.errors import CoreError
from kinem.functions import FunctionTable
from kinem.outline import OutlineTable
from test_jacobians import BUILDERS, random_model


FLAGS = {"point", "relative", "carrier"}  # int64 columns that are flags, not indices
# columns that index a body's x column: the kernels read c + 1 and c + 2 too
BODY_COLUMNS = {"revolute": {"ci", "cj"}, "line": {"ca", "cb"}, "distance": {"ci", "cj"},
                "rack-pinion": {"ci", "cj"}, "point-on-curve": {"cc", "cb"}, "cam-roller": {"cc", "cj"},
                "cam-flat": {"cc", "cj"}, "simple": set(), "gear": set()}


@settings(max_examples=1)
@given(data=st.data())
def test_every_kind_is_covered(data):
    """The builders' types reach every family kind of the core."""
    kinds = {kind for ctype in BUILDERS for kind, _ in parts_of(random_model(data.draw, ctype))[0]}
    assert kinds == set(KINDS)


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


def test_a_panic_in_the_core_is_a_core_error_not_an_abort():
    """The core catches its own panics (kinem/core/src/py/mod.rs, guard): the
    process lives on, the error is a KinemError with one line."""
    from kinem._core import _panic

    with pytest.raises(CoreError) as e:
        _panic("index 7 out of range\nfor a table of 3")
    assert "internal error in kinem's compiled core: index 7 out of range for a table of 3" in str(e.value)
    assert "\n" not in str(e.value)
    assert isinstance(e.value, kinem.KinemError)


def test_a_singular_factorisation_names_the_coordinate_of_its_zero_pivot():
    """The core's LU says which coordinate's column holds its smallest pivot
    (Lu.smallest): with every Jacobian entry of the crank's angle zeroed that
    column is zero, its pivot 0, and the error names crank.phi."""
    from pathlib import Path

    from kinem.errors import SingularError
    from kinem.linalg import Factor, choose

    model = kinem.compile(kinem.load(Path(__file__).parent.parent / "cases" / "slider_crank.toml"))
    j = model.coordinate_names.index("crank.phi")
    values = model.jac_values(model.q0, 0.0)
    values[model.jac_cols == j] = 0.0
    solver = choose(model, kinem.Options())
    assert solver.core
    with pytest.raises(SingularError, match="at coordinate 'crank.phi'"):
        Factor(model, values, solver)
    assert Factor(model, model.jac_values(model.q0, 0.0), solver).pivot_ratio > 0
