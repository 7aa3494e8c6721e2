"""Property-based cross-engine tests: random assemblable slider-cranks (with
offset), Grashof crank-rocker four-bars and quick-returns, at random crank
speeds and start angles. Every engine agrees with native within its
documented tolerance, and native agrees with the closed form.

The strategies keep a margin so that each mechanism assembles along the
whole run: the rod of a slider-crank is at least 0.5 r longer than r + |e|
(it never turns perpendicular to the slider line); four-bars satisfy
s + l <= p + q - 0.1 s (Grashof, away from the change point); the
quick-return's tool line stays within 0.9 of the link length from B for
every crank angle (checked on a 720-point grid)."""
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

import kinem
from adapters import ENGINES, get
from adapters.compare import compare, tolerance_of
from kinem.reference import four_bar, four_bar_case, quick_return, quick_return_case, slider_crank, slider_crank_case

END, STEPS = 1.0, 50
speed = st.floats(0.5, 4.0).flatmap(lambda w: st.sampled_from([w, -w]))
angle = st.floats(-math.pi, math.pi)


@st.composite
def slider_cranks(draw):
    r = draw(st.floats(0.05, 0.2))
    e = draw(st.floats(-0.4, 0.4)) * r
    l = r + abs(e) + draw(st.floats(0.5, 3.0)) * r
    phi0, w = draw(angle), draw(speed)
    case = slider_crank_case(r, l, e, {"poly": [phi0, w]}, phi0, end=END, steps=STEPS)
    return case, lambda t: {"slider.x": slider_crank(phi0 + w * t, w + 0 * t, 0 * t, r, l, e)["x"]}


@st.composite
def four_bars(draw):
    a = draw(st.floats(0.05, 0.2))
    b, c, g = (draw(st.floats(1.5 * a, 4 * a)) for _ in range(3))
    s = sorted([a, b, c, g])
    assume(s[0] + s[3] <= s[1] + s[2] - 0.1 * a)
    phi0, w, sign = draw(angle), draw(speed), draw(st.sampled_from([1.0, -1.0]))
    case = four_bar_case(a, b, c, g, {"poly": [phi0, w]}, phi0, sign, end=END, steps=STEPS)
    return case, lambda t: {"rocker.phi": four_bar(phi0 + w * t, w + 0 * t, 0 * t, a, b, c, g, sign)["th4"]}


@st.composite
def quick_returns(draw):
    rc = draw(st.floats(50.0, 150.0))
    oc = draw(st.floats(1.5, 4.0)) * rc
    rocker = draw(st.floats(1.05, 2.0)) * (oc + rc)
    link = draw(st.floats(0.3, 1.0)) * rocker
    grid = quick_return(np.linspace(0, 2 * np.pi, 720), oc, rc, rocker, link * 10, 0.0)
    by = grid["B"].imag
    height = draw(st.floats(by.max() - 0.9 * link, by.min() + 0.9 * link)) if by.max() - by.min() < 1.8 * link else None
    assume(height is not None)
    phi0, w = draw(angle), draw(speed)
    case = quick_return_case(oc, rc, rocker, link, height, {"poly": [phi0, w]}, phi0, end=END, steps=STEPS)
    return case, lambda t: {"D.x": quick_return(phi0 + w * t, oc, rc, rocker, link, height)["D"].real}


MECHANISMS = {"slider-crank": slider_cranks(), "four-bar": four_bars(), "quick-return": quick_returns()}


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("kind", sorted(MECHANISMS))
@settings(max_examples=4)
@given(data=st.data())
def test_engine_agrees_with_native_and_native_with_closed_form(engine, kind, data):
    case_dict, exact = data.draw(MECHANISMS[kind])
    model = kinem.compile(kinem.load_dict(case_dict))
    native = kinem.solve(model)
    assert native.success, native.message
    # native against the closed form: 1e-9 of the mechanism size (the Newton tolerance is 1e-12)
    for column, ref in exact(native.trajectory.t).items():
        err = np.abs(native.trajectory[column] - ref)
        if column.endswith(".phi"):
            err = np.abs((err + np.pi) % (2 * np.pi) - np.pi)
        assert err.max() <= 1e-9 * (1.0 if column.endswith(".phi") else model.length), column
    adapter = get(engine)
    assert adapter.unsupported(model) is None
    run = adapter.run(model, native.q[0], native.qd[0], adapter.settings())
    c = compare(model, native, run, tolerance_of(adapter))
    assert c.status == "ok", c.status
    assert c.within_tolerance, {k: getattr(c, k) for k in c.tolerance}
