"""Singular configurations and branches (docs/solver.md): the solver never
returns a wrong answer silently. Limit positions stop with a diagnosis;
change points are passed on the smooth branch and recorded; coarse output
steps stay on the assembly branch."""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import kinem
from closed_form import four_bar, rel_error, slider_crank, wrap

STRESS = Path(__file__).resolve().parents[1] / "cases" / "stress"
BOTH = [kinem.OUTPUTS, ("positions",)]


def run(name, outputs=kinem.OUTPUTS, steps=None):
    case = kinem.load(STRESS / f"{name}.toml")
    if steps:
        case = case.with_time(steps=steps)
    return kinem.solve(kinem.compile(case), outputs)


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("steps", [100, 97, 7])  # an instant on the singular point, straddling it, coarse
@pytest.mark.parametrize("name, t_star, involved", [
    ("slider_dead_centre", 0.5, {"slider-drive", "B", "A"}),  # x = 0.35 + 0.1 t reaches r + l = 0.4 at 0.5
    ("rocker_toggle", 0.5, {"rocker-drive", "A", "B"}),      # the rocker's extreme angle at 0.5
])
def test_limit_position_stops_with_diagnosis(name, t_star, involved, steps, outputs):
    r = run(name, outputs, steps)
    assert not r.success and r.status == kinem.Status.SINGULAR
    assert "singular configuration at t = " in r.message and "limit position" in r.message
    t_diag = float(r.message.split("singular configuration at t = ")[1].split(":")[0])
    # located within 1e-3 s: near a limit position the configuration moves like sqrt(t* - t),
    # so the last trustworthy state lies ~(pivot floor 1e-4)^2 / rate^2 before it
    assert abs(t_diag - t_star) < 1e-3
    cond = float(r.message.split("conditioning ")[1].split(" ")[0])
    assert cond < 1e-2
    named = set(r.message.split("constraints involved: ")[1].split(";")[0].split(", "))
    assert involved <= named
    # nothing past the singular instant is returned
    assert r.trajectory.t[-1] < t_star


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("steps", [100, 97, 16, 8])
def test_change_point_stays_on_smooth_branch(steps, outputs):
    r = run("change_point", outputs, steps)
    assert r.success, r.message
    assert len(r.events) == 1 and "singular configuration" in r.events[0][1]
    t = r.trajectory.t
    th2 = -1.5 + t
    before, after = four_bar(th2, 1 + 0 * t, 0 * t, 1.0, 3.0, 2.0, 2.0, 1.0), four_bar(th2, 1 + 0 * t, 0 * t, 1.0, 3.0, 2.0, 2.0, -1.0)
    # the smooth branch: B left of A->O4 before the change point (t = 1.5), right of it after
    th4 = np.where(t <= 1.5, before["th4"], after["th4"])
    th3 = np.where(t <= 1.5, before["th3"], after["th3"])
    # 1e-8: away from the change point the solution is as accurate as anywhere (1e-12 of the
    # size); the instant on it is interpolated, error ~ (distance to its neighbours)^4
    assert np.abs(wrap(r.trajectory["rocker.phi"] - th4)).max() < 1e-8
    assert np.abs(wrap(r.trajectory["coupler.phi"] - th3)).max() < 1e-8
    if "velocities" in outputs:
        w4 = np.where(t < 1.5, before["w4"], after["w4"])
        ok = np.abs(t - 1.5) > 1e-9  # the closed form divides by zero on the change point itself
        assert rel_error(r.trajectory["rocker.omega"][ok], w4[ok]) < 1e-8


@pytest.mark.parametrize("outputs", BOTH)
def test_coarse_crank_stays_on_branch(outputs):
    r = run("coarse_crank", outputs)
    assert r.success, r.message
    t = r.trajectory.t
    ref = slider_crank(5.76 - 1.2 * t + np.pi, -1.2 + 0 * t, 0 * t, 200.0, 500.0)
    assert rel_error(r.trajectory["slider.x"], ref["x"]) < 1e-9
    assert np.all(r.trajectory["slider.x"] < 0)  # the assembly branch: slider left of the crank


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("per_turn", [8, 4, 3])
def test_coarse_four_bar_stays_on_branch(outputs, per_turn):
    case = kinem.load(Path(__file__).resolve().parents[1] / "cases" / "four_bar.toml")
    d = next(c for c in case.constraints if c.type == "driver")
    # constant speed 2 rad/s for three turns
    from kinem.functions import Poly
    cons = tuple(replace(c, fields={**c.fields, "d": Poly((math.pi / 4, 2.0))}) if c is d else c for c in case.constraints)
    case = replace(case, constraints=cons, end=3 * math.pi, steps=3 * per_turn)
    r = kinem.solve(kinem.compile(case), outputs)
    assert r.success, r.message
    t = r.trajectory.t
    ref = four_bar(math.pi / 4 + 2 * t, 2 + 0 * t, 0 * t, 0.1, 0.3, 0.22, 0.2)
    assert np.abs(wrap(r.trajectory["rocker.phi"] - ref["th4"])).max() < 1e-9


def test_rough_estimate_does_not_spin_the_assembly():
    """Newton steps are limited: a poor estimate assembles near itself, not turns away."""
    case = kinem.load(Path(__file__).resolve().parents[1] / "cases" / "slider_crank.toml")
    bodies = tuple(replace(b, q=(b.q[0] + 40.0, b.q[1] - 30.0, b.q[2] + 0.4)) if b.name == "rod" else b for b in case.bodies)
    r = kinem.solve(kinem.compile(replace(case, bodies=bodies)), ("positions",))
    assert r.success
    assert abs(r.trajectory["rod.phi"][0] - 0.2012) < 0.01 and abs(r.trajectory["crank.phi"][0] - 5.76) < 1e-12


def test_conditioning_recorded_per_instant():
    r = kinem.solve(kinem.compile(kinem.load(Path(__file__).resolve().parents[1] / "cases" / "slider_crank.toml")))
    assert r.conditioning.shape == r.iterations.shape
    assert np.all((r.conditioning > 1e-2) & (r.conditioning <= 1.0))  # a regular mechanism all along


def test_redundant_parallelogram_solves():
    """16 consistent equations for 15 coordinates: the coupler translates."""
    r = run("parallelogram_redundant")
    assert r.success, r.message
    tr = r.trajectory
    th, w = 1.0 + 0.8 * tr.t, 0.8
    # 1e-9 of the size (L = 2) and of the rates: the least-squares solve is exact for consistent rows
    assert np.abs(tr["coupler.phi"]).max() < 1e-9
    for k in (1, 2, 3):
        assert np.abs(wrap(tr[f"crank{k}.phi"] - th)).max() < 1e-9
        assert np.abs(tr[f"crank{k}.omega"] - w).max() < 1e-9
    assert np.abs(tr["P.x"] - (1 + np.cos(th))).max() < 2e-9
    assert np.abs(tr["P.ay"] + w * w * np.sin(th)).max() < 1e-8


def test_redundant_double_slider_matches_single():
    single = kinem.solve(kinem.compile(kinem.load(STRESS.parent / "slider_crank.toml")))
    double = run("double_slider")
    assert double.success, double.message
    assert np.abs(double.trajectory.data - single.trajectory.data).max() <= 1e-9 * 665  # 1e-9 of the size L


def test_info_names_redundant_equations_of_the_stress_cases():
    from kinem.info import info

    i = info(kinem.compile(kinem.load(STRESS / "parallelogram_redundant.toml")))
    assert (i.equations, i.coordinates, i.dof, len(i.redundant_equations)) == (16, 15, 1, 1)
    i = info(kinem.compile(kinem.load(STRESS / "double_slider.toml")))
    assert (i.equations, i.coordinates, i.dof, len(i.redundant_equations)) == (14, 12, 1, 2)


def test_missing_driver_says_how_many():
    """The parallelogram without its driver: 15 equations for 15 coordinates,
    but one is redundant, so one degree of freedom is left."""
    case = kinem.load(STRESS / "parallelogram_redundant.toml")
    case = replace(case, constraints=tuple(c for c in case.constraints if c.type != "driver"))
    r = kinem.solve(kinem.compile(case))
    assert not r.success
    assert "1 degree(s) of freedom left after the drivers (add 1 driving equation(s))" in r.message
    assert "dependent equations: T2.y" in r.message


def test_inconsistent_redundant_constraints_fail_clearly():
    """A third crank that is not parallel (pivot at 2.1): the loop cannot close."""
    text = (STRESS / "parallelogram_redundant.toml").read_text().replace("si = [2.0, 0.0]", "si = [2.1, 0.0]")
    r = kinem.solve(kinem.compile(kinem.loads(text, source="x.toml")))
    assert not r.success and r.status == kinem.Status.NOT_CONVERGED
    assert "16 equations for 15 coordinates: 1 redundant, and not consistent here" in r.message


def crank_pin_twice():
    """The book's slider-crank with its crank pin B written twice: 14 consistent equations for 12 coordinates."""
    case = kinem.load(STRESS.parent / "slider_crank.toml")
    b = next(c for c in case.constraints if c.type == "revolute" and c.name == "B")
    return replace(case, constraints=case.constraints + (replace(b, name="B2"),))


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("steps", [5, 6, 7, 9])
@pytest.mark.parametrize("name", ["double_slider", "crank_pin_twice"])
def test_redundant_model_at_coarse_steps_stays_on_branch(name, steps, outputs):
    """A consistent redundant model keeps the branch its square twin keeps, at output steps of
    up to a quarter turn (least squares has no det of its own: the det sign of a square subsystem
    of independent rows is monitored)."""
    case = crank_pin_twice() if name == "crank_pin_twice" else kinem.load(STRESS / f"{name}.toml")
    case = case.with_time(end=5 * math.pi / 1.2, steps=steps)  # 2.5 crank turns at 1.2 rad/s
    twin = replace(case, constraints=tuple(c for c in case.constraints if c.name not in ("T2", "B2")))
    r, square = (kinem.solve(kinem.compile(c), outputs) for c in (case, twin))
    assert square.success and r.success, r.message
    t = r.trajectory.t
    ref = slider_crank(5.76 - 1.2 * t + np.pi, -1.2 + 0 * t, 0 * t, 200.0, 500.0)  # as test_coarse_crank_stays_on_branch
    # 1e-9 of the size: both are solved to the tolerance, a branch flip is hundreds of mm off
    assert np.abs(r.trajectory["slider.x"] - ref["x"]).max() < 1e-9 * 665
    assert np.abs(r.trajectory.data - square.trajectory.data).max() < 1e-9 * 665


def reversal_short_of_change_point(sign):
    """The change-point four-bar (crank 1, coupler 3, rocker 2, ground 2) with its crank driven to
    phi = -1e-6 - 0.5 (t - 1.5)^2: it turns back 1e-6 short of the change point (phi = 0) at the
    output instant t = 1.5."""
    from kinem.reference import four_bar_case

    fn = {"poly": [-1e-6 - 1.125, 1.5, -0.5]}
    return kinem.load_dict(four_bar_case(1.0, 3.0, 2.0, 2.0, fn, phi0=-1e-6 - 1.125, sign=sign, end=3.0, steps=100))


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_reversal_just_short_of_change_point_is_solved_not_interpolated(sign, outputs):
    r = kinem.solve(kinem.compile(reversal_short_of_change_point(sign)), outputs)
    assert r.success, r.message
    assert not any("interpolated" in text for _, text in r.events)
    assert r.conditioning[50] > 0  # solved: its pivot ratio is recorded (an interpolated instant has none)
    L = np.longdouble  # the closed form in extended precision: in double it loses 1e-10 this near the change point
    t = r.trajectory.t.astype(L)
    ref = four_bar(L(-1e-6) - L(0.5) * (t - L(1.5)) ** 2, 1.5 - t, -np.ones_like(t), L(1), L(3), L(2), L(2), sign)
    # 1e-9 of the size (3): rounding (1e-16) over the conditioning there (3e-7) is 3e-10
    for axis, got in (("real", r.trajectory["B.x"]), ("imag", r.trajectory["B.y"])):
        assert np.abs(got - getattr(ref["B"], axis).astype(float)).max() < 1e-9 * 3
