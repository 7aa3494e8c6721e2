"""One scheme of design-parameter paths (kinem.parameters) for every kind of
case: angles in degrees, joints drawn in the global frame, named dimensions
(parameters.<name>); the same paths for apply, --set, sweeps, sensitivities
and tolerances."""
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import cli
from kinem.errors import InputError
from kinem.parameters import apply, case_dict, parameters, resolve

ROOT = Path(__file__).resolve().parents[1]
NAMED = ROOT / "tests" / "data" / "four_bar_named.toml"
DRAWN = sorted((ROOT / "tests" / "data" / "drawn").glob("*.toml"))


def degrees_slider_crank():
    """cases/slider_crank.toml with units = { angle = "deg" } (its angles in degrees)."""
    text = (ROOT / "cases" / "slider_crank.toml").read_text()
    return (text.replace('units = { length = "mm" }', 'units = { length = "mm", angle = "deg" }')
            .replace("5.76]", f"{math.degrees(5.76)!r}]").replace("0.2]", f"{math.degrees(0.2)!r}]")
            .replace("[5.76, -1.2]", f"[{math.degrees(5.76)!r}, {math.degrees(-1.2)!r}]"))


def same(a, b, tol=1e-14):
    """Cases equal but for rounding in their angles (relative ``tol``)."""
    assert [c.fields.keys() for c in a.constraints] == [c.fields.keys() for c in b.constraints]
    for x, y in zip(a.bodies, b.bodies):
        np.testing.assert_allclose(x.q, y.q, rtol=tol, atol=0)
    pa, pb = parameters(a), parameters(b)
    assert [p.path for p in pa] == [p.path for p in pb]
    for x, y in zip(pa, pb):
        assert abs(x.value - y.value) <= tol * max(1, abs(x.value)), (x, y)


def test_degrees_round_trip_and_paths_in_degrees():
    """case_dict writes a case in degrees in degrees (it wrote radians under
    angle = "deg" before: apply converted twice); its angle parameters are
    listed and set in degrees."""
    case = kinem.loads(degrees_slider_crank())
    back = kinem.load_dict(case_dict(case))
    same(back, case)
    assert back.units["angle"] == "deg"
    speed = {p.path: p for p in parameters(case)}["constraints.crank-drive.d.poly.1"]
    assert speed.unit == "deg/s" and abs(speed.value - math.degrees(-1.2)) <= 1e-12
    moved = apply(case, {speed.path: -60.0})
    assert abs(moved.constraints[-1]["d"].coeffs[1] - math.radians(-60.0)) <= 1e-15   # not converted twice
    edited = kinem.loads(degrees_slider_crank().replace(f"{math.degrees(-1.2)!r}]", "-60.0]"))
    same(moved, edited)


@pytest.mark.parametrize("path", DRAWN, ids=lambda p: p.stem)
def test_drawn_round_trip(path):
    """A drawn case's dict draws its points again: the same case back, and
    every parameter set to its own value gives the case again."""
    case = kinem.load(path)
    assert kinem.load_dict(case_dict(case), source=case.source) == case
    listed = parameters(case)
    uses = {u for paths in case.uses.values() for u in paths}   # set by its own path, a use detaches from its name
    assert apply(case, {p.path: p.value for p in listed if p.path not in uses}) == case
    drawn = [p for p in listed if p.path.startswith("points.")]
    assert drawn and all("drawn in the global frame" in p.what for p in drawn)


def test_a_drawn_point_is_its_drawn_coordinates():
    """points.B.at.0 of the drawn four-bar is B's x as drawn: setting it is
    the file edited (both bodies that carry B follow)."""
    path = ROOT / "tests" / "data" / "drawn" / "four_bar.toml"
    case = kinem.load(path)
    b = {p.path: p for p in parameters(case)}["points.B.at.0"]
    assert b.value == 0.35967127378953917 and b.unit == "m" and "coupler, rocker" in b.what
    data = tomllib.loads(path.read_text())
    data["points"]["B"]["at"][0] = 0.36
    edited = kinem.load_dict(data, source=case.source)
    assert apply(case, {"points.B.at.0": 0.36}) == edited
    assert kinem.load(path, parameters={"points.B.at.0": "0.36"}) == edited


def test_a_moved_drawing_fills_its_defaults_again():
    """Moving C turns the drawn slider's frame: the translational joint's
    phi0, filled in from the drawing, is filled in again as the file edited
    would be (not held at the old drawing's relative angle)."""
    path = ROOT / "tests" / "data" / "drawn" / "slider_crank.toml"
    case = kinem.load(path)
    data = tomllib.loads(path.read_text())
    data["points"]["C"]["at"][1] = 5.0
    moved = apply(case, {"points.C.at.1": 5.0})
    assert moved == kinem.load_dict(data, source=case.source)
    (joint,) = [c for c in moved.constraints if c.name == "T"]
    assert abs(joint["phi0"] - math.atan2(5.0, 100.0)) <= 1e-15 and "phi0" in joint.filled


def test_named_dimensions_are_parameters():
    """parameters.<name> is listed with its value and its uses; setting it
    is the file's [parameters] edited; a use set by its own path detaches."""
    case = kinem.load(NAMED)
    listed = {p.path: p for p in parameters(case)}
    coupler = listed["parameters.coupler"]
    assert coupler.value == 0.3 and coupler.unit == "m" and "constraints.B.si.0" in coupler.what
    assert case.uses["coupler"] == ("constraints.B.si.0",)
    assert kinem.load_dict(case_dict(case), source=case.source) == case
    assert apply(case, {"parameters.coupler": 0.31}) == kinem.load(NAMED, parameters={"coupler": 0.31})
    detached = apply(case, {"constraints.B.si.0": 0.31})
    assert detached.uses.get("coupler") is None and detached.parameters["coupler"] == 0.3
    assert resolve(case, ["parameters.crank"])[0].value == 0.1
    with pytest.raises(InputError, match="did you mean 'parameters.coupler'"):
        resolve(case, ["parameters.couplr"])
    with pytest.raises(InputError, match="did you mean 'constraints.B.si.0'"):
        kinem.load(NAMED, parameters={"constraint.B.si.0": 1})
    with pytest.raises(InputError, match="did you mean 'coupler'"):
        kinem.load(NAMED, parameters={"couplr": 1})


def central(path, name, column, h):
    """Central difference of ``column`` over kinem.load(..., parameters={name: v +- h})."""
    base = {p.path: p.value for p in parameters(kinem.load(path))}[name if "." in name else f"parameters.{name}"]
    plus, minus = (kinem.solve(kinem.compile(kinem.load(path, parameters={name: base + s * h}))).trajectory[column]
                   for s in (1, -1))
    return (plus - minus) / (2 * h)


@pytest.mark.parametrize("path, name, columns", [
    (NAMED, "coupler", ("B.x", "B.y", "rocker.phi", "coupler.omega")),
    (ROOT / "tests" / "data" / "drawn" / "four_bar.toml", "ground",
     ("A.x", "B.x", "B.vy", "B.ay", "rocker.x", "rocker.phi", "rocker.vy", "rocker.ax", "coupler.phi")),
    (ROOT / "tests" / "data" / "drawn" / "four_bar.toml", "points.B.at.0",
     ("B.x", "B.y", "A.vx", "coupler.phi", "coupler.omega", "rocker.phi", "rocker.alpha", "rocker.x")),
    (ROOT / "tests" / "data" / "drawn" / "slider_crank.toml", "points.B.at.1",
     ("A.x", "crank.x", "crank.y", "crank.phi", "crank.vx", "crank.ay", "rod.phi", "rod.ax")),
    (ROOT / "tests" / "data" / "drawn" / "slider_crank.toml", "points.C.at.1",
     ("A.x", "A.y", "B.vy", "slider.phi", "slider.x", "rod.phi", "rod.alpha")),
])
def test_sensitivity_to_a_named_dimension_is_the_total_derivative(path, name, columns):
    """d/d(parameters.NAME) is the sum over its uses (chain rule), and
    matches central differences of solves with the value set (h = 1e-5 of
    the value: truncation ~h^2, rounding ~1e-12/h: 1e-6 of the peak). On
    a drawn case the bodies' columns too: a frame derived from a moved
    point moves with it (kinem.parameters.frame_tangent)."""
    model = kinem.compile(kinem.load(path))
    p = name if "." in name else f"parameters.{name}"
    s = kinem.sensitivity(model, [p])
    case = model.case
    uses = [u for u in case.uses.get(name, ()) if u in {q.path for q in parameters(case)}]
    if uses and not path.parent.name == "drawn":   # body-frame uses: the per-use derivatives add up
        per = kinem.sensitivity(model, uses)
        for c in columns:
            total = sum(per.of(c, u) for u in uses)
            np.testing.assert_allclose(s.of(c, p), total, rtol=0, atol=1e-12 * np.abs(total).max())
    value = {q.path: q.value for q in parameters(case)}[p]
    for c in columns:
        fd = central(path, name, c, 1e-5 * abs(value) or 1e-3)   # a zero coordinate: 1e-3 of a 100-mm drawing
        exact = s.of(c, p)
        assert np.abs(exact - fd).max() <= 1e-6 * np.abs(exact).max() + 1e-12, (c, np.abs(exact - fd).max())


def test_tolerances_name_a_named_dimension():
    case = kinem.load(NAMED)
    from kinem.tolerance import tolerance

    bands = tolerance(kinem.compile(case), {"parameters.coupler": 1e-4, "constraints.A.sj.0": 1e-4},
                            samples=16, outputs=["B.y"])
    assert np.all(bands["B.y.worst+"] >= bands["B.y"]) and bands.samples == 16
    data = tomllib.loads(NAMED.read_text())
    data["tolerances"] = {"parameters.coupler": 1e-4}        # [tolerances] by a named dimension's path
    from_file = tolerance(kinem.compile(kinem.load_dict(data)), samples=16, outputs=["B.y"])
    alone = tolerance(kinem.compile(case), {"parameters.coupler": 1e-4}, samples=16, outputs=["B.y"])
    np.testing.assert_array_equal(from_file["B.y.worst+"], alone["B.y.worst+"])
    data["tolerances"] = {"parameters.couplr": 1e-4}
    with pytest.raises(InputError, match="did you mean 'parameters.coupler'"):
        kinem.load_dict(data)


def test_set_and_sweep_take_paths(tmp_path, capsys):
    """--set and sweeps take a design parameter path as well as a name (one
    place: kinem.parameters.apply); an unknown one gets a did-you-mean."""
    out = tmp_path / "a.csv"
    assert cli.main(["solve", str(NAMED), "--set", "constraints.B.si.0=0.31", "--out", str(out)]) == 0
    by_path = np.genfromtxt(out, delimiter=",", names=True)
    assert cli.main(["solve", str(NAMED), "--set", "coupler=0.31", "--out", str(out)]) == 0
    by_name = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_array_equal(by_path["Bx"], by_name["Bx"])
    assert cli.main(["solve", str(NAMED), "--set", "constraint.B.si.0=0.31"]) == 2
    assert "did you mean 'constraints.B.si.0'" in capsys.readouterr().err
    s = kinem.sweep(NAMED, {"constraints.B.si.0": [0.3, 0.31]}, outputs=("B.y",))
    np.testing.assert_allclose(s.data[1, :, 0], by_name["By"], rtol=0, atol=1e-12)
    assert s.names == ("constraints.B.si.0",) and s.success


def test_sensitivity_in_degrees():
    """A case in degrees: d/d(an angle parameter) is per degree, matching
    central differences of solves with the value set (1e-6 of the peak)."""
    text = degrees_slider_crank()
    case = kinem.loads(text)
    p = "constraints.crank-drive.d.poly.0"
    s = kinem.sensitivity(kinem.compile(case), [p])
    value = {q.path: q.value for q in parameters(case)}[p]
    h = 1e-4
    plus, minus = (kinem.solve(kinem.compile(apply(case, {p: value + k * h}))).trajectory["B.x"] for k in (1, -1))
    fd = (plus - minus) / (2 * h)
    assert np.abs(s.of("B.x", p) - fd).max() <= 1e-6 * np.abs(fd).max()
    rad = kinem.sensitivity(kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml")), [p])
    np.testing.assert_allclose(s.of("B.x", p), rad.of("B.x", p) * math.pi / 180, rtol=0,
                               atol=1e-9 * np.abs(fd).max())


def test_the_parameters_of_a_model_are_its_cases_and_other_values_are_refused():
    """kinem.parameters takes a compiled model as well as its case (it
    raised AttributeError); anything else is one InputError naming it."""
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    assert kinem.parameters(kinem.compile(case)) == kinem.parameters(case)
    for bad in (3, None, "cases/four_bar.toml"):
        with pytest.raises(kinem.InputError, match="parameters: .*expected a case"):
            kinem.parameters(bad)
