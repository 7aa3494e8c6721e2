"""A parameter's reach (kinem/core/src/sensitivity.rs, `Reach`, `moving`):
alone, a parameter's (S1)-(S3) are solved only at the places of the
block-triangular solve its Phi_p can reach, the families and named points
it cannot move are skipped, and a parameter that moves the whole mechanism
rigidly (a ground's x or y) has its constant row written once. Among all
the case's parameters (more than eight: several groups of eight, whose
reach is not taken) every place is solved and every family and point
taken: the full pass. Every parameter of every case in cases/, alone
against among all of them: within 1e-13 of each array's peak (the
rounding of the two solve paths); and the rigid shifts' rows are the
exact translation."""
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem.parameters import parameters
from kinem.sensitivity import sensitivity

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted(p.stem for p in (ROOT / "cases").glob("*.toml"))


def block(s, k):
    """Parameter k's columns of a Sensitivity."""
    data = np.asarray(s.derivatives.data)
    width = data.shape[1] // len(s.parameters)
    return data[:, k * width:(k + 1) * width]


@pytest.mark.parametrize("name", CASES)
def test_every_parameter_alone_is_the_full_pass(name):
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    every = [p.path for p in parameters(model.case)]
    assert len(every) > 8, "among all, the full pass: more than one group of eight"
    together = sensitivity(model, every)
    for k, path in enumerate(every):
        alone, full = block(sensitivity(model, path), 0), block(together, k)
        finite = np.isfinite(full)
        assert np.array_equal(finite, np.isfinite(alone)), path
        peak = np.abs(full[finite]).max(initial=0.0)
        assert np.abs(alone[finite] - full[finite]).max(initial=0.0) <= 1e-13 * peak, path


@pytest.mark.parametrize("name", ["slider_crank", "cam_table41"])
@pytest.mark.parametrize("axis", [0, 1])
def test_a_grounds_shift_moves_every_body_and_point_by_one(name, axis):
    """d/d(the ground's x or y) of every body's and named point's x (or y)
    is 1, of every other column (across, angles, velocities,
    accelerations) 0: the written row, exactly; the full pass (the
    parameter among all) within 1e-13."""
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    path = f"constraints.#1.value.{axis}"
    every = [p.path for p in parameters(model.case)]
    s = sensitivity(model, path)
    columns = [c for c in s.trajectory.columns if c != "t"]
    alone = block(s, 0)
    assert alone.shape[1] == len(columns)
    along = ".x" if axis == 0 else ".y"
    for j, c in enumerate(columns):
        assert np.all(alone[:, j] == (1.0 if c.endswith(along) else 0.0)), (c, alone[:3, j])
    full = block(sensitivity(model, every), every.index(path))
    assert np.abs(full - alone).max() <= 1e-13, path
