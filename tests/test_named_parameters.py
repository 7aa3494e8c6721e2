"""[parameters]: named dimensions used where a number is expected, set by
load(parameters=...) and --set NAME=VALUE; nothing evaluated."""
import tomllib
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import cli
from kinem.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "tests" / "data" / "four_bar_named.toml"


def points(case, columns=("A.x", "A.y", "B.x", "B.y", "B.vx", "B.ay", "rocker.phi", "coupler.omega")):
    r = kinem.solve(kinem.compile(case))
    assert r.success, r.message
    return np.column_stack([r.trajectory[c] for c in columns])


def test_named_four_bar_solves_as_the_book_file():
    named, plain = kinem.load(FOUR_BAR), kinem.load(ROOT / "cases" / "four_bar.toml")
    assert dict(named.parameters) == {"crank": 0.1, "coupler": 0.3, "rocker": 0.22, "ground": 0.2}
    # the same mechanism in other body frames: points and angles agree to 1e-14 of the size (0.3 m)
    np.testing.assert_allclose(points(named), points(plain), rtol=0, atol=1e-14 * 0.3 * 10)


def test_a_parameter_set_at_load_is_the_file_edited():
    data = tomllib.loads(FOUR_BAR.read_text())
    data["parameters"]["coupler"] = 0.31
    edited = kinem.load_dict(data)
    for given in ({"coupler": 0.31}, {"parameters.coupler": "0.31"}):
        case = kinem.load(FOUR_BAR, parameters=given)
        assert case.parameters["coupler"] == 0.31
        assert np.array_equal(points(case), points(edited))


def test_names_and_values_checked():
    with pytest.raises(InputError, match="unknown parameter 'couplr'; did you mean 'coupler'"):
        kinem.load(FOUR_BAR, parameters={"couplr": 1})
    with pytest.raises(InputError, match="expected a number"):
        kinem.load(FOUR_BAR, parameters={"coupler": "long"})
    data = tomllib.loads(FOUR_BAR.read_text())
    assert kinem.load_dict(data, parameters={"crank": 0.11}).parameters["crank"] == 0.11
    assert data["parameters"]["crank"] == 0.1   # the caller's dict is not changed
    data["constraints"][3]["si"] = ["coupel", 0.0]   # a misspelt name where a number is expected
    with pytest.raises(InputError, match="unknown parameter 'coupel'; did you mean 'coupler'") as e:
        kinem.load_dict(data)
    assert len(e.value.problems) == 1
    data = tomllib.loads(FOUR_BAR.read_text())
    data["parameters"]["rocker"] = "crank"           # no parameter is another's name: nothing is evaluated
    data["parameters"]["bad"] = "2 * crank"
    with pytest.raises(InputError) as e:
        kinem.load_dict(data)
    assert len(e.value.problems) == 2 and all("a parameter's value is not another's name" in p
                                               for p in e.value.problems)


def test_parameters_in_functions_and_vectors():
    case = kinem.loads("""
        name = "p"
        [parameters]
        w = 2.0
        x0 = 1.5
        [time]
        end = 1.0
        steps = 2
        [bodies]
        b = { q = ["x0", 0.0, 0.0] }
        [[constraints]]
        type = "driver"
        body = "b"
        coord = "x"
        d = { poly = ["x0", "w"] }
        [[constraints]]
        type = "driver"
        body = "b"
        coord = "y"
        d = "w"
        [[constraints]]
        type = "driver"
        body = "b"
        coord = "phi"
        d = { harmonic = { amplitude = "w", omega = 1.0 } }
    """)
    r = kinem.solve(kinem.compile(case))
    assert r.success
    np.testing.assert_allclose(r.trajectory["b.x"], 1.5 + 2.0 * r.trajectory.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.trajectory["b.y"], 2.0, rtol=0, atol=1e-12)


def test_cli_set(tmp_path, capsys):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert cli.main(["solve", str(FOUR_BAR), "--out", str(a)]) == 0
    assert cli.main(["solve", str(FOUR_BAR), "--set", "coupler=0.31", "--out", str(b)]) == 0
    ta, tb = (np.loadtxt(p, delimiter=",", skiprows=1) for p in (a, b))
    assert ta.shape == tb.shape and np.abs(ta - tb).max() > 1e-3
    assert cli.main(["solve", str(FOUR_BAR), "--set", "couplr=0.31"]) == 2
    assert "did you mean 'coupler'" in capsys.readouterr().err
    assert cli.main(["solve", str(FOUR_BAR), "--set", "coupler"]) == 2
    assert "NAME=VALUE" in capsys.readouterr().err
    capsys.readouterr()
    assert cli.main(["info", str(FOUR_BAR), "--set", "coupler=0.31"]) == 0
    assert "parameters         crank = 0.1, coupler = 0.31, rocker = 0.22, ground = 0.2" in capsys.readouterr().out
