"""The stress suite's situations, each with its stated behaviour (the
singular-configuration, branch and redundancy cases are in test_stability)."""
import math
import subprocess
import sys

import numpy as np
import pytest

import kinem
from kinem import stress
from kinem.reference import four_bar, four_bar_case, n_four_bar, slider_crank, slider_crank_case


def test_length_scale_gives_the_same_normalised_result():
    """The same slider-crank in lengths x 1e-3, 1 and 1e3: positions / L agree
    to 1e-9 (the Newton tolerance is relative to L), angles and rates alike."""
    runs = []
    for s in (1e-3, 1.0, 1e3):
        model = kinem.compile(kinem.load_dict(slider_crank_case(0.1 * s, 0.3 * s, 0.02 * s, end=1.0, steps=50)))
        r = kinem.solve(model)
        assert r.success
        runs.append((s, r.trajectory))
    ref = runs[1][1]
    for s, tr in runs:
        assert np.abs(tr["slider.x"] / s - ref["slider.x"]).max() <= 1e-9 * 0.4
        assert np.abs(tr["rod.phi"] - ref["rod.phi"]).max() <= 1e-9
        assert np.abs(tr["slider.ax"] / s - ref["slider.ax"]).max() <= 1e-9 * np.abs(ref["slider.ax"]).max()


@pytest.mark.parametrize("margin", [1e-2, 1e-4, 1e-6, 1e-8])
def test_near_change_point_four_bar_stays_on_branch(margin):
    """s + l - (p + q) = -margin: the four-bar nearly folds once per turn but
    must stay on its assembly branch, as accurate as anywhere."""
    g = 2.0 + margin
    case = kinem.load_dict(four_bar_case(1.0, 3.0, 2.0, g, {"poly": [0.5, 2.0]}, 0.5, end=math.pi, steps=200))
    r = kinem.solve(kinem.compile(case), ("positions",))
    assert r.success, r.message
    t = r.trajectory.t
    th4 = four_bar(0.5 + 2 * t, 2 + 0 * t, 0 * t, 1.0, 3.0, 2.0, g)["th4"]
    d = np.abs((r.trajectory["rocker.phi"] - th4 + np.pi) % (2 * np.pi) - np.pi)
    # on the branch: the other branch is at least ~sqrt(margin) >= 1e-4 rad away at the fold
    assert d.max() < 1e-6
    # and as accurate as the conditioning allows: the residual tolerance over the smallest
    # conditioning figure of the run bounds the coordinate error (x 10 for the geometry)
    assert d.max() <= 10 * kinem.Options.of(case).tolerance / r.conditioning.min()


@pytest.mark.parametrize("n", [1, 2, 5, 40])
def test_n_four_bar_passes_the_horizontal_position(n):
    """IFToMM N-four-bar: every bar parallel at the horizontal position, rank
    short by N; the chain stays a chain of parallelograms."""
    r = kinem.solve(kinem.compile(kinem.load_dict(n_four_bar(n))))
    assert r.success, r.message
    tr = r.trajectory
    th = math.pi / 2 + 0.5 - tr.t
    assert max(np.abs(tr[f"crank{k}.phi"] - th).max() for k in range(n + 1)) < 1e-8
    assert max(np.abs(tr[f"coupler{k}.phi"]).max() for k in range(n)) < 1e-8
    assert max(np.abs(tr[f"crank{k}.omega"] + 1.0).max() for k in range(n + 1)) < 1e-7


def test_long_run_does_not_drift():
    """2,000 crank turns at 8 instants per turn (kinem stress runs 10,000):
    the error at the end is that of the start, 1e-9 of the size."""
    w = 20 * math.pi
    turns = 2000
    case = kinem.load_dict(slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, w]}, 0.5, end=turns / 10, steps=turns * 8))
    r = kinem.solve(kinem.compile(case), ("positions",))
    assert r.success
    t = r.trajectory.t
    err = np.abs(r.trajectory["slider.x"] - slider_crank(0.5 + w * t, w + 0 * t, 0 * t, 0.1, 0.3)["x"])
    assert err[-100:].max() <= 1e-9 * 0.4 and err.max() <= 1e-9 * 0.4


@pytest.mark.parametrize("engine", ["pymunk", "mujoco", "exudyn"])
def test_mass_ratio_runs_are_classified(engine):
    scenario = next(s for s in stress.scenarios(quick=True) if s.group == "mass-ratio")
    out = stress.run_one((scenario, engine))
    assert out["outcome"] in ("accurate", "inaccurate", "branch-flip", "diverged", "nan")


def test_classify():
    assert stress.classify(1e-12, 1e-12, 1e-8) == "accurate"
    assert stress.classify(1e-5, 1e-9, 1e-8) == "inaccurate"
    assert stress.classify(0.5, 1e-9, 1e-8) == "branch-flip"
    assert stress.classify(0.5, 1e-3, 1e-8) == "inaccurate"
    assert stress.classify(0.0, 0.0, 1e-8, finite=False) == "nan"


def test_native_meets_every_expectation_quick():
    p = subprocess.run([sys.executable, "-m", "kinem", "stress", "--quick", "--engines", "native", "--jobs", "0"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "singular-detected" in p.stdout and "N-four-bar, N = 20" in p.stdout
