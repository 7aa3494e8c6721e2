"""The core's settle (kinem/core/src/newton.rs), the one Newton loop: the
step-by-step analysis runs it on its operations, the march on its own after
a chord from the last instant's factorisation that did not contract fast
enough (newton::chord); both agree to rounding; its last correction tells a
singular root (linear convergence) from a regular one."""
from dataclasses import replace
from pathlib import Path

import math

import numpy as np
import pytest

import kinem
from kinem import analysis
from kinem.reference import four_bar, rel_error
from kinem.native import MAX_STEP, MarchState, Mode, Why
from kinem.tracking import NEAR_SINGULAR, REGULAR, singular_pivot

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1"])
@pytest.mark.parametrize("outputs", [kinem.OUTPUTS, ("positions",)])
def test_the_march_and_the_step_by_step_analysis_agree_to_rounding(name, outputs):
    """The step-by-step analysis runs Newton with its final correction and
    the factorisation at the corrected q (two per instant); the march runs
    the chord with the last instant's factorisation to rounding and
    factorises once per instant at the final q (newton::chord). Both end at
    the root to rounding: positions and rates equal to 1e-12 of the size or
    of the rates' peak (LAPACK's blocked getrf and the march's unblocked LU
    round differently, and the conditioning amplifies that: 1e-12 is 1e4
    times rounding); the march never factorises more often, and once per
    instant with rates where the chord contracts fast (the slider-crank's
    and the four-bar's 501 and 251 instants)."""
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    step = kinem.solve(model, outputs, options=replace(kinem.Options.of(model.case), block=1))
    march = kinem.solve(model, outputs)
    assert step.success and march.success
    assert step.factorizations >= 2 * len(step.q) - 1
    assert march.jacobian_evaluations == march.factorizations <= step.factorizations
    if name != "quick_return_1" and "velocities" in outputs:   # the Hermite start: the chord at every instant
        assert march.factorizations <= len(march.q) + 4   # the assembly and the first instant: Newton
    assert np.abs(step.q - march.q).max() / model.length < 1e-12
    for a, b in [(step.qd, march.qd), (step.qdd, march.qdd)]:
        if a is not None:
            assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()


def change_point():
    """The change-point four-bar at t = 1.5, on its change point (coupler and
    rocker collinear with the ground: both angles 0), and its exact
    configuration there."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "stress" / "change_point.toml"))
    q = np.zeros(model.n)
    names = model.coordinate_names
    q[names.index("crank.x")], q[names.index("coupler.x")] = 0.0, 1.0
    q[names.index("rocker.x")] = 2.0
    return model, q


def test_a_singular_root_leaves_a_large_last_correction_and_is_rejected():
    """Newton converges linearly at a singular root: 1e-6 off the change point
    along the Jacobian's null direction (coupler and rocker turning together,
    B moving along the vertical) the residual is already below the tolerance
    (it is quadratic there), and the final correction halves the distance:
    about 4e-7, far above 1e-2 sqrt(tolerance) = 1e-8. At a regular
    configuration the final correction is rounding."""
    model, exact = change_point()
    tol = kinem.Options.of(model.case).tolerance
    assert np.abs(model.phi(exact, 1.5)).max() < 1e-15
    names = model.coordinate_names
    start = exact.copy()
    start[names.index("coupler.phi")] += 1e-6
    start[names.index("rocker.phi")] += 1.5e-6
    data = kinem.Data(q=start)
    analysis.position(model, data, 1.5)
    assert data.iterations == 0 and data.residual <= tol
    assert data.correction > REGULAR * tol**0.5
    # the pivot ratio is small here too; the correction alone rejects it: the core's step (the march's
    # assembly from these estimates, the acceptance test) with no pivot floor
    settings = (tol, 25, MAX_STEP, 0.0, True)
    o = model.plan.step(MarchState(start), 1.5, settings, Mode.TRACK)
    assert o.why == NEAR_SINGULAR and o.correction > REGULAR * tol**0.5
    o = model.plan.step(MarchState(start), 1.2, settings[:3] + (singular_pivot(tol), True), Mode.TRACK)
    assert o.why == Why.ACCEPTED and o.correction <= 1e-10 and o.pivot > 1e-3


@pytest.mark.parametrize("block", [64, 1])
@pytest.mark.parametrize("outputs", [kinem.OUTPUTS, ("positions",)])
def test_the_instant_on_the_change_point_is_the_singular_configuration(outputs, block):
    """Both output sets, compiled march or step by step, find the change point
    at its instant (t = 1.5) and give its configuration (interpolated, then
    Gauss-Newton: to 1e-9 rad) and carry on along the same smooth branch.
    Guarded by the last correction: sub-steps get Newton within 1e-10 of
    the change point, where a final correction with the nearly singular LU
    threw q 5e-4 rad along the null direction, to a pivot ratio of 1e-4
    that passes the floor (seen with the correction test off)."""
    model, exact = change_point()
    r = kinem.solve(model, outputs, options=replace(kinem.Options.of(model.case), block=block))
    assert r.success and [t for t, _ in r.events] == [1.5]
    k = int(np.argmin(np.abs(r.trajectory.t - 1.5)))
    assert np.abs(r.q[k] - exact).max() < 1e-9
    full = kinem.solve(model)
    assert np.abs(r.q - full.q).max() < 1e-8


def test_jacobian_reuse_takes_one_factorisation_per_instant_and_keeps_the_rates():
    """Modified Newton (jacobian_reuse) iterates and corrects with the last
    instant's factorisation, so it converges linearly: the four-bar's
    positions and rates come out about 1e-14 and 1e-13 off the closed form
    (5e-16 and 5e-15 without), bounded here by the tolerance (1e-12) and
    ten times it: the rates come from the factorisation at the corrected
    q, which the conditioning (about 1e-2 here) amplifies. One factorisation
    per instant (two without), and the assembly's."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    r = kinem.solve(model, options=replace(kinem.Options.of(model.case), jacobian_reuse=True))
    assert r.success
    t = r.trajectory.t
    ref = four_bar(math.pi / 4 + 1.5 * t - 0.6 * t**2, 1.5 - 1.2 * t, np.full_like(t, -1.2), 0.1, 0.3, 0.22, 0.2)
    for body, k in (("coupler", "3"), ("rocker", "4")):
        assert rel_error(r.trajectory[f"{body}.phi"], ref[f"th{k}"], angle=True) <= 1e-12
        assert rel_error(r.trajectory[f"{body}.omega"], ref[f"w{k}"]) <= 1e-11
        assert rel_error(r.trajectory[f"{body}.alpha"], ref[f"a{k}"]) <= 1e-11
    assert r.factorizations <= len(t) + 10


def test_jacobian_reuse_after_a_failed_solve_starts_with_a_fresh_factorisation():
    """A step whose Newton fails leaves no factorisation to reuse: coarse
    steps with three iterations allowed fail, are halved, and go on (this
    raised AttributeError when the next step looked for one)."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml").with_time(steps=5))
    r = kinem.solve(model, trace=True, options=replace(kinem.Options.of(model.case), jacobian_reuse=True,
                                                       max_iterations=3))
    assert r.success and r.substeps > 0
    assert any(what == "rejected" and "no convergence" in detail for _, what, _, _, detail in r.trace)
