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


direction = point.filter(lambda p: np.hypot(*p) > 0.1)


@st.composite
def outline(draw):
    """A circle, a periodic spline (radians or degrees) or an open spline.
    Intervals of at least 0.33 rad (2 pi / 19) keep theta_on's margin (5 % of an interval)
    well beyond the finite-difference stencil (2 H |theta'| <= 6e-3), and
    radii in [1, 1.5] keep the cubics' coefficients, and so the fifth path
    derivative in the stencil's truncation error (fd.py), moderate."""
    center = draw(point)
    kind = draw(st.sampled_from(["circle", "periodic", "open"]))
    if kind == "circle":
        return {"circle": {"radius": draw(positive)}, "center": center}
    n = draw(st.integers(4, 8))
    w = np.cumsum([0.0] + draw(st.lists(st.floats(1.0, 3.0), min_size=n - 1, max_size=n - 1)))
    s = draw(st.lists(st.floats(1.0, 1.5), min_size=n, max_size=n))
    start = draw(num)
    if kind == "open":
        bc = draw(st.sampled_from(["not-a-knot", "natural"]))
        return {"spline": {"theta": list(start + w), "s": s, "bc": bc}, "center": center}
    s[-1] = s[0]
    theta = start + 2 * np.pi * w / w[-1]
    if draw(st.booleans()):
        return {"spline": {"theta": list(np.degrees(theta)), "s": s, "periodic": True, "degrees": True},
                "center": center}
    return {"spline": {"theta": list(theta), "s": s, "periodic": True}, "center": center}


def on_outline(d, point_key, table):
    """A constraint table with a random outline, its estimate of theta and a point."""
    o = d(outline())
    spline = o.get("spline", {"theta": [0.0]})
    first = np.radians(spline["theta"][0]) if spline.get("degrees") else spline["theta"][0]
    return dict(table, outline=o, theta=float(first) + 0.1, **{point_key: d(point)})


def theta_on(o):
    """An angle on outline o inside one of its table intervals, 5 % of the
    interval away from the knots (s''' jumps there); on a periodic outline
    accumulated over up to 3 turns either way."""
    x = o.pieces()[0]
    turns = st.integers(-3, 3) if o.periodic else st.just(0)
    return st.tuples(st.integers(0, len(x) - 2), st.floats(0.05, 0.95), turns).map(
        lambda a: x[a[0]] + a[1] * (x[a[0] + 1] - x[a[0]]) + 2 * np.pi * a[2])


def rack_pinion(d):
    """A rack-pinion table whose pinion lies on the side of u turned +90
    degrees at the estimates (every body at the origin): the case file
    refuses the other side. sj is the centre's foot on the line, moved along it."""
    rho, center, u, along = d(positive), d(point), d(direction), d(num)
    e = complex(*u) / abs(complex(*u))
    foot = complex(*center) - (0.5 + d(st.floats(0.0, 2.0))) * 1j * e + along * e
    return {"pinion": "b0", "radius": rho, "center": center, "rack": "b1", "sj": [foot.real, foot.imag],
            "u": u, "phi0": d(num)}


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
    "gear": lambda d: dict({"carrier": "b2"} if d(st.booleans()) else {}, i="b0", ri=d(positive), j="b1",
                           rj=d(positive), internal=d(st.booleans()), phi0=d(num)),
    "rack-pinion": lambda d: rack_pinion(d),
    "cam-point": lambda d: on_outline(d, "sj", {"cam": "b0", "follower": "b1"}),
    "cam-roller": lambda d: on_outline(d, "sj", {"cam": "b0", "follower": "b1", "radius": d(positive)}),
    "cam-flat": lambda d: on_outline(d, "sj", {"cam": "b0", "follower": "b1", "normal": d(direction)}),
    "point-follower": lambda d: on_outline(d, "si", {"i": "b0", "j": "b1"}),
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
    for col, label in enumerate(model.artificial, model.n - len(model.artificial)):  # theta on its outline
        c = next(c for c in model.case.constraints if f"{c.name}.theta" == label)
        q[col] = data.draw(theta_on(c["outline"]))
    qd = np.array([data.draw(st.floats(-3.0, 3.0)) for _ in range(model.n)])
    # a table function's third derivative jumps at its knots: keep the stencil (+-2 H) off them
    knots = np.concatenate([np.linspace(0.0, END, n) for n in range(4, 9)])
    t = data.draw(st.floats(0.2, END - 0.2).filter(lambda t: np.abs(knots - t).min() > 5e-3))
    assert_derivatives(model, q, qd, t)


def test_a_wrong_jacobian_is_caught():
    """The check can fail: perturb one revolute Jacobian entry."""
    from fd import errors

    case = kinem.load_dict({"name": "x", "time": {"end": 1.0, "steps": 1},
                            "bodies": {"a": {"q": [0, 0, 0]}, "b": {"q": [0, 0, 0]}},
                            "constraints": [{"type": "revolute", "i": "a", "si": [1.0, 0.5], "j": "b", "sj": [0.3, 0.0]}]})
    model = kinem.compile(case)
    original = model.jac_values
    object.__setattr__(model, "jac_values", lambda q, t: original(q, t) * 1.0001)
    ej, _, _ = errors(model, np.array([0.1, 0.2, 0.3, -0.4, 0.5, 1.1]), np.ones(6), 0.5)
    assert ej > 1e-6
