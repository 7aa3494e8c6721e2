"""The command line: solve, info, outputs, and one-line errors with exit
code 2 for each kind of malformed case (no traceback, no partial file)."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"
SLIDER = (CASES / "slider_crank.toml").read_text()


def run(*args, cwd=ROOT):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], capture_output=True, text=True, cwd=cwd)
    return p.returncode, p.stdout, p.stderr


def test_info_slider_crank_counts():
    code, out, err = run("info", CASES / "slider_crank.toml", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert (d["coordinates"], d["equations"], d["driving_equations"], d["jacobian_nonzeros"], d["dof"]) == (12, 12, 1, 36, 1)
    assert d["residual"] < 1e-10 and d["redundant_equations"] == []


def test_info_names_redundant_equations(tmp_path):
    """A parallelogram with a third parallel crank: one equation is redundant, DOF stays 1."""
    case = {"name": "parallelogram", "time": {"end": 1.0, "steps": 10},
            "bodies": {"ground": {"q": [0, 0, 0]}, "c1": {"q": [0, 0, 1.0]}, "c2": {"q": [1, 0, 1.0]},
                       "c3": {"q": [2, 0, 1.0]}, "bar": {"q": [0.54, 0.84, 0.0]}},
            "constraints": [{"type": "ground", "body": "ground"}]
            + [{"type": "revolute", "name": f"G{k}", "i": "ground", "si": [float(k), 0.0], "j": f"c{k + 1}", "sj": [0.0, 0.0]} for k in range(3)]
            + [{"type": "revolute", "name": f"T{k}", "i": f"c{k + 1}", "si": [1.0, 0.0], "j": "bar", "sj": [float(k), 0.0]} for k in range(3)]}
    from kinem.info import info as get_info

    i = get_info(kinem.compile(kinem.load_dict(case)))
    assert i.equations == 15 and i.coordinates == 15
    assert i.dof == 1
    assert len(i.redundant_equations) == 1


def test_example_4_1_point_b():
    r = kinem.solve(kinem.compile(kinem.load(ROOT / "tests/data/example_4_1.toml")))
    # the book prints B = (0.48, 4.60), rounded to two decimals
    assert abs(r.trajectory["B.x"][0] - 0.48) < 0.005 and abs(r.trajectory["B.y"][0] - 4.60) < 0.005


def test_solve_csv_columns_and_values(tmp_path):
    out = tmp_path / "sc.csv"
    code, _, err = run("solve", CASES / "slider_crank.toml", "--out", out, "--steps", "50")
    assert code == 0, err
    header = out.read_text().splitlines()[0].split(",")
    bodies = ["ground", "crank", "rod", "slider"]
    q = ["x", "y", "phi", "vx", "vy", "omega", "ax", "ay", "alpha"]
    pts = ["x", "y", "vx", "vy", "ax", "ay"]
    assert header == ["t"] + [f"{b}.{k}" for b in bodies for k in q] + [f"{p}.{k}" for p in ("B", "A") for k in pts]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (51, len(header))
    ref = kinem.solve(kinem.compile(kinem.load(CASES / "slider_crank.toml").with_time(steps=50)))
    assert np.array_equal(data[:, 1:], ref.trajectory.data)  # 17 digits: exact round trip


def test_solve_positions_only_stdout():
    code, out, err = run("solve", CASES / "four_bar.toml", "--outputs", "positions", "--steps", "5")
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("t,ground.x,ground.y,ground.phi,crank.x") and ".vx" not in lines[0]
    assert len(lines) == 7


def test_positions_only_does_no_velocity_work(monkeypatch):
    """Positions only: no velocities or accelerations at the output instants.
    The march (the core's loop) then extrapolates positions for its
    predictor; nu and gamma are evaluated through Python only at the few
    states the tracker takes (the assembly), the full run's rates in the core."""
    from kinem.model import Model

    model = kinem.compile(kinem.load(CASES / "slider_crank.toml"))
    rates_at = {"nu": 0, "gamma": 0}

    def spy(name, f):
        def g(self, *args):
            rates_at[name] += np.size(args[-1])  # instants (t is the last argument)
            return f(self, *args)
        return g

    kinem.solve(model)  # compiled and loaded (its set-up evaluates both once)
    monkeypatch.setattr(Model, "nu", spy("nu", Model.nu))
    monkeypatch.setattr(Model, "gamma", spy("gamma", Model.gamma))
    p = kinem.solve(model, ("positions",))
    assert p.qd is None and p.qdd is None
    n = len(p.iterations)
    assert rates_at["nu"] <= 2 and rates_at["gamma"] <= 2
    full = kinem.solve(model)
    assert full.qd is not None and full.qdd is not None and len(full.qd) == n
    # the full run: nu and gamma at every instant in the core, none through Python per instant
    assert rates_at["nu"] <= 4 and rates_at["gamma"] <= 4
    # one Jacobian per instant, at its final configuration (the conditioning monitor, the rates to
    # rounding, the next instant's chord: newton::chord), and Newton's at the assembly at t = 0 and
    # the first instant after it (no factorisation to chord with yet)
    assert n <= full.jacobian_evaluations <= n + 4
    assert p.jacobian_evaluations <= full.jacobian_evaluations + n
    # with jacobian_reuse, the next instant's Newton iterations start from that one
    from dataclasses import replace

    reuse = kinem.solve(model, options=replace(kinem.Options.of(model.case), jacobian_reuse=True))
    assert len(reuse.iterations) <= reuse.jacobian_evaluations < 1.1 * len(reuse.iterations)
    assert np.allclose(p.q, full.q, atol=1e-9 * model.length)


def test_npz_output(tmp_path):
    out = tmp_path / "fb.npz"
    code, _, err = run("solve", CASES / "four_bar.toml", "--out", out, "--steps", "10")
    assert code == 0, err
    z = np.load(out)
    assert z["data"].shape == (11, len(z["columns"])) and z["t"][-1] == 2.5


BAD = {
    "toml-syntax": (SLIDER.replace("end = 5.0", "end = = 5.0"), "TOML syntax error"),
    "unknown-type": (SLIDER.replace('type = "revolute"\nname = "O"', 'type = "revolut"\nname = "O"'), "unknown type 'revolut'"),
    "unknown-key": (SLIDER.replace('sj = [-100.0, 0.0]', 'sj = [-100.0, 0.0]\nsk = 1'), "key 'sk': unknown key"),
    "missing-key": (SLIDER.replace('j = "crank"\nsj = [-100.0, 0.0]', 'j = "crank"'), "key 'sj': missing"),
    "unknown-body": (SLIDER.replace('j = "crank"\nsj = [-100.0, 0.0]', 'j = "crnak"\nsj = [-100.0, 0.0]'), "unknown body 'crnak'"),
    "unknown-point": (SLIDER.replace('sj = [-100.0, 0.0]', 'sj = "Q"'), "unknown point 'Q'"),
    "wrong-length": (SLIDER.replace('si = [300.0, 0.0]', 'si = [300.0, 0.0, 1.0]'), "key 'si'"),
    "non-finite": (SLIDER.replace('si = [300.0, 0.0]', 'si = [300.0, nan]'), "finite"),
    "zero-length-line": (SLIDER.replace('qi = [100.0, 0.0]', 'qi = [0.0, 0.0]'), "zero length"),
    "unknown-top-key": ("solverr = {}\n" + SLIDER, "key 'solverr': unknown key"),
    "bad-time": (SLIDER.replace("steps = 500", "steps = 0"), "key 'steps'"),
    "bad-block": (SLIDER + "\n[solver]\nblock = 0\n", "key 'block': got 0; expected a whole number from 1 to 4096"),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_bad_input_one_line_exit_2(tmp_path, kind):
    text, needle = BAD[kind]
    path = tmp_path / "bad.toml"
    path.write_text(text)
    out = tmp_path / "out.csv"
    for args in (("info", path), ("solve", path, "--out", out)):
        code, stdout, stderr = run(*args)
        assert code == 2, (kind, stderr)
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in stderr, stderr
        assert str(path) in lines[0] and needle in lines[0], lines[0]
    assert not out.exists()


def test_bad_input_names_constraint_and_key():
    with pytest.raises(kinem.InputError) as e:
        kinem.loads(BAD["unknown-point"][0], source="x.toml")
    assert "x.toml: constraint 3 ('B', revolute): key 'sj': unknown point 'Q'" in str(e.value)


def test_every_problem_is_reported():
    text = SLIDER.replace('sj = [-100.0, 0.0]', 'sj = "Q"').replace('si = [300.0, 0.0]', 'si = [300.0, nan]')
    with pytest.raises(kinem.InputError) as e:
        kinem.loads(text, source="x.toml")
    assert len(e.value.problems) == 2


def test_bad_arguments_exit_2():
    code, _, err = run("solve", CASES / "slider_crank.toml", "--outputs", "speed")
    assert code == 2 and len(err.strip().splitlines()) == 1
    code, _, err = run("solve", CASES / "missing.toml")
    assert code == 2 and "cannot read" in err


def test_analysis_failure_exit_1_and_no_partial_file(tmp_path):
    """A slider-crank whose crank is longer than the rod cannot assemble: exit 1, no file."""
    text = SLIDER.replace('si = [300.0, 0.0]', 'si = [50.0, 0.0]').replace(
        'sj = [-200.0, 0.0]', 'sj = [-20.0, 0.0]')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    out = tmp_path / "out.csv"
    out.write_text("previous")
    code, _, err = run("solve", path, "--out", out)
    assert code == 1, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert out.read_text() == "previous"


def test_engine_docs_are_generated_and_current():
    from kinem import engines

    text = (ROOT / "docs" / "engines.md").read_text()
    assert engines.BEGIN + "\n" + engines.markdown() + engines.END in text, "run: kinem engines --update-docs"


def test_stress_and_tune_json_write_null_for_a_figure_not_computed(monkeypatch, capsys):
    """`kinem stress --json` and `engines --tune --json` wrote NaN (no JSON number: strict readers refuse
    it) for a figure not computed; now null, as compare --json writes, numpy's numbers as floats."""
    from kinem.cli.commands import strict_json

    text = strict_json([{"error": float("nan"), "residual": float("inf"), "wall_time": np.float64(0.25),
                         "steps": np.int64(3), "q": np.array([1.0, 2.0])}])
    strict = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in {text}"))
    assert strict == [{"error": None, "residual": None, "wall_time": 0.25, "steps": 3, "q": [1.0, 2.0]}]
    from kinem import stress
    from kinem.cli import main

    row = stress.Row("g", "s", "native", float("nan"), float("nan"), 0.1, ())
    monkeypatch.setattr(stress, "run", lambda *a, **k: [stress.Outcome(stress.Class.SINGULAR, "", row)])
    monkeypatch.setattr(stress, "misses", lambda *a, **k: [])
    assert main(["stress", "--json", "--engines", "native"]) == 0
    out = capsys.readouterr().out
    assert json.loads(out, parse_constant=lambda c: pytest.fail(c))[0]["error"] is None
