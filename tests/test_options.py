"""Solver options are passed to ``solve`` (kinem.Options), not compiled into
the Model: another tolerance, block size or linear solver never recompiles."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import kinem
import kinem.model
from closed_form import slider_crank

CASES = Path(__file__).resolve().parents[1] / "cases"


@pytest.fixture(scope="module")
def model():
    return kinem.compile(kinem.load(CASES / "slider_crank.toml"))


def test_defaults_come_from_the_case_solver_section(model):
    o = kinem.Options.of(model.case)
    assert (o.tolerance, o.max_iterations, o.linear_solver, o.jacobian_reuse, o.block) == (1e-12, 25, "auto", False, 256)
    a, b = kinem.solve(model), kinem.solve(model, options=o)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.iterations, b.iterations)


def test_changing_options_never_recompiles(model, monkeypatch):
    def no_compile(*a, **k):
        raise AssertionError("recompiled")
    monkeypatch.setattr(kinem, "compile", no_compile)
    monkeypatch.setattr(kinem.model, "compile", no_compile)
    t = model.times
    ref = slider_crank(5.76 - 1.2 * t + np.pi, -1.2 + 0 * t, 0 * t, 200.0, 500.0)["x"]
    runs = {tol: kinem.solve(model, options=kinem.Options(tolerance=tol)) for tol in (1e-4, 1e-12)}
    assert all(r.success for r in runs.values())
    # a looser tolerance stops earlier: fewer iterations, and a larger residual bound
    assert runs[1e-4].iterations.sum() < runs[1e-12].iterations.sum()
    assert runs[1e-4].residual.max() > 1e-12 >= runs[1e-12].residual.max()
    # 1e-9 of the size (665 mm) at the default: positions are right to the tolerance over the conditioning
    assert np.abs(runs[1e-12].trajectory["slider.x"] - ref).max() < 1e-9 * 665
    # step by step, sparse LU and modified Newton from the same Model agree with the default
    for o in (kinem.Options(block=1), kinem.Options(linear_solver="sparse"), kinem.Options(jacobian_reuse=True)):
        r = kinem.solve(model, options=o)
        assert r.success and np.abs(r.trajectory["slider.x"] - ref).max() < 1e-9 * 665


@pytest.mark.parametrize("bad", [dict(tolerance=0.0), dict(tolerance=2.0), dict(max_iterations=0),
                                 dict(linear_solver="cholesky"), dict(block=0), dict(block=2.5)])
def test_bad_options_are_input_errors(bad):
    with pytest.raises(kinem.InputError, match="solver options: " + next(iter(bad))):
        kinem.Options(**bad)


def test_options_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        kinem.Options().tolerance = 1e-3
