"""The front door for notebooks (issue 25): increasing instants checked,
Trajectory.to_pandas and __array__, kinem.plot and kinem.animate, a short
repr of a case."""
import sys

import numpy as np
import pytest

import kinem
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def solved():
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml").with_time(1.0, 20))
    return model, kinem.solve(model)


@pytest.mark.parametrize("times", [[0, 0.5, 0.2], [0, 0.5, 0.5], [], [[0, 1]], [0, float("nan")], "abc"])
def test_solve_refuses_times_that_do_not_increase(solved, times):
    with pytest.raises(kinem.InputError, match="solve: times"):
        kinem.solve(solved[0], times=times)


def test_asarray_is_the_csv_table(solved):
    traj = solved[1].trajectory
    a = np.asarray(traj)
    assert a.shape == (len(traj), 1 + len(traj.columns))
    assert np.array_equal(a[:, 0], traj.t) and np.array_equal(a[:, 1:], traj.data)
    assert np.asarray(traj, dtype=np.float32).dtype == np.float32


def test_to_pandas_names_the_missing_package(solved, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)   # import pandas raises ImportError
    with pytest.raises(kinem.KinemError, match="needs pandas, which is not installed"):
        solved[1].trajectory.to_pandas()


def test_to_pandas_is_indexed_by_t(solved):
    pytest.importorskip("pandas")
    traj = solved[1].trajectory
    df = traj.to_pandas()
    assert list(df.columns) == list(traj.columns) and df.index.name == "t"
    assert np.array_equal(df.index.to_numpy(), traj.t) and np.array_equal(df["slider.x"].to_numpy(), traj["slider.x"])


def test_plot_returns_a_figure_of_the_moving_positions(solved):
    import matplotlib

    matplotlib.use("Agg")
    fig = kinem.plot(solved[1])
    labels = [line.get_label() for ax in fig.axes for line in ax.get_lines()]
    assert "slider.x" in labels and "crank.phi" in labels and "ground.x" not in labels   # the ground does not move
    fig = kinem.plot(solved[1].trajectory, columns=["B.x"])
    assert [line.get_label() for line in fig.axes[0].get_lines()] == ["B.x"]
    with pytest.raises(kinem.InputError, match="no column 'nope'"):
        kinem.plot(solved[1], columns=["nope"])


def test_animate_writes_the_results_motion(solved, tmp_path):
    out = kinem.animate(solved[1], tmp_path / "m.svg")
    assert out == tmp_path / "m.svg" and out.read_text().rstrip().endswith("</svg>")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.svg"]
    with pytest.raises(kinem.InputError, match="expected a file ending in"):
        kinem.animate(solved[1], tmp_path / "m.txt")


def test_repr_of_a_case_is_a_summary(solved):
    text = repr(solved[0].case)
    assert text.startswith("Case('slider_crank': 4 bodies, 2 points, 6 constraints") and len(text) < 200


def test_a_models_repr_is_one_short_line():
    """repr(model) names the case and its size, not the case's whole text
    (it was 4.7 kB for five bodies)."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "cam_table41.toml"))
    text = repr(model)
    assert "\n" not in text and len(text) < 200 and "'cam_table41'" in text and "10 coordinates" in text
