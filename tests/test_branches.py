"""The branch an assembly reaches (issue 24 item 7): `kinem info` shows a cam
roller's side of the outline and each joint's relative angle, from the
assembly `kinem solve` performs; a case's `side` / `sign` keys pin them, and
the other branch fails both commands in one line (exit 1)."""
import json
from pathlib import Path

import pytest

import kinem
from kinem.cli import main
from kinem.result import Status

ROOT = Path(__file__).resolve().parents[1]
CAM = ROOT / "cases" / "cam_roller_circle.toml"     # circle radius 30 about (10, 0), roller radius 8
FOUR_BAR = ROOT / "cases" / "four_bar.toml"


def _cam(tmp_path, inside=False, pin=None, name="cam.toml"):
    """cam_roller_circle.toml, with the estimates of the inside branch (the
    follower 16 mm lower, theta 2.04) and a side pin when asked."""
    text = CAM.read_text()
    if inside:
        text = text.replace("follower = { q = [0.0, 50.0, 0.0] }", "follower = { q = [0.0, 34.0, 0.0] }")
        text = text.replace("theta = 1.84 ", "theta = 2.04 ")
    if pin:
        text = text.replace("radius = 8.0\n", f'radius = 8.0\nside = "{pin}"\n')
    p = tmp_path / name
    p.write_text(text)
    return p


def _four_bar(tmp_path, sign):
    text = FOUR_BAR.read_text().replace('name = "A"\n', f'name = "A"\nsign = "{sign}"\n')
    assert f'sign = "{sign}"' in text
    p = tmp_path / "fb.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("inside, side, distance", [(False, "outside", 38.0), (True, "inside", 22.0)])
def test_info_reports_the_cam_roller_side(tmp_path, capsys, inside, side, distance):
    """The roller touches the circle with its centre on the normal: R + rho =
    38 from the circle's centre outside, R - rho = 22 inside (to the
    assembly's tolerance, 1e-10 of the size)."""
    path = _cam(tmp_path, inside)
    assert main(["info", str(path), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)["sides"]["contact"]
    assert s["side"] == side and s["radius"] == pytest.approx(30.0, abs=1e-9)
    assert s["distance"] == pytest.approx(distance, abs=1e-8)
    assert main(["info", str(path)]) == 0
    assert f"cam roller         contact: {side} the outline" in capsys.readouterr().out


def test_info_assembles_as_solve_does(tmp_path):
    """info's side is the side of solve's first instant."""
    from kinem.branches import cam_side
    from kinem.info import info

    model = kinem.compile(kinem.load(_cam(tmp_path, inside=True)))
    r = kinem.solve(model, ("positions",))
    (side,) = info(model).sides
    assert side == cam_side(model, r.q[0], model.case.constraints[3]) and side.side == "inside"


@pytest.mark.parametrize("inside, pin", [(False, "outside"), (True, "inside")])
def test_a_side_pin_on_the_branch_reached_passes(tmp_path, capsys, inside, pin):
    path = _cam(tmp_path, inside, pin)
    assert main(["info", str(path)]) == 0
    r = kinem.solve(kinem.compile(kinem.load(path)))
    assert r.success and r.status is Status.SUCCESS


@pytest.mark.parametrize("command", ["solve", "info"])
@pytest.mark.parametrize("inside, pin, found", [(False, "inside", "outside"), (True, "outside", "inside")])
def test_a_side_pin_on_the_other_branch_fails_in_one_line(tmp_path, capsys, command, inside, pin, found):
    path = _cam(tmp_path, inside, pin)
    out = tmp_path / "out.csv"
    assert main([command, str(path)] + (["--out", str(out)] if command == "solve" else [])) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert str(path) in err and "('contact', cam-roller)" in err and "key 'side'" in err
    assert f"the roller {found} the outline" in err and f"expected {pin}" in err
    assert not out.exists()


def test_a_wrong_branch_is_a_failed_result_with_no_instants(tmp_path):
    r = kinem.solve(kinem.compile(kinem.load(_cam(tmp_path, pin="inside"))))
    assert not r.success and r.status is Status.WRONG_BRANCH and r.failed_constraint == "contact"
    assert len(r.trajectory) == 0 and r.t_fail == 0.0


def test_a_sign_pin_holds_the_loop_orientation(tmp_path, capsys):
    """four_bar.toml assembles with joint A at -0.513 rad (info's
    configuration): "negative" passes, "positive" fails naming A and 'sign'."""
    assert main(["info", str(_four_bar(tmp_path, "negative"))]) == 0
    assert "A -0.513 rad" in capsys.readouterr().out
    path = _four_bar(tmp_path, "positive")
    assert main(["solve", str(path), "--out", str(tmp_path / "o.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err
    assert "('A', revolute)" in err and "key 'sign'" in err and "-0.513" in err and "expected positive" in err


def test_a_pin_is_checked_when_loaded(tmp_path, capsys):
    path = _cam(tmp_path, pin="middle")
    assert main(["info", str(path)]) == 2
    assert "key 'side': got 'middle'; expected \"outside\" or \"inside\"" in capsys.readouterr().err
