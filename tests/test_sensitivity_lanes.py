"""The core's sensitivities (kinem/core/src/sensitivity.rs) take up to
eight parameters per evaluation, in the narrowest lanes that hold them
(1, 2, 4 or 8), and with many parameters solve through Phi_q's inverse:
a parameter's derivatives must not depend on which others are asked with
it. Each parameter alone (one lane, three solves with the factors)
against the same parameter among all the case's (eight lanes, the
inverse where it pays), and among its first three (four lanes, one empty):
within 1e-13 of each array's peak (rounding of the two solve paths)."""
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem.parameters import parameters
from kinem.sensitivity import sensitivity

ROOT = Path(__file__).resolve().parents[1]


def block(s, k):
    """Parameter k's columns of a Sensitivity."""
    data = np.asarray(s.derivatives.data)
    width = data.shape[1] // len(s.parameters)
    return data[:, k * width:(k + 1) * width]


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1", "cam_table41"])
def test_a_parameters_derivatives_do_not_depend_on_its_company(name):
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    every = [p.path for p in parameters(model.case)]
    assert len(every) > 8   # the wide lanes and more than one group are exercised
    together, three = sensitivity(model, every), sensitivity(model, every[:3])
    for k in (0, 1, 2, len(every) - 1):
        alone = block(sensitivity(model, every[k]), 0)
        peak = np.abs(alone).max()
        assert peak > 0, every[k]
        for other, j in ((together, k), (three, k)) if k < 3 else ((together, k),):
            assert np.abs(block(other, j) - alone).max() <= 1e-13 * peak, (every[k], len(other.parameters))
