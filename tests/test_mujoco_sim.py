"""The MuJoCo adapter against the native solver (adapters/mujoco_sim.py).

Every run starts from native's first instant; the errors are measured as the
harness does (positions of bodies and named points over model.length, wrapped
angles, velocities) and held to the adapter's TOLERANCE, which is derived
there from the soft-constraint error at the default step.
"""
import tomllib
from pathlib import Path

import pickle

import numpy as np
import pytest

import kinem
from kinem.constraints import REGISTRY
from kinem.functions import FunctionSet

pytest.importorskip("mujoco")
from adapters import mujoco_sim  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ADAPTER = mujoco_sim.ADAPTER
TOL = mujoco_sim.TOLERANCE
from adapters.compare import errors as figures  # noqa: E402
CASES = ["slider_crank", "four_bar", "quick_return_1", "quick_return_2", "quick_return_3"]


def case_dict(name):
    with open(ROOT / "cases" / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def errors(model, native, run):
    """(position / L, angle [rad], velocity [1/s: linear / L and angular])."""
    a, b, L = native.trajectory, run.trajectory, model.length
    pos = ang = vel = 0.0
    for name in model.body_names + model.point_names:
        pos = max(pos, np.max(np.hypot(a[f"{name}.x"] - b[f"{name}.x"], a[f"{name}.y"] - b[f"{name}.y"])) / L)
        vel = max(vel, np.max(np.hypot(a[f"{name}.vx"] - b[f"{name}.vx"], a[f"{name}.vy"] - b[f"{name}.vy"])) / L)
    for name in model.body_names:
        ang = max(ang, np.max(np.abs(np.angle(np.exp(1j * (a[f"{name}.phi"] - b[f"{name}.phi"]))))))
        vel = max(vel, np.max(np.abs(a[f"{name}.omega"] - b[f"{name}.omega"])))
    return pos, ang, vel


def compare(data_or_path, settings=None):
    case = kinem.load(data_or_path) if isinstance(data_or_path, Path) else kinem.load_dict(data_or_path)
    model = kinem.compile(case)
    native = kinem.solve(model, outputs=("positions", "velocities"))
    assert native.success, native.message
    run = ADAPTER.run(model, native.q[0], native.qd[0], settings)
    assert run.ok, run.label
    return model, native, run


def assert_within(model, native, run):
    pos, ang, vel = errors(model, native, run)
    assert pos <= TOL["position_error_rel"], f"position error {pos:.2e} of the size"
    assert ang <= TOL["angle_error"], f"angle error {ang:.2e} rad"
    e = figures(model, native, run.q, run.trajectory)   # velocities / the run's peak speed and angular speed
    for k in ("velocity_error_rel", "angular_velocity_error_rel"):
        assert e[k] <= TOL[k], f"{k} {e[k]:.2e}"


@pytest.mark.parametrize("name", CASES)
def test_case_matches_native(name):
    model, native, run = compare(ROOT / "cases" / f"{name}.toml")
    assert_within(model, native, run)
    assert run.trajectory.columns == native.trajectory.columns
    np.testing.assert_array_equal(run.trajectory.t, model.times)
    # the step divides the output interval and is no longer than dt = "auto" asks:
    # rate_step over the mechanism's rate scale, or a step the self-check refined
    # (said in the notes; the cost counts every attempt), solref following it
    h = model.times[1] - model.times[0]
    assert run.settings["dt"] * run.substeps == pytest.approx(h, rel=1e-12)
    assert run.settings["dt"] <= ADAPTER.defaults()["rate_step"] / run.settings["rate_scale"] * (1 + 1e-12)
    assert run.settings["solref"] == (3 * run.settings["dt"], 1.0)
    assert all(n.startswith("self-check: ") for n in run.notes), run.notes
    intervals = len(model.times) - 1
    assert run.steps % intervals == 0 and run.steps >= intervals * run.substeps
    assert (run.steps == intervals * run.substeps) == (not run.notes)
    assert max(run.estimate[k] / v for k, v in TOL.items()) <= 1.0   # its own check holds
    assert run.wall_time > 0 and run.version == ADAPTER.version()


DRIVERS = {
    "constant speed": {"poly": [0.7853981633974483, 1.5]},
    "constant acceleration": {"poly": [0.7853981633974483, 1.5, -0.6]},
    "harmonic": {"harmonic": {"amplitude": 1.0, "omega": 2.0, "phase": 0.0, "offset": 0.7853981633974483}},
    "table": {"table": {"t": [0.0, 0.5, 1.0, 1.5, 2.0, 2.5], "value": [0.785, 1.2, 2.0, 2.4, 2.2, 1.5]}},
}


@pytest.mark.parametrize("settings, key", [({"integrator": "no-such-integrator"}, "integrator"),
                                           ({"dt": 0}, "dt"), ({"dt": -1.0}, "dt"), ({"dt": "x"}, "dt"),
                                           ({"solimp": [0.9]}, "solimp"), ({"bogus": 1}, "bogus")])
def test_bad_setting_is_an_input_error(settings, key):
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    with pytest.raises(kinem.InputError, match=f"mujoco setting '{key}'"):
        ADAPTER.run(model, model.q0, np.zeros(model.n), settings)


@pytest.mark.parametrize("kind", DRIVERS)
def test_driver_function_kinds(kind):
    data = case_dict("four_bar")
    for c in data["constraints"]:
        if c["type"] == "driver":
            c["d"] = DRIVERS[kind]
    assert_within(*compare(data))


def test_relative_driver():
    # the coupler driven relative to the crank at joint A; the crank follows
    data = case_dict("four_bar")
    for c in data["constraints"]:
        if c["type"] == "driver":
            c.update(body="coupler", relative_to="crank", d={"poly": [0.27 - 0.785, 0.5]})
    assert_within(*compare(data))


@pytest.mark.parametrize("point", [None, [50.0, 0.0]])
def test_slider_x_driver(point):
    # slider-crank driven by the slider (or a point of it) along x, away from the dead centres
    data = case_dict("slider_crank")
    data["time"] = {"end": 2.0, "steps": 200}
    drive = {"type": "driver", "name": "push", "body": "slider", "coord": "x",
             "d": {"harmonic": {"amplitude": 30.0, "omega": 1.0, "offset": -663.1 + (point or [0])[0]}}}
    if point:
        drive["point"] = point
    data["constraints"] = [c for c in data["constraints"] if c["type"] != "driver"] + [drive]
    assert_within(*compare(data))


def test_distance_driver():
    # a linear actuator between a ground point and an arm pinned to ground
    data = {"name": "actuator", "time": {"end": 3.0, "steps": 300},
            "bodies": {"ground": {"q": [0, 0, 0]}, "arm": {"q": [35, 35, 0.785]}},
            "points": {"P": {"body": "arm", "at": [50, 0]}},
            "constraints": [
                {"type": "ground", "body": "ground"},
                {"type": "revolute", "name": "O", "i": "ground", "si": [0, 0], "j": "arm", "sj": [-50, 0]},
                {"type": "distance-driver", "name": "act", "i": "ground", "si": [0, -100], "j": "arm",
                 "sj": [50, 0], "d": {"harmonic": {"amplitude": 10.0, "omega": 2.0, "offset": 184.8}}}]}
    assert_within(*compare(data))


def scotch_yoke(pin_on_crank):
    """A yoke held by absolute y and phi, moved by a crank through a
    revolute-translational joint: the yoke is a tree child of the crank
    (line body: hinge then slide; pin body: slide then hinge)."""
    c0 = [50 * np.cos(0.5), 50 * np.sin(0.5), 0.5]
    if pin_on_crank:
        yoke = [100 * np.cos(0.5), 0.0, 0.0]
        rt = {"i": "crank", "si": [50, 0], "j": "yoke", "sj": [0, 0], "qj": [0, 100]}
    else:
        yoke = [50 / np.tan(0.5), 50.0, 0.0]
        rt = {"i": "yoke", "si": [0, 0], "j": "crank", "sj": [-50, 0], "qj": [50, 0]}
    return {"name": "yoke", "time": {"end": 1.0, "steps": 100},
            "bodies": {"ground": {"q": [0, 0, 0]}, "crank": {"q": c0}, "yoke": {"q": yoke}},
            "points": {"Y": {"body": "yoke", "at": [10, 20]}},
            "constraints": [
                {"type": "ground", "body": "ground"},
                {"type": "revolute", "name": "O", "i": "ground", "si": [0, 0], "j": "crank", "sj": [-50, 0]},
                {"type": "driver", "name": "drive", "body": "crank", "coord": "phi", "d": {"poly": [0.5, 0.8]}},
                {"type": "revolute-translational", "name": "A", **rt},
                {"type": "absolute", "name": "y", "body": "yoke", "coord": "y", "point": [10.0, 0.0]},
                {"type": "absolute", "name": "phi", "body": "yoke", "coord": "phi"}]}


@pytest.mark.parametrize("pin_on_crank", [True, False])
def test_revolute_translational_in_tree(pin_on_crank):
    data = scotch_yoke(pin_on_crank)
    model, native, run = compare(data)
    plan = mujoco_sim.Plan(model, native.q[0])
    yoke = next(b for b in plan.bodies if b[0] == "yoke")
    assert yoke[1] == "crank" and [j[0] for j in yoke[4]] == (
        ["hinge", "slide"] if pin_on_crank else ["slide", "hinge"])
    assert_within(model, native, run)


def test_floating_body():
    # a platform held only by three revolute-revolute links: a free root of the tree
    data = {"name": "platform", "time": {"end": 2.0, "steps": 200},
            "bodies": {"ground": {"q": [0, 0, 0]}, "crank": {"q": [175, 0, 0]}, "plat": {"q": [150, 200, 0]}},
            "points": {"P3": {"body": "plat", "at": [0, -50]}},
            "constraints": [
                {"type": "ground", "body": "ground"},
                {"type": "revolute", "name": "O", "i": "ground", "si": [150, 0], "j": "crank", "sj": [-25, 0]},
                {"type": "driver", "name": "d", "body": "crank", "coord": "phi",
                 "d": {"harmonic": {"amplitude": 0.2, "omega": 3.0}}},
                {"type": "revolute-revolute", "name": "L1", "i": "ground", "si": [0, 0], "j": "plat",
                 "sj": [-100, 0], "length": float(np.hypot(50, 200))},
                {"type": "revolute-revolute", "name": "L2", "i": "ground", "si": [300, 0], "j": "plat",
                 "sj": [100, 0], "length": float(np.hypot(50, 200))},
                {"type": "revolute-revolute", "name": "L3", "i": "crank", "si": [25, 0], "j": "plat",
                 "sj": [0, -50], "length": float(np.hypot(50, 150))}]}
    model, native, run = compare(data)
    plan = mujoco_sim.Plan(model, native.q[0])
    assert next(b for b in plan.bodies if b[0] == "plat")[1] == mujoco_sim.WORLD
    assert_within(model, native, run)


def test_free_representation():
    # every body free in the plane, every joint an equality: the same motion, less accurately
    assert_within(*compare(ROOT / "cases" / "quick_return_1.toml", {"tree": "free"}))


@pytest.mark.parametrize("name", ["gear_pair", "planetary", "rack_pinion", "rolling_pinion"])
def test_gears(name):
    path = ROOT / "cases" / f"{name}.toml"
    if not path.exists() or REGISTRY.get("gear") is None or REGISTRY["gear"].family is None:
        pytest.skip("gear cases or families not present")
    assert_within(*compare(path))


def test_declarations_cover_every_type():
    assert set(ADAPTER.supports) | set(ADAPTER.reasons) == set(REGISTRY)
    assert not set(ADAPTER.supports) & set(ADAPTER.reasons)


def test_unsupported_type():
    # a pin in a circular slot (point-follower): no exact MuJoCo constraint
    data = {"name": "slot", "time": {"end": 1.0, "steps": 10},
            "bodies": {"ground": {"q": [0, 0, 0]}, "pin": {"q": [50, 0, 0]}},
            "constraints": [
                {"type": "ground", "body": "ground"},
                {"type": "point-follower", "name": "slot", "i": "pin", "si": [0, 0], "j": "ground",
                 "outline": {"circle": {"radius": 50.0}, "center": [0.0, 0.0]}, "theta": 0.0},
                {"type": "absolute", "name": "no-spin", "body": "pin", "coord": "phi"},
                {"type": "driver", "name": "lift", "body": "pin", "coord": "y",
                 "d": {"harmonic": {"amplitude": 40.0, "omega": 1.5}}}]}
    if REGISTRY["point-follower"].family is None:
        pytest.skip("point-follower not implemented in kinem")
    model = kinem.compile(kinem.load_dict(data))
    run = ADAPTER.run(model, model.q0, np.zeros(model.n))
    assert run.label.startswith("unsupported: point-follower"), run.label
    assert run.trajectory is None and ADAPTER.unsupported(model) == run.detail


def test_unsupported_driver_form():
    # the coupler's absolute angle is no joint's coordinate
    data = case_dict("four_bar")
    for c in data["constraints"]:
        if c["type"] == "driver":
            c.update(body="coupler", d={"poly": [0.27, 0.5]})
    model = kinem.compile(kinem.load_dict(data))
    run = ADAPTER.run(model, model.q0, np.zeros(model.n))
    assert run.label.startswith("unsupported: driver ('crank-drive'): phi of 'coupler' needs"), run.label
    # typed: the report groups cases by the constraint type and the why, never by reading the text back
    assert (run.detail.kind, run.detail.why.split(" needs")[0]) == ("driver", "phi of 'coupler'")
    # and it comes back whole from a worker process (the report's pool pickles runs)
    back = pickle.loads(pickle.dumps(run.detail))
    assert (back, back.kind, back.name, back.why) == (run.detail, "driver", "crank-drive", run.detail.why)


@pytest.mark.parametrize("settings", [
    {"dt": 0.01, "refsafe": False, "solref": [1e-5, 1.0]},   # equality springs far too stiff for the step
])
def test_failure_is_a_status(settings):
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    native = kinem.solve(model)
    run = ADAPTER.run(model, native.q[0], native.qd[0], settings)
    assert run.label.startswith("failed: "), run.label
    assert "\n" not in run.label


@pytest.mark.parametrize("name", ["slider_crank", "quick_return_1"])
def test_interval_drive_steps_in_c_within_tolerance(name):
    """drive = "interval": driven joints set only at output instants and each interval
    stepped by one mj_step(m, d, substeps) call; the driver is linear in t in these cases,
    so the armature holds it between instants (measured 2e-9 and 2e-8 of L, within the defaults' tolerance)."""
    model, native, run = compare(ROOT / "cases" / f"{name}.toml", {"drive": "interval"})
    assert run.settings["drive"] == "interval"
    assert run.steps % (len(model.times) - 1) == 0   # every interval stepped whole (each attempt)
    assert_within(model, native, run)


if __name__ == "__main__":   # the table of docs/engines/mujoco.md: .venv/bin/python tests/test_mujoco_sim.py
    for name in CASES:
        model, native, run = compare(ROOT / "cases" / f"{name}.toml")
        pos, ang, vel = errors(model, native, run)
        print(f"{name:15s} position/L {pos:.1e}  angle {ang:.1e} rad  velocity {vel:.1e} /s  "
              f"dt {run.settings['dt']:.3g} s  steps {run.steps}  {1e6 * run.wall_time / run.steps:.1f} us/step")
