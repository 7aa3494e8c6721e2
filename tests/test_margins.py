"""Issue 30 item 5: margins as outputs (kinem.margins): the smallest
singular value of the dimensionless Jacobian and the transmission angles."""
import subprocess
import sys
from pathlib import Path

import numpy as np

import kinem
from kinem.margins import joints

ROOT = Path(__file__).resolve().parents[1]
ALL = ("positions", "velocities", "accelerations", "margins")


def test_four_bar_transmission_angle_is_the_textbook_one():
    """cos mu = (b^2 + c^2 - a^2 - d^2 + 2 a d cos th2) / (2 b c) at the
    coupler-rocker joint B (crank a, coupler b, rocker c, ground d), to 1e-12 rad;
    only the joints between two binary links (A, B) have a column."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    r = kinem.solve(model, outputs=ALL)
    tr = r.trajectory
    assert [j[0] for j in joints(model)] == ["A", "B"]
    assert "O2.transmission" not in tr and "O4.transmission" not in tr
    a, b, c, d = 0.1, 0.3, 0.22, 0.2
    mu = np.arccos((b * b + c * c - a * a - d * d + 2 * a * d * np.cos(tr["crank.phi"])) / (2 * b * c))
    assert np.max(np.abs(tr["B.transmission"] - mu)) < 1e-12
    # at A, between crank and coupler: pi minus their relative angle, folded into [0, pi]
    rel = np.angle(np.exp(1j * (tr["coupler.phi"] - tr["crank.phi"])))
    assert np.max(np.abs(tr["A.transmission"] - (np.pi - np.abs(rel)))) < 1e-12
    assert (tr["margin"] > 0.05).all() and len(r.margin_moves) == len(tr.t)


def test_slider_crank_dead_point_margin_goes_to_zero():
    """Driven from the slider, the slider-crank's outer dead centre (t = 0.5)
    is singular: the margin falls like sqrt(0.5 - t) (constant ratio within
    2% over the last decades) and is below 1e-5 at 1e-8 from it; its singular
    vector moves the crank."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "stress" / "slider_dead_centre.toml"))
    gap = np.geomspace(0.4, 1e-8, 12)
    r = kinem.solve(model, times=np.concatenate([[0.0], 0.5 - gap]), outputs=("positions", "margins"))
    assert r.success, r.message
    m = r.trajectory["margin"][1:]
    assert np.all(np.diff(m) < 0) and m[-1] < 1e-5
    ratio = m / np.sqrt(gap)
    assert np.max(np.abs(ratio[-6:] / ratio[-1] - 1)) < 0.02
    assert "crank.phi" in r.margin_moves[-1]


def test_cli_solve_writes_margin_columns(tmp_path):
    out = tmp_path / "m.csv"
    subprocess.run([sys.executable, "-m", "kinem", "solve", str(ROOT / "cases" / "four_bar.toml"), "--outputs",
                    "positions,margins", "--steps", "10", "--out", str(out)], check=True, capture_output=True)
    head = out.read_text().splitlines()[0].split(",")
    assert head[-3:] == ["margin", "A.transmission", "B.transmission"]
    assert np.isfinite(np.loadtxt(out, delimiter=",", skiprows=1)).all()
