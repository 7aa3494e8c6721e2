"""kinem compare --sensitivity (adapters/sensitivity.py; docs/design.md,
"Sensitivities cross-checked by the engines"): every engine's central
differences within (X1) of native's exact sensitivities on the book's
cases, and a coarsened engine outside, the figure named. Short runs: the
cases' first instants only."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

import kinem
from adapters.base import Status
from adapters.sensitivity import check, columns

ROOT = Path(__file__).resolve().parents[1]
ENGINES = ["native", "pymunk", "mujoco", "exudyn"]


def run(*args):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    return p.returncode, p.stdout, p.stderr


@pytest.mark.parametrize("name, path, end", [
    ("slider_crank", "constraints.B.sj.0", 0.6),
    ("four_bar", "constraints.B.si.0", 0.3),
    ("quick_return_1", "constraints.crank-drive.d.poly.1", 0.4),
])
def test_engines_differences_within_their_limits(name, path, end):
    case = kinem.load(ROOT / f"cases/{name}.toml")
    model = kinem.compile(case.with_time(end=end, steps=20))
    exact, checks = check(model, [path], ENGINES)
    assert [c.engine for c in checks] == ENGINES
    for c in checks:
        assert c.status is Status.OK, (c.engine, c.text)
        assert c.within and 0 <= c.ratio <= 1, (c.engine, c.text)   # (X1), the limit from eps_e and h
        assert c.figure.endswith(f"/d({path})") and c.figure in exact
    # the differences are a real check: a wrong exact sensitivity (10% off) is outside native's limit
    native = checks[0]
    column = native.figure[2:native.figure.index(")/d(")]
    wrong = abs(1.1 * exact.of(column, path) - native.curves[column]).max()
    assert wrong > native.limit, (wrong, native.limit)


def test_a_coarsened_engine_fails_naming_the_figure():
    code, out, err = run("compare", ROOT / "cases/four_bar.toml", "--sensitivity", "points.A.at.0",
                         "--engines", "native,pymunk", "--set", "pymunk.dt=0.02", "--end", "0.3", "--steps", "15",
                         "--json")
    assert code == 1, err
    rows = {r["engine"]: r for r in json.loads(out)["sensitivity"]}
    assert rows["native"]["within"] is True
    bad = rows["pymunk"]
    assert bad["within"] is False and bad["ratio"] > 1 and bad["error"] > bad["limit"]
    model = kinem.compile(kinem.load(ROOT / "cases/four_bar.toml"))
    assert bad["figure"] in [f"d({c})/d(points.A.at.0)" for c in columns(model)]
    code, out, _ = run("compare", ROOT / "cases/four_bar.toml", "--sensitivity", "points.A.at.0",
                       "--engines", "native,pymunk", "--set", "pymunk.dt=0.02", "--end", "0.3", "--steps", "15")
    assert code == 1 and f"OUTSIDE: {bad['figure']} off by" in out


def test_no_parameters_is_an_input_error():
    code, out, err = run("compare", ROOT / "cases/slider_crank.toml", "--sensitivity", "--engines", "native")
    assert code == 2 and "[report] sensitivity" in err and not out
    code, _, err = run("compare", ROOT / "cases/four_bar.toml", "--sensitivity", "points.Q.at.0", "--engines", "native")
    assert code == 2 and "points.Q.at.0" in err


def test_report_design_section_shows_the_engines_differences():
    """The report's design section gets a column per engine: its largest
    ratio to (X1) for every parameter, within 1 on the four-bar."""
    import re

    from kinem.report.design import section

    model = kinem.compile(kinem.load(ROOT / "cases/four_bar.toml").with_time(end=0.5, steps=20))
    table = section(model, ["pymunk"])[0]
    assert "<th>pymunk differences</th>" in table
    ratios = re.findall(r'<td title="within: d\([^)]+\)/d\(([^)]+)\)[^"]*">([0-9.e+-]+)</td></tr>', table)
    assert [p for p, _ in ratios] == ["points.A.at.0", "constraints.B.si.0", "points.O4.at.0"]
    assert all(0 <= float(r) <= 1 for _, r in ratios)
