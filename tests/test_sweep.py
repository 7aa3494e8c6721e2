"""kinem.sweep and kinem sweep: a grid of named parameters solved as one batch,
each variant equal to solving it alone, each failure on its own row."""
import csv
import io
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import cli
from kinem.errors import InputError
from kinem.sweep import parse_values, sweep

FOUR_BAR = Path(__file__).parent / "data" / "four_bar_named.toml"
OUT = ("B.x", "B.y", "B.vx", "rocker.phi", "rocker.alpha")


def alone(parameters, columns=OUT):
    r = kinem.solve(kinem.compile(kinem.load(FOUR_BAR, parameters=parameters)))
    assert r.success, r.message
    return np.column_stack([r.trajectory[c] for c in columns])


def test_201_coupler_lengths_each_as_solved_alone():
    lengths = np.linspace(0.28, 0.32, 201)
    s = sweep(FOUR_BAR, {"coupler": lengths}, outputs=OUT)
    assert s.success and s.data.shape == (201, 251, len(OUT))
    assert np.array_equal(s.values[:, 0], lengths)
    for k, c in enumerate(lengths):
        # the batch converges each variant to the same tolerance as alone: 1e-10 of the size (0.3 m) or better
        np.testing.assert_allclose(s.data[k], alone({"coupler": c}), rtol=0, atol=3e-11 * 100)
    # the coupler length matters: B moves by millimetres over the sweep
    assert np.ptp(s["B.x"][:, 0]) > 1e-3


def test_a_failing_variant_is_its_own_row(tmp_path):
    # a coupler of 0.6 m cannot close the loop (at most crank + ground + rocker = 0.52 m)
    s = sweep(FOUR_BAR, {"coupler": [0.3, 0.6, 0.31], "rocker": [0.22]}, outputs=("B.x",))
    assert [bool(e) for e in s.errors] == [False, True, False]
    assert "NOT_CONVERGED" in s.errors[1] or "SINGULAR" in s.errors[1]
    assert np.isnan(s.data[1]).all()
    np.testing.assert_allclose(s.data[2], alone({"coupler": 0.31}, ("B.x",)), rtol=0, atol=1e-10)
    rows = list(csv.reader(io.StringIO(s.csv().decode())))
    assert rows[0] == ["variant", "coupler", "rocker", "t", "B.x", "error"]
    failed = [r for r in rows[1:] if r[0] == "1"]
    assert len(failed) == 1 and failed[0][3] == "" and failed[0][5]
    assert len(rows) == 1 + 2 * 251 + 1


def test_a_bad_value_is_its_own_row():
    s = sweep(FOUR_BAR, {"crank": [0.1, 2e12]}, outputs=("B.x",))
    assert s.errors[0] == "" and s.errors[1].startswith("bad input") and "magnitude" in s.errors[1]


def test_grid_is_every_combination():
    s = sweep(FOUR_BAR, {"coupler": [0.29, 0.3], "crank": [0.09, 0.1, 0.11]}, outputs=("B.y",))
    assert s.values.tolist() == [[0.29, 0.09], [0.29, 0.1], [0.29, 0.11], [0.3, 0.09], [0.3, 0.1], [0.3, 0.11]]
    np.testing.assert_allclose(s.data[4], alone({"coupler": 0.3, "crank": 0.1}, ("B.y",)), rtol=0, atol=1e-10)


def test_bad_requests():
    with pytest.raises(InputError, match="did you mean 'coupler'"):
        sweep(FOUR_BAR, {"couplr": [0.3]})
    with pytest.raises(InputError, match="did you mean 'B.x'"):
        sweep(FOUR_BAR, {"coupler": [0.3]}, outputs=("B.xx",))
    assert parse_values("c=1:2:3")[1].tolist() == [1.0, 1.5, 2.0]
    assert parse_values("c=1,2.5")[1].tolist() == [1.0, 2.5]
    for bad in ("c", "c=1:2", "c=1:2:0", "c=a,b", "=1"):
        with pytest.raises(InputError, match="--set"):
            parse_values(bad)


def test_cli_sweep(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    assert cli.main(["sweep", str(FOUR_BAR), "--set", "coupler=0.29:0.31:3", "--outputs", "B.x,rocker.phi",
                     "--out", str(out)]) == 0
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["variant", "coupler", "t", "B.x", "rocker.phi", "error"]
    assert len(rows) == 1 + 3 * 251
    last = alone({"coupler": 0.31}, ("B.x",))
    assert abs(float(rows[-1][3]) - last[-1, 0]) <= 1e-10
    assert cli.main(["sweep", str(FOUR_BAR), "--set", "coupler=0.3,0.6", "--outputs", "B.x",
                     "--out", str(out)]) == 1
    assert "1 of 2 variants failed" in capsys.readouterr().err
    assert cli.main(["sweep", str(FOUR_BAR), "--outputs", "B.x"]) == 2


def test_progress_on_a_terminal(tmp_path):
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_outputs import on_a_terminal

    code, seen = on_a_terminal(["sweep", FOUR_BAR, "--set", "coupler=0.29:0.31:5", "--outputs", "B.x",
                                "--out", tmp_path / "s.csv"], timeout=120)
    assert code == 0 and b"variant 5 loaded" in seen and b"5 variants solved" in seen and b"10/10" in seen
    code, seen = on_a_terminal(["animate", FOUR_BAR, "--engines", "native", "--out", tmp_path / "m.gif"], timeout=300)
    assert code == 0 and b"frame 120 of 120 drawn" in seen
