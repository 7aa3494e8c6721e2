"""The native solver against closed-form kinematics: the repository's
slider-crank and four-bar, then random mechanisms that are not in it.

Tolerance 1e-9 (the issue's bound): the Newton tolerance is 1e-12 of the
mechanism size and converges quadratically, so positions carry ~1e-12
relative error, and velocities/accelerations come from linear solves with
that Jacobian (condition numbers ~1e2 here)."""
import math
from pathlib import Path

import numpy as np
from hypothesis import assume, given, settings, strategies as st

import kinem
from closed_form import four_bar, rel_error, slider_crank
from kinem.reference import four_bar_case, slider_crank_case

CASES = Path(__file__).resolve().parents[1] / "cases"
TOL = 1e-9


def check_slider_crank(tr, crank_angle, r, l, e, crank, rod, slider, slider_at, side=-1.0):
    th, w, a = crank_angle
    ref = slider_crank(th, w, a, r, l, e, side)
    # slider origin = pin A + slider_at (no rotation: translational joint with phi fixed at 0)
    assert rel_error(tr[f"{slider}.x"] - slider_at, ref["x"]) <= TOL
    assert rel_error(tr[f"{slider}.vx"], ref["vx"]) <= TOL
    assert rel_error(tr[f"{slider}.ax"], ref["ax"]) <= TOL
    assert rel_error(tr[f"{rod}.phi"], ref["phi"], angle=True) <= TOL
    assert rel_error(tr[f"{rod}.omega"], ref["omega"]) <= TOL
    assert rel_error(tr[f"{rod}.alpha"], ref["alpha"]) <= TOL


def test_book_slider_crank():
    r = kinem.solve(kinem.compile(kinem.load(CASES / "slider_crank.toml")))
    assert r.success
    t = r.trajectory.t
    # crank pin B = -200 (cos phi2, sin phi2): a crank of 200 at angle phi2 + pi; phi2 = 5.76 - 1.2 t
    crank = (5.76 - 1.2 * t + np.pi, np.full_like(t, -1.2), np.zeros_like(t))
    check_slider_crank(r.trajectory, crank, 200.0, 500.0, 0.0, "crank", "rod", "slider", 0.0)
    assert np.allclose(r.trajectory["crank.phi"], 5.76 - 1.2 * t, rtol=0, atol=1e-12)


def check_four_bar(tr, th2, w2, a2, a, b, c, d, sign=1.0):
    ref = four_bar(th2, w2, a2, a, b, c, d, sign)
    assert rel_error(tr["coupler.phi"], ref["th3"], angle=True) <= TOL
    assert rel_error(tr["rocker.phi"], ref["th4"], angle=True) <= TOL
    for q, k in (("omega", "w"), ("alpha", "a")):
        assert rel_error(tr[f"coupler.{q}"], ref[f"{k}3"]) <= TOL
        assert rel_error(tr[f"rocker.{q}"], ref[f"{k}4"]) <= TOL


def test_four_bar_freudenstein():
    res = kinem.solve(kinem.compile(kinem.load(CASES / "four_bar.toml")))
    assert res.success
    t = res.trajectory.t
    th2, w2, a2 = math.pi / 4 + 1.5 * t - 0.6 * t**2, 1.5 - 1.2 * t, np.full_like(t, -1.2)
    check_four_bar(res.trajectory, th2, w2, a2, 0.1, 0.3, 0.22, 0.2)
    assert rel_error(res.trajectory["B.x"] + 1j * res.trajectory["B.y"],
                     four_bar(th2, w2, a2, 0.1, 0.3, 0.22, 0.2)["B"]) <= TOL


def test_quick_return_models_agree():
    """Three models of one crank-shaper give the same A, B and D, within
    1e-8 x the mechanism size (the issue's bound)."""
    runs = [kinem.solve(kinem.compile(kinem.load(CASES / f"quick_return_{k}.toml"))) for k in (1, 2, 3)]
    assert all(r.success for r in runs)
    size = 500.0  # rocker length, the mechanism's largest dimension
    for p in ("A", "B", "D"):
        for q in ("x", "y", "vx", "vy", "ax", "ay"):
            ref = runs[0].trajectory[f"{p}.{q}"]
            scale = size if q in ("x", "y") else max(np.abs(ref).max(), 1.0)
            for r in runs[1:]:
                assert np.max(np.abs(r.trajectory[f"{p}.{q}"] - ref)) <= 1e-8 * scale, (p, q)
    # and the geometry given in the issue at t = 0
    tr = runs[0].trajectory
    for p, x, y in (("A", 86.78, 49.69), ("B", 120.43, 185.28), ("D", 239.53, 200.0)):
        assert abs(tr[f"{p}.x"][0] - x) < 0.006 and abs(tr[f"{p}.y"][0] - y) < 0.006


# -- mechanisms that are not in the repository ---------------------------------

drive_kind = st.sampled_from(["speed", "acceleration", "harmonic"])


def driver_function(draw, kind, phi0):
    w = draw(st.floats(0.5, 4.0)) * draw(st.sampled_from([-1, 1]))
    if kind == "speed":
        c = [phi0, w]
    elif kind == "acceleration":
        c = [phi0, w, draw(st.floats(-1.0, 1.0))]
    else:
        amp, om = draw(st.floats(0.2, 2.0)), draw(st.floats(0.5, 3.0))
        return {"harmonic": {"amplitude": amp, "omega": om, "phase": 0.0, "offset": phi0}}, \
            (lambda t: phi0 + amp * np.sin(om * t), lambda t: amp * om * np.cos(om * t),
             lambda t: -amp * om * om * np.sin(om * t))
    p = np.polynomial.Polynomial(c)
    return {"poly": c}, (p, p.deriv(1), p.deriv(2))


@settings(max_examples=15)
@given(st.data())
def test_random_offset_slider_cranks(data):
    d = data.draw
    scale = d(st.sampled_from([1e-3, 1.0, 1e3]))
    r = d(st.floats(0.5, 2.0)) * scale
    e = d(st.floats(-0.4, 0.4)) * r
    l = r + abs(e) + d(st.floats(0.5, 3.0)) * r      # margin: the rod never becomes perpendicular to the line
    phi0 = d(st.floats(-math.pi, math.pi))
    fn, (f0, f1, f2) = driver_function(d, d(drive_kind), phi0)
    case = kinem.load_dict(slider_crank_case(r, l, e, fn, phi0, crank_origin=d(st.floats(-0.5, 0.5)),
                                             rod_origin=d(st.floats(-0.5, 0.5))))
    res = kinem.solve(kinem.compile(case))
    assert res.success, res.message
    t = res.trajectory.t
    check_slider_crank(res.trajectory, (f0(t), f1(t), f2(t)), r, l, e, "crank", "rod", "slider", 0.0)


@settings(max_examples=15)
@given(st.data())
def test_random_grashof_crank_rockers(data):
    d = data.draw
    scale = d(st.sampled_from([1e-2, 1.0, 1e2]))
    a = d(st.floats(0.2, 1.0))                       # crank: the shortest link
    b, c, g = (d(st.floats(a * 1.5, 4.0)) for _ in range(3))
    lengths = sorted([a, b, c, g])
    # Grashof with margin: s + l <= p + q - 0.1 a keeps the transmission angle away from 0 and pi
    assume(lengths[0] + lengths[3] <= lengths[1] + lengths[2] - 0.1 * a)
    a, b, c, g = (x * scale for x in (a, b, c, g))
    sign = d(st.sampled_from([1.0, -1.0]))
    phi0 = d(st.floats(-math.pi, math.pi))
    fn, (f0, f1, f2) = driver_function(d, d(drive_kind), phi0)
    res = kinem.solve(kinem.compile(kinem.load_dict(four_bar_case(a, b, c, g, fn, phi0, sign))))
    assert res.success, res.message
    t = res.trajectory.t
    check_four_bar(res.trajectory, f0(t), f1(t), f2(t), a, b, c, g, sign)


# Rates at machine precision (issue 14): the rates come from the Jacobian at the corrected
# position (one Newton correction past the tolerance), so their error is rounding times the
# conditioning, not the Newton tolerance times it. 1e-13 of their peak: about 500 machine
# epsilons, for conditioning ~1e2 of these mechanisms (measured 3e-16 .. 4e-15).
RATES = 1e-13


def test_book_cases_rates_to_machine_precision():
    for march in (kinem.Options(), kinem.Options(block=1)):
        r = kinem.solve(kinem.compile(kinem.load(CASES / "slider_crank.toml")), options=march)
        t, tr = r.trajectory.t, r.trajectory
        ref = slider_crank(5.76 - 1.2 * t + np.pi, np.full_like(t, -1.2), np.zeros_like(t), 200.0, 500.0)
        for q, k in (("slider.vx", "vx"), ("slider.ax", "ax"), ("rod.omega", "omega"), ("rod.alpha", "alpha")):
            assert rel_error(tr[q], ref[k]) <= RATES, (q, rel_error(tr[q], ref[k]))
        res = kinem.solve(kinem.compile(kinem.load(CASES / "four_bar.toml")), options=march)
        t, tr = res.trajectory.t, res.trajectory
        ref = four_bar(math.pi / 4 + 1.5 * t - 0.6 * t**2, 1.5 - 1.2 * t, np.full_like(t, -1.2), 0.1, 0.3, 0.22, 0.2)
        for q, k in (("omega", "w"), ("alpha", "a")):
            for body, i in (("coupler", 3), ("rocker", 4)):
                assert rel_error(tr[f"{body}.{q}"], ref[f"{k}{i}"]) <= RATES, (body, q)
