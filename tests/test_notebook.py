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
    # the named points that move (A rides on the slider) and the angles; the ground does not move
    assert "A.x" in labels and "crank.phi" in labels and "ground.x" not in labels and "B.x" in labels
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


# -- issue 32: the notebook layer ----------------------------------------------------------------

def four_bar(report_points=None):
    import tomllib

    data = tomllib.loads((ROOT / "cases" / "four_bar.toml").read_text())
    if report_points:
        data["report"] = {"points": report_points}
    return kinem.solve(kinem.compile(kinem.load_dict(data, source="four_bar")))


def lines(fig):
    return {ax.get_ylabel(): [(ln.get_label(), ln.get_color(), ln.get_linestyle()) for ln in ax.get_lines()]
            for ax in fig.axes}


def test_plot_one_panel_per_unit_distinct_lines():
    import matplotlib

    matplotlib.use("Agg")
    panels = lines(kinem.plot(four_bar()))
    assert list(panels) == ["length (m)", "angle (rad)"]   # the case's unit; angles on their own axis
    assert [n for n, _, _ in panels["length (m)"]] == ["A.x", "A.y", "B.x", "B.y"]   # named points, not bodies
    assert [n for n, _, _ in panels["angle (rad)"]] == ["crank.phi", "coupler.phi", "rocker.phi"]
    panels = lines(kinem.plot(four_bar(["B"]), angles="deg"))   # [report] points by default
    assert [n for n, _, _ in panels["length (m)"]] == ["B.x", "B.y"] and "angle (deg)" in panels
    r = kinem.solve(kinem.compile(kinem.load(ROOT / "cases" / "cam_roller_circle.toml")))
    panels = lines(kinem.plot(r))
    assert "contact.theta" in [n for n, _, _ in panels["angle (rad)"]]           # a radian column off the mm axis
    assert all(not n.endswith("theta") for n, _, _ in panels["length (mm)"])
    every = [c for c in r.trajectory.columns if c.rsplit(".", 1)[1] in ("x", "y", "phi", "vx")]
    drawn = [ln for p in lines(kinem.plot(r, columns=every)).values() for ln in p]
    assert len({(c, s) for _, c, s in drawn}) == len(drawn) > 10   # no two lines alike
    panels = lines(kinem.plot(r, columns=["cam.phi", "cam.omega", "follower.vy"], angles="deg"))
    assert list(panels) == ["angle (deg)", "angular velocity (deg/s)", "velocity (mm/s)"]
    line = kinem.plot(r, columns=["cam.phi"], angles="deg").axes[0].get_lines()[0]
    np.testing.assert_allclose(line.get_ydata(), np.degrees(r.trajectory["cam.phi"]), rtol=1e-15)
    with pytest.raises(kinem.InputError, match="did you mean 'cam.phi'"):
        kinem.plot(r, columns=["cam.ph"])


def test_plot_path_draws_the_mechanism_and_paths():
    import matplotlib

    matplotlib.use("Agg")
    r = four_bar()
    fig = kinem.plot(r, kind="path")
    (ax,) = fig.axes
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["O2 path", "O4 path", "A path", "B path"]
    path = next(ln for ln in ax.get_lines() if ln.get_label() == "B path")
    np.testing.assert_allclose(path.get_xdata(), r.trajectory["B.x"], rtol=0, atol=1e-12)
    assert len(ax.patches) + len(ax.get_lines()) > 8   # the links, joints and ground drawn too
    fig = kinem.plot(four_bar(["B"]), kind="path", at=-1)
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["B path"]
    with pytest.raises(kinem.InputError, match="did you mean 'B'"):
        kinem.plot(r, kind="path", columns=["b2"])
    with pytest.raises(kinem.InputError, match="expected 'time' or 'path'"):
        kinem.plot(r, kind="xy")


def test_animate_a_result_whose_model_is_gone(tmp_path, capsys):
    from PIL import Image

    out = kinem.animate(kinem.solve(kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))),
                        tmp_path / "x.gif", frames=40, progress=True)
    with Image.open(out) as im:
        assert im.n_frames == 40 and im.size[0] > 300
    assert "frame 40 of 40 drawn" in capsys.readouterr().err


def test_statuses_by_name_and_columns_suggested(solved):
    r = solved[1]
    assert str(r.status) == "SUCCESS" and f"{r.status}" == "SUCCESS" and r.status == 0
    with pytest.raises(KeyError, match="did you mean 'B.x'"):
        r.trajectory["B.xx"]
    with pytest.raises(KeyError, match=r"columns: ground.x, .*\(\d+ columns\)"):
        r.trajectory["zzzzzz"]


def test_rich_display(solved):
    r = solved[1]
    html = r._repr_html_()
    assert html.startswith("<div><p><b>slider_crank</b>: SUCCESS") and "<svg" in html and "data-path" in html
    t = r.trajectory._repr_html_()
    assert "<table>" in t and "<th>slider.x</th>" not in t and "<th>ground.x</th>" in t and t.count("<tr>") == 6
