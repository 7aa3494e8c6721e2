"""The Exudyn adapter against the native solver (adapters/exudyn_sim.py).

Every run starts from the native solution at t = 0 and is compared at the
output instants with the figures of adapters.compare.errors.
"""
import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import exudyn as exu
import kinem
from adapters.compare import errors
from adapters.exudyn_sim import ADAPTER, TOLERANCE, _Function
from kinem.errors import InputError
from kinem.functions import Harmonic, Poly, Table, value_at

CASES = Path(__file__).resolve().parents[1] / "cases"
FIVE = ["slider_crank", "four_bar", "quick_return_1", "quick_return_2", "quick_return_3"]
HIGHER_PAIRS = ["gear_pair", "planetary", "rack_pinion", "rolling_pinion"]
REDUNDANT = ["stress/double_slider", "stress/parallelogram_redundant"]  # consistent redundant constraints


def case_dict(name):
    with open(CASES / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def constraint(d, name):
    return next(c for c in d["constraints"] if c.get("name") == name)


def run_against_native(model, settings=None, native=None):
    native = native or kinem.solve(model)
    assert native.success, native.message
    run = ADAPTER.run(model, native.q[0], native.qd[0], ADAPTER.settings(settings))
    assert run.ok, run.label
    n_out = len(model.times) - 1
    assert run.steps == run.substeps * n_out or any(n.startswith(("self-check", "its own run")) for n in run.notes)
    assert run.q.shape == native.q.shape and all(c in native.trajectory for c in run.trajectory.columns)
    return errors(model, native, run.q, run.trajectory)


def assert_within(e, tolerance=TOLERANCE):
    bad = {k: (e[k], v) for k, v in tolerance.items() if not e[k] <= v}
    assert not bad, f"(figure, limit): {bad}"


@pytest.mark.parametrize("name", FIVE)
def test_case_matches_native(name):
    model = kinem.compile(kinem.load(CASES / f"{name}.toml"))
    assert_within(run_against_native(model))


def test_positions_at_round_off_against_a_tightly_converged_native():
    # The native default tolerance (scaled residual 1e-12) bounds the figures
    # of test_case_matches_native; with native converged to 1e-14 both are at
    # round-off: measured <= 1.3e-14 of L on the five cases, 1e-12 is 100x that.
    case = kinem.load(CASES / "quick_return_1.toml").with_time(end=0.6, steps=60)
    model = kinem.compile(case)
    tight = dataclasses.replace(kinem.Options.of(case), tolerance=1e-14, max_iterations=50)
    e = run_against_native(model, native=kinem.solve(model, options=tight))
    assert e["position_error_rel"] <= 1e-12 and e["angle_error"] <= 1e-12
    assert e["constraint_residual"] <= 1e-12


DRIVES = {
    "constant speed": {"poly": [0.7853981633974483, 1.5]},
    "constant acceleration": {"poly": [0.7853981633974483, 1.5, -0.6]},
    "harmonic": {"harmonic": {"amplitude": 0.8, "omega": 2.5, "phase": 0.3, "offset": 0.55}},
    "table": {"table": {"t": [0.0, 0.3, 0.6, 1.0, 1.4], "value": [0.7, 1.0, 1.5, 1.6, 2.2]}},
}


@pytest.mark.parametrize("kind", list(DRIVES))
def test_driver_function_kinds(kind):
    d = case_dict("four_bar")
    d["time"] = {"end": 1.0, "steps": 100}
    constraint(d, "crank-drive")["d"] = DRIVES[kind]
    assert_within(run_against_native(kinem.compile(kinem.load_dict(d))))


def test_python_user_functions_give_the_symbolic_result():
    d = case_dict("four_bar")
    d["time"] = {"end": 1.0, "steps": 100}
    constraint(d, "crank-drive")["d"] = DRIVES["table"]
    model = kinem.compile(kinem.load_dict(d))
    native = kinem.solve(model)
    runs = [ADAPTER.run(model, native.q[0], native.qd[0], ADAPTER.settings({"symbolic_drivers": s}))
            for s in (True, False)]
    # the same expressions evaluated in C++ or Python: round-off apart
    assert np.abs(runs[0].q - runs[1].q).max() <= 1e-12 * model.length


@pytest.mark.parametrize("f", [Poly((0.3, -1.2, 0.7, 0.05)), Harmonic(0.8, 2.5, 0.3, 0.55),
                               Table((0.0, 0.3, 0.6, 1.0, 1.4), (0.7, 1.0, 1.5, 1.6, 2.2))])
def test_function_values_match_kinem(f):
    fn = _Function(f)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    d, d_t = fn.symbolic(mbs, offset=0.25)
    for t in (-0.2, 0.0, 0.3, 0.45, 1.0, 1.37, 1.6):
        for order in (0, 1, 2):
            ref = value_at(f, t, order)
            assert fn.value(t, order) == pytest.approx(ref, rel=1e-13, abs=1e-13)
        assert d.Evaluate(mbs, t, 0, 0.0) == pytest.approx(0.25 + value_at(f, t), rel=1e-13, abs=1e-13)
        assert d_t.Evaluate(mbs, t, 0, 0.0) == pytest.approx(value_at(f, t, 1), rel=1e-13, abs=1e-13)


def _slider_x():
    d = case_dict("slider_crank")
    constraint(d, "crank-drive").update(body="slider", coord="x",
                                        d={"harmonic": {"amplitude": 100.0, "omega": 1.5, "offset": -500.0}})
    return d


def _point(coord, offset):
    d = case_dict("four_bar")
    constraint(d, "crank-drive").update(coord=coord, point=[0.05, 0.0],
                                        d={"harmonic": {"amplitude": 0.02, "omega": 2.0, "offset": offset}})
    return d


def _relative():
    d = case_dict("four_bar")
    constraint(d, "crank-drive").update(body="coupler", relative_to="crank",
                                        d={"harmonic": {"amplitude": 0.1, "omega": 2.0, "offset": -0.55}})
    return d


def _relative_to_turned_ground():
    d = case_dict("four_bar")
    d["bodies"]["ground"]["q"] = [0.01, -0.02, 0.2]
    constraint(d, "crank-drive").update(relative_to="ground", d={"poly": [0.6, 1.5, -0.6]})
    return d


def _absolute():
    d = case_dict("slider_crank")
    d["constraints"] = [c for c in d["constraints"] if c.get("name") != "T"]
    d["constraints"] += [{"type": "absolute", "name": "y-point", "body": "slider", "coord": "y",
                          "point": [100.0, 0.0], "value": 0.0},
                         {"type": "absolute", "name": "y", "body": "slider", "coord": "y", "value": 0.0}]
    return d


def _distance_driver():
    d = case_dict("slider_crank")
    d["constraints"] = [c for c in d["constraints"] if c.get("name") != "crank-drive"]
    d["constraints"].append({"type": "distance-driver", "name": "cylinder", "i": "ground", "si": [0.0, 0.0],
                             "j": "slider", "sj": [0.0, 0.0], "d": {"poly": [663.0, -100.0]}})
    return d


FORMS = {"x of a slider": _slider_x, "y of a point": lambda: _point("y", 0.0707),
         "x of a point": lambda: _point("x", 0.0207), "relative angle": _relative,
         "relative to a turned ground": _relative_to_turned_ground, "absolute": _absolute,
         "distance-driver": _distance_driver}


@pytest.mark.parametrize("form", list(FORMS))
def test_other_supported_forms(form):
    d = FORMS[form]()
    d["time"] = {"end": 1.0, "steps": 100}
    assert_within(run_against_native(kinem.compile(kinem.load_dict(d))))


@pytest.mark.parametrize("name", HIGHER_PAIRS + REDUNDANT)
def test_gears_rack_pinion_and_redundant_constraints(name):
    if not (CASES / f"{name}.toml").exists():
        pytest.skip(f"cases/{name}.toml not present")
    model = kinem.compile(kinem.load(CASES / f"{name}.toml").with_time(end=1.0, steps=100))
    assert_within(run_against_native(model))


def test_a_pin_in_a_circular_slot_is_a_user_constraint():
    """A point-follower (formerly unsupported): the pin's outline angle theta
    is a node of its own, read back into the trajectory's theta column."""
    d = case_dict("slider_crank")
    d["time"] = {"end": 0.5, "steps": 25}
    d["bodies"]["pin"] = {"q": [50.0, 0.0, 0.0]}
    d["constraints"] += [{"type": "point-follower", "name": "slot", "i": "pin", "si": [0.0, 0.0], "j": "ground",
                          "outline": {"circle": {"radius": 50.0}, "center": [0.0, 0.0]}, "theta": 0.0},
                         {"type": "absolute", "name": "no-spin", "body": "pin", "coord": "phi", "value": 0.0},
                         {"type": "driver", "name": "lift", "body": "pin", "coord": "y",
                          "d": {"harmonic": {"amplitude": 30.0, "omega": 1.5}}}]
    model = kinem.compile(kinem.load_dict(d))
    native = kinem.solve(model)
    assert_within(run_against_native(model, native=native))
    run = ADAPTER.run(model, settings=ADAPTER.settings())
    col = model.coordinate_names.index("slot.theta")
    assert np.abs(run.q[:, col] - native.q[:, col]).max() <= 1e-9   # rad, the position tolerance's class


def test_driver_on_a_grounded_body_is_unsupported():
    d = case_dict("four_bar")
    constraint(d, "crank-drive")["body"] = "ground"
    model = kinem.compile(kinem.load_dict(d))
    run = ADAPTER.run(model, model.q0, np.zeros(model.n))
    assert run.label.startswith("unsupported: driver") and run.trajectory is None


@pytest.mark.parametrize("absurd", [{"newton_max_iterations": 1},
                                    {"substeps": 1, "dt": 10.0, "newton_max_iterations": 2}])
def test_blow_up_is_a_failed_status_and_silent(absurd, capfd):
    model = kinem.compile(kinem.load(CASES / "slider_crank.toml").with_time(end=0.2, steps=20))
    native = kinem.solve(model)
    run = ADAPTER.run(model, native.q[0], native.qd[0], ADAPTER.settings(absurd))
    assert run.label.startswith("failed: ") and run.q is None
    assert capfd.readouterr().out == ""


def test_a_run_prints_nothing(capfd):
    model = kinem.compile(kinem.load(CASES / "quick_return_2.toml").with_time(end=0.1, steps=10))
    native = kinem.solve(model)
    assert ADAPTER.run(model, native.q[0], native.qd[0]).ok
    assert capfd.readouterr().out == ""


def test_settings_are_checked_and_recorded():
    with pytest.raises(InputError):
        ADAPTER.settings({"time_step": 1e-3})
    with pytest.raises(InputError):
        ADAPTER.settings({"integrator": "rk4"})
    model = kinem.compile(kinem.load(CASES / "slider_crank.toml").with_time(end=0.1, steps=10))
    native = kinem.solve(model)
    run = ADAPTER.run(model, native.q[0], native.qd[0], ADAPTER.settings({"dt": 3e-3}))
    # the step divides the output interval 0.01 and is at most dt: 4 substeps; the
    # settings record the step used (as every adapter's do)
    assert run.substeps == 4 and run.steps == 40 and run.settings["dt"] == pytest.approx(2.5e-3, rel=1e-12)
    assert run.version == ADAPTER.version() and math.isfinite(run.wall_time)


# -- cams and slots: the adapter's own constraint equations (issue 29, item 8) --

def test_curve_constraint_gradients_match_finite_differences():
    """point_on_curve, cam_roller and cam_flat: each gradient row against
    fourth-order central differences of its rows (tests/fd.py), on a spline
    outline at random coordinates. A wrong term is of order 1; the limit is
    fd.TOL_FIRST of max(1, |value|)."""
    from adapters.exudyn_sim import cam_flat, cam_roller, point_on_curve
    from fd import TOL_FIRST, d1
    from kinem.outline import Outline

    outline = Outline.spline([0.0, 1.0, 2.5, 4.0, 2 * np.pi], [3.0, 3.6, 2.8, 3.3, 3.0], periodic=True,
                             center=(0.4, -0.2))
    rng = np.random.default_rng(29)
    n = np.exp(0.7j)
    for factory, args in ((point_on_curve, (0.3 - 0.5j,)), (cam_roller, (0.3 - 0.5j, 0.8)),
                          (cam_flat, (0.3 - 0.5j, n))):
        phi, grad, phi_t = factory(outline, *args)
        assert phi_t is None   # no explicit time
        for _ in range(5):
            z = rng.uniform(-2.0, 2.0, 7)
            g = np.array(grad(list(z), 0.0))
            for k in range(7):
                e = np.zeros(7)
                e[k] = 1.0
                fd = d1(lambda h: np.array(phi(list(z + h * e), 0.0)))
                assert np.abs(g[:, k] - fd).max() <= TOL_FIRST * max(1.0, np.abs(fd).max()), (factory.__name__, k)
