"""Sub-steps count against the work limit (issue 25, item 3): a driver too
fast for the output interval ends the run in one line (exit 1) naming its
rate and the step it needs, instead of running for minutes; on a terminal
the progress bar counts the sub-steps."""
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import kinem
from kinem import stream

ROOT = Path(__file__).resolve().parents[1]


def fast_slider_crank(omega):
    """The slider-crank with its crank driven by a harmonic of frequency omega."""
    with open(ROOT / "cases" / "slider_crank.toml", "rb") as f:
        d = tomllib.load(f)
    c = next(c for c in d["constraints"] if c.get("name") == "crank-drive")
    c["d"] = {"harmonic": {"amplitude": 1.0, "omega": omega, "phase": 0.0, "offset": 5.76}}
    return d


def case_file(tmp_path, omega):
    import json

    d = fast_slider_crank(omega)
    lines = [f"{k} = {json.dumps(v)}" for k, v in d.items() if not isinstance(v, (dict, list))]
    text = "\n".join(lines) + "\n"
    for k, v in d.items():
        if isinstance(v, dict):
            text += f"\n[{k}]\n" + "".join(f"{kk} = {_toml(vv)}\n" for kk, vv in v.items())
    for c in d["constraints"]:
        text += "\n[[constraints]]\n" + "".join(f"{kk} = {_toml(vv)}\n" for kk, vv in c.items())
    path = tmp_path / "fast.toml"
    path.write_text(text)
    return path


def _toml(v):
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v)


def test_a_run_past_its_substep_limit_fails_naming_the_driver_and_the_step():
    model = kinem.compile(kinem.load_dict(fast_slider_crank(1e4)))
    r = kinem.solve(model, outputs=("positions",), options=kinem.Options(max_substeps=50))
    assert not r.success and r.attempts == 51 and r.substeps <= 51
    assert "more than the limit of 50 step attempts" in r.message
    assert "driver 'crank-drive' moves at up to 1e+04 rad/s" in r.message   # amplitude 1 x omega 1e4
    assert "--steps" in r.message and "needs steps of about" in r.message


def test_the_limit_holds_for_the_whole_chunked_run():
    model = kinem.compile(kinem.load_dict(fast_slider_crank(1e3)))
    o = stream.run(model, ("positions",), lambda r: None, size=5,
                   options=kinem.Options(max_substeps=80))
    assert not o.success and "more than the limit of 80 step attempts" in o.detail


def test_kinem_solve_counts_substeps_against_max_work(tmp_path):
    case = case_file(tmp_path, 1e3)
    model = kinem.compile(kinem.load(case))
    # room for 40 step attempts beyond the output instants (each counts as SUBSTEP_WORK instants)
    limit = stream.work(model) + 40 * stream.SUBSTEP_WORK * model.n
    out = tmp_path / "f.csv"
    p = subprocess.run([sys.executable, "-m", "kinem", "solve", str(case), "--max-work", str(limit),
                        "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 1 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert "more than the limit of 40 step attempts" in lines[0] and "'crank-drive'" in lines[0]
    assert "1e+03 rad/s" in lines[0] and not out.exists()


def test_the_progress_bar_counts_substeps_on_a_terminal(tmp_path):
    from test_outputs import on_a_terminal

    case = case_file(tmp_path, 1e3)
    model = kinem.compile(kinem.load(case))
    limit = stream.work(model) + 500 * stream.SUBSTEP_WORK * model.n
    code, seen = on_a_terminal(["solve", case, "--max-work", limit, "--out", os.devnull], timeout=600)
    # 501 instants: too few for the bar by instants; the sub-steps show it (every SHOW_SUBSTEPS = 100)
    assert code == 1 and b"200 sub-steps" in seen and b"t = " in seen


@pytest.mark.parametrize("bad", [-1, 1.5])
def test_max_substeps_is_checked(bad):
    with pytest.raises(kinem.InputError, match="max_substeps"):
        kinem.Options(max_substeps=bad)
