"""Joints where they are drawn (kinem.casefile.drawn): the book's slider-crank,
four-bar and quick-return written with global points and named parameters
solve as today's files; kinem info shows the derived local coordinates."""
import json
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import cli
from kinem.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
DRAWN = ROOT / "tests" / "data" / "drawn"
PAIRS = {"slider_crank": ("B", "A"), "four_bar": ("A", "B"), "quick_return_1": ("A", "B", "D")}


@pytest.mark.parametrize("name", PAIRS)
def test_drawn_solves_as_the_book_file(name):
    book, drawn = (kinem.solve(kinem.compile(kinem.load(p))) for p in (ROOT / "cases" / f"{name}.toml",
                                                                       DRAWN / f"{name}.toml"))
    assert book.success and drawn.success, drawn.message
    for stage in (("x", "y"), ("vx", "vy"), ("ax", "ay")):
        cols = [f"{p}.{q}" for p in PAIRS[name] for q in stage]
        size = max(np.abs(book.trajectory[c]).max() for c in cols)   # the size of this stage's figures
        for c in cols:
            # same answers to 1e-14 of the size: lengths recovered from 17-digit drawn coordinates
            assert np.abs(book.trajectory[c] - drawn.trajectory[c]).max() <= 1e-14 * size, c


def test_info_shows_the_derived_local_coordinates(capsys):
    assert cli.main(["info", str(DRAWN / "slider_crank.toml")]) == 0
    out = capsys.readouterr().out
    assert "crank: frame x -173.2464128, y 99.92837662, phi -0.5231853072; local B [0, 0], O [200, 0]" in out
    assert "rod: frame" in out and "A [500, 0]" in out
    assert cli.main(["info", str(DRAWN / "four_bar.toml"), "--json"]) == 0
    drawn = json.loads(capsys.readouterr().out)["drawn"]
    assert drawn["rocker"]["points"]["B"] == [0.22, 0.0] and drawn["coupler"]["points"]["B"][0] == pytest.approx(0.3, 1e-15)


def test_a_drawn_point_moves_with_its_parameter():
    a = kinem.load(DRAWN / "four_bar.toml")
    b = kinem.load(DRAWN / "four_bar.toml", parameters={"ground": 0.21})
    assert dict(a.bodies[0].carries)["O4"] == (0.2, 0.0) and dict(b.bodies[0].carries)["O4"] == (0.21, 0.0)
    rocker = {x.name: x for x in b.bodies}["rocker"]
    assert rocker.q[:2] == (0.21, 0.0)   # the rocker's frame is at O4, as drawn


def drawn(points, bodies):
    return {"name": "d", "time": {"end": 1.0, "steps": 1}, "points": points, "bodies": bodies,
            "constraints": [{"type": "ground", "body": "g"}]}


def problems(points, bodies):
    with pytest.raises(InputError) as e:
        kinem.load_dict(drawn(points, bodies))
    return e.value.problems


def test_mistakes_one_problem_each():
    g = {"q": [0.0, 0.0, 0.0]}
    P = {"at": [1.0, 2.0], "frame": "global"}
    (p,) = problems({"pin": P}, {"g": g, "b": {"points": ["pn"]}})   # one misspelt name: one problem
    assert "body 'b': key 'points': unknown point drawn in the global frame 'pn'; did you mean 'pin'?" in p
    (p,) = problems({"P": P}, {"g": g})
    assert "point 'P'" in p and "carried by no body" in p
    (p,) = problems({"P": {"body": "g", "at": [1.0, 2.0]}}, {"g": g, "b": {"points": ["P"]}})
    assert "given in body 'g''s frame" in p
    (p,) = problems({"P": {"at": [1.0, 2.0], "frame": "sky"}}, {"g": g})
    assert "key 'frame'" in p and '"global"' in p
    (p,) = problems({}, {"g": g, "b": {"mass": 1.0}})
    assert "body 'b'" in p and "'q'" in p


def test_frames_from_points():
    case = kinem.load_dict(drawn({"P": {"at": [1.0, 1.0], "frame": "global"},
                                  "Q": {"at": [1.0, 3.0], "frame": "global"},
                                  "R": {"at": [0.0, 1.0], "frame": "global", "body": "b"}},
                                 {"g": {"q": [0.0, 0.0, 0.0], "points": ["R"]}, "b": {"points": ["P", "Q"]}}))
    b = {x.name: x for x in case.bodies}["b"]
    assert b.q == (1.0, 1.0, np.pi / 2) and dict(b.carries) == {"P": (0.0, 0.0), "Q": (2.0, 0.0),
                                                                 "R": pytest.approx((0.0, 1.0), abs=1e-15)}
    points = {p.name: p for p in case.points}
    assert points["R"].body == "b" and points["P"].body == "b"   # its body key; else the first that lists it
    assert [p.name for p in case.points] == ["P", "Q", "R"]
