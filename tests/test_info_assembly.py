"""Issue 24 item 7: ``kinem info`` reports the assembly ``kinem solve``
performs (the same function), and the configuration the estimates chose."""
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem.info import configuration, info

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.mechanisms24 import MECHANISMS  # noqa: E402


@pytest.mark.parametrize("name", sorted(MECHANISMS) + ["four_bar", "quick_return_2", "planetary"])
def test_info_assembles_as_solve_does(name):
    case = (kinem.load_dict(MECHANISMS[name]()) if name in MECHANISMS
            else kinem.load(ROOT / "cases" / f"{name}.toml"))
    model = kinem.compile(case)
    i = info(model)
    r = kinem.solve(model)
    assert i.assembled == r.success and i.assembled
    assert i.residual == pytest.approx(float(r.residual[0]), abs=1e-300)
    assert i.configuration == configuration(model, r.q[0])


def test_info_shows_the_branch_the_estimates_chose():
    """The four-bar's rocker estimated on the other side of the line from
    the crank pin to the rocker pivot: solve and info both assemble the
    other branch, and the sign of the coupler-rocker angle says which."""
    import tomllib

    data = tomllib.loads((ROOT / "cases" / "four_bar.toml").read_text())
    up = info(kinem.compile(kinem.load_dict(data)))
    data["bodies"]["coupler"]["q"] = [0.16, -0.04, -0.5]
    data["bodies"]["rocker"]["q"] = [0.26, -0.09, -1.9]
    model = kinem.compile(kinem.load_dict(data))
    down = info(model)
    assert up.assembled and down.assembled
    b_up, b_down = dict(up.configuration)["B"], dict(down.configuration)["B"]
    assert np.sign(b_up) == -np.sign(b_down), (b_up, b_down)
    assert down.configuration == configuration(model, kinem.solve(model).q[0])
