"""Every constraint type's Jacobian, nu and gamma against finite differences
of Phi (tests/fd.py), with hypothesis over random points, configurations
(angles well beyond 2 pi), velocities, times and driving functions."""
import numpy as np
import pytest
from hypothesis import given, strategies as st

import kinem
from kinem.constraints import implemented_types
from fd import assert_derivatives

END = 3.0
num = st.floats(-2.0, 2.0, allow_nan=False)
point = st.tuples(num, num).map(list)
positive = st.floats(0.2, 3.0)


@st.composite
def function(draw):
    kind = draw(st.sampled_from(["constant", "poly", "harmonic", "table"]))
    if kind == "constant":
        return draw(num)
    if kind == "poly":
        return {"poly": draw(st.lists(num, min_size=1, max_size=4))}
    if kind == "harmonic":
        return {"harmonic": {"amplitude": draw(num), "omega": draw(st.floats(0.1, 4.0)),
                             "phase": draw(num), "offset": draw(num)}}
    n = draw(st.integers(4, 8))
    return {"table": {"t": list(np.linspace(0.0, END, n)), "value": draw(st.lists(num, min_size=n, max_size=n))}}


def distinct_points(draw):
    a = draw(point)
    b = draw(point.filter(lambda p: np.hypot(p[0] - a[0], p[1] - a[1]) > 0.1))
    return a, b


# type -> strategy of its constraint table between bodies b0, b1, b2
BUILDERS = {
    "ground": lambda d: {"body": "b0", "value": [d(num), d(num), d(num)]},
    "absolute": lambda d: d(st.sampled_from([
        {"body": "b0", "coord": "phi", "value": d(num)},
        {"body": "b0", "coord": "x", "value": d(num)},
        {"body": "b1", "coord": "y", "point": d(point), "value": d(num)},
        {"body": "b1", "coord": "x", "point": d(point), "value": d(num)},
    ])),
    "driver": lambda d: d(st.sampled_from([
        {"body": "b0", "coord": "phi", "d": d(function())},
        {"body": "b0", "coord": "y", "d": d(function())},
        {"body": "b1", "coord": "x", "point": d(point), "d": d(function())},
        {"body": "b1", "coord": "y", "point": d(point), "d": d(function())},
        {"body": "b1", "coord": "phi", "relative_to": "b2", "d": d(function())},
    ])),
    "revolute": lambda d: {"i": "b0", "si": d(point), "j": "b1", "sj": d(point)},
    "translational": lambda d: dict(zip(("si", "qi"), distinct_points(d)), i="b0", j="b1", sj=d(point), phi0=d(num)),
    "revolute-translational": lambda d: dict(zip(("sj", "qj"), distinct_points(d)), i="b0", si=d(point), j="b1"),
    "revolute-revolute": lambda d: {"i": "b0", "si": d(point), "j": "b1", "sj": d(point), "length": d(positive)},
    "distance-driver": lambda d: {"i": "b0", "si": d(point), "j": "b1", "sj": d(point), "d": d(function())},
}


def random_model(draw, ctype):
    cons = [dict(BUILDERS[ctype](draw), type=ctype) for _ in range(draw(st.integers(1, 3)))]
    case = kinem.load_dict({
        "name": "fd", "time": {"end": END, "steps": 3},
        "bodies": {f"b{k}": {"q": [0.0, 0.0, 0.0]} for k in range(3)},
        "constraints": cons,
    })
    return kinem.compile(case)


def test_every_implemented_type_is_checked():
    assert set(implemented_types()) <= set(BUILDERS)


@pytest.mark.parametrize("ctype", sorted(BUILDERS))
@given(data=st.data())
def test_derivatives_match_finite_differences(ctype, data):
    if ctype not in implemented_types():
        pytest.skip(f"{ctype} not implemented")
    model = random_model(data.draw, ctype)
    angle = st.floats(-20.0, 20.0)  # accumulated angles, beyond 2 pi
    q = np.array([data.draw(angle if k % 3 == 2 else num) for k in range(model.n)])
    qd = np.array([data.draw(st.floats(-3.0, 3.0)) for _ in range(model.n)])
    t = data.draw(st.floats(0.2, END - 0.2))
    assert_derivatives(model, q, qd, t)


def test_a_wrong_jacobian_is_caught():
    """The check can fail: perturb one revolute Jacobian entry."""
    from fd import errors

    case = kinem.load_dict({"name": "x", "time": {"end": 1.0, "steps": 1},
                            "bodies": {"a": {"q": [0, 0, 0]}, "b": {"q": [0, 0, 0]}},
                            "constraints": [{"type": "revolute", "i": "a", "si": [1.0, 0.5], "j": "b", "sj": [0.3, 0.0]}]})
    model = kinem.compile(case)
    fam = model.families[0]
    original = fam.jac
    object.__setattr__(fam, "jac", lambda q, t: original(q, t) * 1.0001)
    ej, _, _ = errors(model, np.array([0.1, 0.2, 0.3, -0.4, 0.5, 1.1]), np.ones(6), 0.5)
    assert ej > 1e-6
