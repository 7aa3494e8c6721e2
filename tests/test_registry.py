"""The engine registry and the adapter skeleton: one list of engines used by
the CLI, the report, the stress suite and the matrix; settings checked in
one place with one-line exit-2 errors; a new engine is one module plus one
registry line (tests/dummy_sim.py)."""
import json
import re
from pathlib import Path

import pytest

import adapters
import kinem
from adapters.base import Status
from kinem.cli import main

ROOT = Path(__file__).resolve().parents[1]
SLIDER = ROOT / "cases" / "slider_crank.toml"


@pytest.fixture
def dummy(monkeypatch):
    monkeypatch.setitem(adapters.REGISTRY, "dummy", "dummy_sim")   # the one registry line


def short_case(tmp_path, extra=""):
    text = re.sub(r"\[time\][^\[]*", "[time]\nend = 0.1\nsteps = 10\n\n", SLIDER.read_text(), count=1) + extra
    path = tmp_path / "case.toml"
    path.write_text(text)
    return path


def test_a_new_engine_is_one_module_and_one_line(dummy, tmp_path, capsys):
    case = short_case(tmp_path)
    assert "dummy" in adapters.names()
    # kinem compare: every engine by default, --engines, --set
    assert main(["compare", str(case), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["engines"]
    assert list(rows) == ["native", "pymunk", "mujoco", "exudyn", "dummy"]
    assert rows["dummy"]["status"] == "ok" and rows["dummy"]["within_tolerance"] is True
    assert rows["dummy"]["substeps"] == 10     # interval 0.01 s over dt 1e-3: the skeleton's substeps
    assert main(["compare", str(case), "--engines", "native,dummy", "--set", "dummy.dt=0"]) == 2
    assert "dummy setting 'dt' = 0: expected a positive number" in capsys.readouterr().err
    # the support matrix and the report's engine run
    from kinem import engines
    from kinem.report.runs import Task, run_task

    assert "dummy 0.1" in engines.markdown()
    r = run_task(Task(str(case), "dummy"))
    assert r["status"] == "ok" and r["within_tolerance"] and r["time_per_interval"] is not None
    # the stress suite
    from kinem import stress

    s = next(s for s in stress.scenarios(True) if s.engines and s.group == "length-scale")
    out = stress.run_one((s, "dummy"))
    assert out.status is stress.Class.ACCURATE, out


@pytest.mark.parametrize("value, expected", [("0", "= 0: expected a positive number"),
                                             ("x", "= 'x': expected a positive number"),
                                             ("-1", "= -1: expected a positive number")])
def test_bad_dt_is_one_line_exit_2(value, expected, capsys):
    assert main(["compare", str(SLIDER), "--engines", "native,mujoco", "--set", f"mujoco.dt={value}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--set: mujoco setting 'dt' " + expected in err


@pytest.mark.parametrize("table, expected", [
    ("[engines.nope]\ndt = 1e-3\n", ": [engines.nope]: unknown engine 'nope'; expected one of pymunk, mujoco, exudyn"),
    ("[engines.mujoco]\ndt = -1.0\n", ": [engines.mujoco]: key 'dt': got -1.0; expected a positive number"),
    ("[engines.pymunk]\nsteps = 3\n", ": [engines.pymunk]: key 'steps': unknown key; expected one of"),
])
def test_case_file_engine_tables_are_checked_when_used(tmp_path, capsys, table, expected):
    case = short_case(tmp_path, "\n" + table)
    kinem.load(case)   # the loader keeps the tables raw: the solver core knows no engine names
    assert main(["compare", str(case), "--engines", "native,mujoco,pymunk"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(case) in err and expected in err


def test_statuses_are_typed():
    model = kinem.compile(kinem.load(ROOT / "cases" / "cam_table41.toml"))
    run = adapters.get("mujoco").run(model, model.q0, model.q0 * 0)
    assert run.status is Status.UNSUPPORTED and run.label == f"unsupported: {run.detail}"
    assert Status.DIVERGED.failure and not Status.UNSUPPORTED.failure
    assert Status.DIVERGED.label("x") == "failed: x"   # one prefix for every failure in reports


def test_every_setting_has_a_check():
    for name in adapters.names():
        a = adapters.get(name)
        assert set(a.checks) == set(a.defaults()), name
        a.settings()   # the defaults pass their own checks
