"""The front door (issue 17, item 7): version, usage, error prefix, the
README's Python block run as it stands, Data from a model, short reprs,
dev.py's kinem passthrough."""
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import kinem

ROOT = Path(__file__).resolve().parents[1]


def run(*args):
    p = subprocess.run([sys.executable, "-m", "kinem", *args], capture_output=True, text=True, cwd=ROOT, timeout=300)
    return p.returncode, p.stdout, p.stderr


def test_version():
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", kinem.__version__)
    code, out, err = run("--version")
    assert code == 0 and out.strip() == f"kinem {kinem.__version__}", err


def test_bare_kinem_prints_usage():
    code, out, err = run()
    assert code == 0 and out.startswith("usage: kinem") and "solve" in out and "report" in out and err == ""


def test_errors_are_not_prefixed_twice():
    code, _, err = run("solve")
    assert code == 2 and err.strip() == "kinem: error: solve: the following arguments are required: case"
    code, _, err = run("nonsense")
    assert code == 2 and err.startswith("kinem: error: argument COMMAND: invalid choice") and "kinem: error: kinem" not in err


def test_readme_python_block_runs_as_written(monkeypatch, capsys):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "README.md has no Python block"
    monkeypatch.chdir(ROOT)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    printed = capsys.readouterr().out
    assert printed.startswith("SolveResult(success=True") and len(printed) < 400


def test_data_from_a_model():
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    data = kinem.Data.from_model(model)
    assert data.q is not model.q0 and (data.q == model.q0).all() and data.t == 0.0
    kinem.position(model, data, 0.0)
    assert data.residual <= kinem.Options().tolerance   # kinem.position's default
    with pytest.raises(TypeError, match="Data.from_model"):
        kinem.Data(model)


def test_short_repr_of_results():
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    r = kinem.solve(model)
    text = repr(r)
    assert len(text) < 300 and "\n" not in text and "array" not in text
    assert text.startswith("SolveResult(success=True, status=SUCCESS, message='all instants solved'")
    assert repr(r.trajectory) == ("Trajectory(501 instants, t 0 to 5, 48 columns: ground.x, ground.y, "
                                  "ground.phi, ground.vx, ...)")


def test_a_results_columns_are_made_once_at_first_use_and_equal_its_coordinates():
    """solve's trajectory makes its columns when first read (issue 31 item
    6): the same array at every read, read-only, each body's columns its
    coordinates, velocities and accelerations exactly; a failed solve's
    columns hold only the instants solved; SolveResult.of takes every
    field, no fewer."""
    import numpy as np

    from kinem.result import SolveResult

    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    r = kinem.solve(model)
    traj = r.trajectory
    assert traj.data is traj.data and not traj.data.flags.writeable
    assert traj.data.shape == (501, 48)
    for k, name in enumerate(("x", "y", "phi")):
        assert np.array_equal(traj[f"crank.{name}"], r.q[:, 3 + k])
        assert np.array_equal(traj[f"crank.{('vx', 'vy', 'omega')[k]}"], r.qd[:, 3 + k])
        assert np.array_equal(traj[f"crank.{('ax', 'ay', 'alpha')[k]}"], r.qdd[:, 3 + k])
    short = kinem.solve(model, options=kinem.Options(max_iterations=1), q0=model.q0 + 5.0)
    assert not short.success and short.trajectory.data.shape == (len(short.q), 48) == (0, 48)
    assert short.t_fail == 0.0
    values = {f: getattr(r, f) for f in r.__dataclass_fields__}
    again = SolveResult.of(**values)
    assert all(getattr(again, f) is getattr(r, f) for f in values)
    given = dict(values)   # or as a dict, taken as the result's own (solve's way)
    assert SolveResult.of(given).__dict__ is given and SolveResult.of(given).q is r.q
    with pytest.raises(TypeError, match="not both"):
        SolveResult.of(dict(values), model=None)
    values.pop("model")
    with pytest.raises(TypeError, match="model"):
        SolveResult.of(**values)


def test_dev_py_passes_kinem_commands_through(monkeypatch):
    spec = importlib.util.spec_from_file_location("dev", ROOT / "dev.py")
    dev = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(dev)
    calls = []
    monkeypatch.setattr(dev, "ensure_env", lambda: None)   # never build a virtual environment here
    monkeypatch.setattr(dev.subprocess, "run", lambda args, **kw: calls.append((args, kw)) or
                        subprocess.CompletedProcess(args, 0))
    assert dev.main(["kinem", "solve", "x.toml", "--out", "y.csv"]) == 0
    args, kw = calls[0]
    assert args[1:] == ["-m", "kinem", "solve", "x.toml", "--out", "y.csv"] and "cwd" not in kw
    assert args[0] == str(dev.PYTHON) and os.path.basename(args[0]).startswith("python")


def test_a_results_arrays_are_frozen_like_its_columns():
    """The trajectory's columns are made from result.q/qd/qdd on first use:
    those arrays are read-only, so an edit cannot reach the columns later."""
    r = kinem.solve(kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml")))
    for x in (r.q, r.qd, r.qdd):
        with pytest.raises(ValueError):
            x[0, 0] = 1.0
    assert r.trajectory["crank.phi"][0] == r.q[0, 5]
