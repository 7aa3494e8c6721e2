"""Issue 17, diagnoses users can act on: a surplus or missing driver named
with the count of degrees of freedom, a loop that cannot close named with its
gap, and `kinem info` exiting 1 when the case does not assemble."""
import contextlib
import io
import math
import tomllib
from pathlib import Path

import pytest

import kinem
from kinem.cli import main

SLIDER = (Path(__file__).resolve().parents[1] / "cases" / "slider_crank.toml").read_text()
# crank OB = 200 at 330 degrees puts B 100 above the slider's line; a rod of 70 cannot reach it
SHORT_ROD = SLIDER.replace('si = [300.0, 0.0]', 'si = [50.0, 0.0]').replace('sj = [-200.0, 0.0]', 'sj = [-20.0, 0.0]')


def cli(*args):
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, err.getvalue()


def with_extra_driver():
    d = tomllib.loads(SLIDER)
    d["constraints"].append({"type": "driver", "name": "extra", "body": "rod", "coord": "phi", "d": 0.2})
    return d


def test_surplus_driver_is_named_with_the_degrees_of_freedom():
    with pytest.raises(kinem.InputError) as e:   # bad input, as a missing driver is (issue 32)
        kinem.solve(kinem.compile(kinem.load_dict(with_extra_driver())))
    assert ("too many driving equations: 2 (crank-drive, extra) for 1 degree of freedom "
            "(12 coordinates, 11 independent kinematic equations; Gruebler count 12 - 11 = 1): "
            "remove 1 driving equation") in str(e.value), str(e.value)


def test_too_few_and_too_many_drivers_exit_alike(tmp_path):
    driver = SLIDER[SLIDER.index('[[constraints]]\ntype = "driver"'):SLIDER.index("[report]")]
    extra = '[[constraints]]\ntype = "driver"\nname = "extra"\nbody = "rod"\ncoord = "phi"\nd = 0.2\n\n'
    for name, text, words in (("few", SLIDER.replace(driver, ""), "add 1 driver"),
                              ("many", SLIDER.replace(driver, driver + extra), "remove 1 driving")):
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        code, err = cli("solve", path, "--out", tmp_path / "o.csv")
        assert code == 2 and len(err.splitlines()) == 1 and words in err and "Gruebler count 12 - 11 = 1" in err, err


def test_missing_driver_is_named_with_the_degrees_of_freedom():
    d = tomllib.loads(SLIDER)
    d["constraints"] = [c for c in d["constraints"] if c["type"] != "driver"]
    with pytest.raises(kinem.InputError) as e:
        kinem.solve(kinem.compile(kinem.load_dict(d)))
    assert "too few driving equations: 0 for 1 degree of freedom" in str(e.value), str(e.value)


def test_loop_that_cannot_close_is_named_with_its_gap():
    r = kinem.solve(kinem.compile(kinem.loads(SHORT_ROD)))
    assert not r.success and "the loop of constraints B, O, T, A cannot close" in r.message, r.message
    gap = float(r.message.split("its ends are ")[1].split(" mm apart")[0])
    height = -200.0 * math.sin(5.76)   # B's height above the slider's line (the crank at 5.76 rad)
    assert abs(gap - (height - 70.0)) < 0.006, (gap, height - 70.0)  # printed to 4 digits: 29.93, half a unit 0.005


def test_solve_command_names_the_loop_on_one_line(tmp_path):
    path = tmp_path / "short.toml"
    path.write_text(SHORT_ROD)
    code, err = cli("solve", path, "--out", tmp_path / "o.csv")
    assert code == 1 and len(err.splitlines()) == 1 and "cannot close" in err


def test_info_exits_1_when_the_case_does_not_assemble(tmp_path):
    path = tmp_path / "short.toml"
    path.write_text(SHORT_ROD)
    code, err = cli("info", path)
    assert code == 1 and len(err.splitlines()) == 1, err
    assert "does not assemble" in err and "cannot close" in err
    code, err = cli("info", path, "--json")
    assert code == 1


def test_info_of_a_good_case_still_exits_0():
    code, err = cli("info", Path(__file__).resolve().parents[1] / "cases" / "four_bar.toml")
    assert code == 0, err


def test_one_misspelt_body_is_one_problem():
    """A body misspelt where it is defined: every reference to its right name is the same problem (issue 32)."""
    text = SLIDER.replace("crank  = { q", "crnak  = { q")
    with pytest.raises(kinem.InputError) as e:
        kinem.loads(text)
    assert len(e.value.problems) == 1, e.value.problems
    assert "unknown body 'crank'; did you mean 'crnak'? (the same name in 4 places)" in e.value.problems[0]


@pytest.mark.parametrize("estimate", [-1.3, 5.0])
def test_a_far_contact_estimate_is_named_with_the_value_it_needs(estimate, tmp_path):
    root = Path(__file__).resolve().parents[1]
    text = (root / "cases" / "cam_roller_circle.toml").read_text()
    assert "theta = 1.84" in text
    r = kinem.solve(kinem.compile(kinem.loads(text.replace("theta = 1.84", f"theta = {estimate}"))))
    assert not r.success
    assert f"the estimate theta = {estimate:g} of 'contact' is" in r.message, r.message
    need = float(r.message.split("try theta = ")[1].split(";")[0])
    assert abs(need - 1.84) < 0.05   # the contact angle the bodies' estimates give, near the file's own
    fixed = kinem.solve(kinem.compile(kinem.loads(text.replace("theta = 1.84", f"theta = {need}"))))
    assert fixed.success, fixed.message
