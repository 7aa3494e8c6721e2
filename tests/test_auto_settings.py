"""Settings the adapters choose themselves ("auto"): MuJoCo's step from the
mechanism's rate scale, its drive mode, MuJoCo's refinement by its
self-check (never native's trajectory) with solref following the step, and
pymunk's one retry with more Gauss-Seidel iterations (divergence,
unconverged velocities)."""
import numpy as np
import pytest

import kinem
from adapters import get
from adapters.base import Status, rate_scale, start_rate, trajectory_rate
from adapters.compare import compare, tolerance_of
from kinem.reference import four_bar_case, quick_return_case, slider_crank_case

MUJOCO, PYMUNK = get("mujoco"), get("pymunk")


def solved(case_dict):
    model = kinem.compile(kinem.load_dict(case_dict))
    native = kinem.solve(model)
    assert native.success, native.message
    return model, native


def slider_crank(w, fn=None):
    return solved(slider_crank_case(0.1, 0.3, 0.0, fn or {"poly": [0.3, w]}, 0.3, end=0.5, steps=25))


# A random four-bar of tests/test_engines_property.py (drawn there): pymunk's
# Gauss-Seidel diverges on it at 25 iterations with dt = 2e-4, holds at 100.
DIVERGING_FOUR_BAR = four_bar_case(0.07420530939463176, 0.27794610723853192, 0.29682123757852696,
                                   0.12728141727082676, {"poly": [-0.0006970427816885632, 1.259060005106527]},
                                   -0.0006970427816885632, 1.0, end=1.0, steps=50)
# A quick-return the property test's strategy allows (hypothesis shrank to it):
# link as long as the rocker, the tool line through O. Its loops' closure
# MuJoCo's first step misses its tolerance there (the self-check refines it);
# pymunk diverges at 25 iterations.
HARD_QUICK_RETURN = quick_return_case(100.0, 50.0, 300.0, 300.0, 0.0, {"poly": [0.0, -2.0]}, 0.0, end=1.0, steps=50)


def test_rate_scale_follows_the_speed():
    # a constant-speed crank: rates, sqrt(accelerations) and cbrt(jerks) all scale with w
    (m1, n1), (m4, n4) = slider_crank(1.0), slider_crank(4.0)
    assert rate_scale(m1, n1.trajectory) >= 1.0   # at least the crank's own rate
    # 5 %: the jerks are differences of the accelerations over the output instants
    assert rate_scale(m4, n4.trajectory) / rate_scale(m1, n1.trajectory) == pytest.approx(4.0, rel=0.05)
    # an engine's own run (accelerations by differences of its velocities) gives the same scale within 5 %
    assert trajectory_rate(m1, m1.times, n1.q, n1.qd) == pytest.approx(rate_scale(m1, n1.trajectory), rel=0.05)
    # the start's alone: at most the whole run's, and as fast as the crank
    assert 1.0 <= start_rate(m1, n1.q[0], n1.qd[0]) <= rate_scale(m1, n1.trajectory) * (1 + 1e-9)


def test_auto_step_is_smaller_for_a_faster_mechanism():
    (m1, n1), (m4, n4) = slider_crank(1.0), slider_crank(4.0)
    h = m1.times[1] - m1.times[0]
    first = {}
    for w, (m, n) in ((1, (m1, n1)), (4, (m4, n4))):
        # the first attempt: the fewest steps per interval with dt <= rate_step / the start's rate scale
        s = MUJOCO.settings()
        MUJOCO.resolve(m, s, n.q[0], n.qd[0])
        assert s["substeps"] == int(np.ceil(h * s["rate_scale"] / MUJOCO.defaults()["rate_step"]))
        first[w] = s["dt"]
        # the run ends within tolerance at that step or a refined one (never coarser)
        run = MUJOCO.run(m, n.q[0], n.qd[0], None)
        assert run.ok and run.settings["dt"] <= s["dt"] * (1 + 1e-12)
        assert compare(m, n, run, tolerance_of(MUJOCO)).within_tolerance
    assert first[4] < first[1] / 3   # 4x the rate; steps rounded to divide the interval
    # an explicit step is taken as it is
    fixed = MUJOCO.run(m4, n4.q[0], n4.qd[0], {"dt": first[1]})
    assert fixed.settings["dt"] == pytest.approx(first[1]) and "rate_scale" not in fixed.settings
    assert not fixed.notes


def test_mujoco_drives_in_c_where_a_held_force_is_exact():
    m, n = slider_crank(1.0)
    linear = MUJOCO.run(m, n.q[0], n.qd[0], None)
    assert (linear.settings["drive"], linear.settings["armature"]) == ("interval", 1e12)
    m, n = slider_crank(1.0, {"harmonic": {"amplitude": 0.5, "omega": 2.0, "phase": 0.0, "offset": 0.3}})
    harmonic = MUJOCO.run(m, n.q[0], n.qd[0], None)
    assert (harmonic.settings["drive"], harmonic.settings["armature"]) == ("overwrite", 1e9)
    assert compare(m, n, harmonic, tolerance_of(MUJOCO)).within_tolerance


def test_mujoco_refines_its_step_and_solref_when_its_self_check_misses():
    model, native = solved(HARD_QUICK_RETURN)
    first = MUJOCO.step(model)
    run = MUJOCO.run(model, native.q[0], native.qd[0], None)
    assert run.ok and run.notes and all("self-check: " in n for n in run.notes), run.notes
    assert run.settings["dt"] < first
    # the loops' time constant follows the refined step (else their softness, ~ solref[0]^2, stays)
    assert run.settings["solref"] == (3 * run.settings["dt"], 1.0)
    # the cost counts every attempt
    intervals = len(model.times) - 1
    assert run.steps > intervals * (run.substeps + round((model.times[1] - model.times[0]) / first)) - 1
    c = compare(model, native, run, tolerance_of(MUJOCO))
    assert c.within_tolerance and max(run.estimate[k] / v for k, v in MUJOCO.tolerance.items()) <= 1.0
    # an explicit step is never changed
    fixed = MUJOCO.run(model, native.q[0], native.qd[0], {"dt": first})
    assert fixed.ok and not fixed.notes and fixed.settings["dt"] == pytest.approx(first)
    assert fixed.settings["solref"] == (3 * fixed.settings["dt"], 1.0)
    # a given solref is never changed by a refinement
    given = MUJOCO.run(model, native.q[0], native.qd[0], {"solref": (2e-3, 1.0)})
    assert given.notes and given.settings["solref"] == (2e-3, 1.0)


@pytest.mark.parametrize("case", [DIVERGING_FOUR_BAR, HARD_QUICK_RETURN], ids=["four-bar", "quick-return"])
def test_pymunk_retries_with_more_iterations_when_it_diverges(case):
    model, native = solved(case)
    explicit = PYMUNK.run(model, native.q[0], native.qd[0], {"iterations": 25})
    assert explicit.status is Status.DIVERGED and not explicit.notes
    run = PYMUNK.run(model, native.q[0], native.qd[0], None)
    assert run.ok and run.settings["iterations"] == 100
    assert "drifted apart" in run.notes[0] and "iterations = 100" in run.notes[0]
    # then at most refinements of the step by its own figures (the start's rates can be below the run's)
    assert all("self-check: " in n or "own run's rate" in n for n in run.notes[1:]), run.notes
    assert run.steps > (len(model.times) - 1) * run.substeps   # the diverged attempt's steps count
    assert compare(model, native, run, tolerance_of(PYMUNK)).within_tolerance


def test_pymunk_checks_that_its_velocity_solve_converged():
    from adapters.pymunk_sim import UNCONVERGED, velocity_residual

    model, native = slider_crank(1.0)
    rows = ~model.driving
    # native's own velocities satisfy the velocity equations to round-off
    assert velocity_residual(model, native.q, native.qd, model.times, rows) < 1e-12
    s = PYMUNK.settings()
    PYMUNK.resolve(model, s, native.q[0], native.qd[0])
    assert PYMUNK.retry(model, s, model.times, {"iterations"}, None, native.q, native.qd) is None
    qd = native.qd.copy()
    qd[len(qd) // 2, 5] *= 1 + 1e-4            # the rod's omega at one instant, off by 1e-4
    why, change = PYMUNK.retry(model, s, model.times, {"iterations"}, None, native.q, qd)
    assert velocity_residual(model, native.q, qd, model.times, rows) > UNCONVERGED
    assert "velocity solve did not converge" in why and change == {"iterations": 100}
    # only iterations it chose itself
    assert PYMUNK.retry(model, s, model.times, set(), None, native.q, qd) is None
