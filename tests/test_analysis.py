"""Analysis paths beyond the closed-form mechanisms: the sparse LU path,
failure results, and solves with the relative, point and distance drivers
against closed forms."""
from pathlib import Path

import numpy as np

import kinem

CASES = Path(__file__).resolve().parents[1] / "cases"


def test_sparse_and_dense_lu_agree():
    from kinem.linalg import choose

    model = kinem.compile(kinem.load(CASES / "quick_return_1.toml"))
    dense = kinem.solve(model)
    options = kinem.Options(linear_solver="sparse")   # the same model: options never recompile
    assert choose(model, options).sparse and not choose(model, kinem.Options()).sparse
    sparse = kinem.solve(model, options=options)
    assert dense.success and sparse.success
    # the same Newton iterates up to rounding: agreement far below the 1e-12 tolerance
    assert np.max(np.abs(sparse.trajectory.data - dense.trajectory.data) / (1 + np.abs(dense.trajectory.data))) < 1e-9


def test_failure_result_says_when_and_where():
    """A non-Grashof four-bar (s + l > p + q) whose crank is driven through a
    full turn: it reaches a limit position, where the analysis must stop."""
    import math

    from closed_form import four_bar

    a, b, c, g = 0.5, 0.6, 0.6, 1.0
    ref = four_bar(np.array([math.pi / 2]), np.zeros(1), np.zeros(1), a, b, c, g)
    th3, th4 = ref["th3"][0], ref["th4"][0]
    A = 0.5j
    cpl = A + b / 2 * np.exp(1j * th3)
    rck = g + c / 2 * np.exp(1j * th4)
    case = kinem.load_dict({
        "name": "fails", "time": {"end": 3.0, "steps": 300},
        "bodies": {"ground": {"q": [0, 0, 0]}, "crank": {"q": [0, 0.25, math.pi / 2]},
                   "coupler": {"q": [cpl.real, cpl.imag, th3]}, "rocker": {"q": [rck.real, rck.imag, th4]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "i": "ground", "si": [0, 0], "j": "crank", "sj": [-a / 2, 0]},
            {"type": "revolute", "i": "crank", "si": [a / 2, 0], "j": "coupler", "sj": [-b / 2, 0]},
            {"type": "revolute", "i": "coupler", "si": [b / 2, 0], "j": "rocker", "sj": [c / 2, 0]},
            {"type": "revolute", "i": "rocker", "si": [-c / 2, 0], "j": "ground", "sj": [g, 0]},
            {"type": "driver", "body": "crank", "coord": "phi", "d": {"poly": [math.pi / 2, 1.5]}},
        ],
    })
    r = kinem.solve(kinem.compile(case))
    assert not r.success and r.status in (kinem.Status.NOT_CONVERGED, kinem.Status.SINGULAR)
    assert 0 < r.t_fail < 3.0
    assert len(r.trajectory) == int(round(r.t_fail / 0.01))
    assert f"t = {r.t_fail:.6g}" in r.message


def test_non_square_system_is_an_input_error():
    case = kinem.load_dict({"name": "x", "time": {"end": 1.0, "steps": 2},
                            "bodies": {"g": {"q": [0, 0, 0]}, "c": {"q": [1, 0, 0]}},
                            "constraints": [{"type": "ground", "body": "g"},
                                            {"type": "revolute", "i": "g", "si": [0, 0], "j": "c", "sj": [-1, 0]}]})
    import pytest

    with pytest.raises(kinem.InputError, match="5 equations for 6 coordinates: 1 equation missing"):
        kinem.solve(kinem.compile(case))


def arm_case(relative_fn, base_fn):
    return kinem.load_dict({
        "name": "arm", "time": {"end": 2.0, "steps": 80},
        "bodies": {"ground": {"q": [0, 0, 0]}, "upper": {"q": [0.5, 0, 0]}, "fore": {"q": [1.4, 0, 0]}},
        "points": {"tip": {"body": "fore", "at": [0.4, 0.0]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "i": "ground", "si": [0, 0], "j": "upper", "sj": [-0.5, 0]},
            {"type": "revolute", "i": "upper", "si": [0.5, 0], "j": "fore", "sj": [-0.4, 0]},
            {"type": "driver", "body": "upper", "coord": "phi", "d": base_fn},
            {"type": "driver", "body": "fore", "coord": "phi", "relative_to": "upper", "d": relative_fn},
        ],
    })


def test_relative_driver_two_link_arm():
    r = kinem.solve(kinem.compile(arm_case({"harmonic": {"amplitude": 0.8, "omega": 2.0}}, {"poly": [0.3, 0.5]})))
    assert r.success
    t = r.trajectory.t
    p1, w1 = 0.3 + 0.5 * t, 0.5
    p2 = p1 + 0.8 * np.sin(2 * t)
    w2 = w1 + 1.6 * np.cos(2 * t)
    a2 = -3.2 * np.sin(2 * t)
    tip = np.exp(1j * p1) + 0.8 * np.exp(1j * p2)
    vtip = 1j * w1 * np.exp(1j * p1) + 0.8j * w2 * np.exp(1j * p2)
    atip = -w1**2 * np.exp(1j * p1) + 0.8 * (1j * a2 - w2**2) * np.exp(1j * p2)
    tr = r.trajectory
    # Newton stops at scaled residual <= 1e-12, i.e. 1e-12 of the size L (~1.5 here):
    # 1e-9 relative to the quantity's peak leaves margin for the linear solves
    for got, ref in ((tr["tip.x"] + 1j * tr["tip.y"], tip), (tr["tip.vx"] + 1j * tr["tip.vy"], vtip),
                     (tr["tip.ax"] + 1j * tr["tip.ay"], atip)):
        assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_point_driver_and_distance_driver():
    """A boom pinned at the origin, lifted by an actuator from (a, 0) to the boom
    point at distance b: |b e^{i phi} - a| = d(t) gives
    cos phi = (a^2 + b^2 - d^2) / (2ab); and a slider whose point x follows d(t)."""
    a, b = 1.0, 0.8
    case = kinem.load_dict({
        "name": "boom", "time": {"end": 1.0, "steps": 50},
        "bodies": {"ground": {"q": [0, 0, 0]}, "boom": {"q": [0.5, 0.5, 1.2]}, "slider": {"q": [0.1, 0, 0]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "i": "ground", "si": [0, 0], "j": "boom", "sj": [-0.7, 0]},
            {"type": "distance-driver", "i": "ground", "si": [a, 0], "j": "boom", "sj": [b - 0.7, 0],
             "d": {"poly": [1.0, 0.2]}},
            {"type": "absolute", "body": "slider", "coord": "y", "point": [0.0, 0.5], "value": 0.5},
            {"type": "absolute", "body": "slider", "coord": "phi"},
            {"type": "driver", "body": "slider", "coord": "x", "point": [0.3, 0.5], "d": {"harmonic": {"amplitude": 0.2, "omega": 3.0}}},
        ],
    })
    r = kinem.solve(kinem.compile(case))
    assert r.success, r.message
    t = r.trajectory.t
    d = 1.0 + 0.2 * t
    phi = np.arccos((a * a + b * b - d * d) / (2 * a * b))
    tr = r.trajectory
    # bounds as in the arm test: 1e-9 of each quantity's peak
    omega = d * 0.2 / (a * b * np.sin(phi))  # from d d' = a b sin(phi) phi'
    assert np.abs(tr["boom.phi"] - phi).max() <= 1e-9 * np.abs(phi).max()
    assert np.abs(tr["boom.omega"] - omega).max() <= 1e-9 * np.abs(omega).max()
    assert np.abs(tr["slider.x"] + 0.3 - 0.2 * np.sin(3 * t)).max() <= 1e-9 * 0.3
    assert np.abs(tr["slider.ax"] + 1.8 * np.sin(3 * t)).max() <= 1e-9 * 1.8
    assert np.abs(tr["slider.y"]).max() <= 1e-9
