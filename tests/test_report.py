"""kinem report: results.json against its schema, the baseline gate on
synthetic regressions, the self-contained HTML, junit.xml, and bad baselines
as input errors. Cases are shortened copies (20 instants); engines are a
fake adapter, run in this process (workers=0)."""
import base64
import copy
import json
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import adapters
from adapters.base import Adapter, EngineRun
from kinem.errors import InputError
from kinem.report import Options, results, run
from kinem.report.gate import ERROR_FACTOR, ERROR_FLOOR, SLOWDOWN_FACTOR, gate
from kinem.report.schema import SCHEMA, problems

ROOT = Path(__file__).resolve().parents[1]


def short_case(tmp_path, name, end, steps=20):
    text = (ROOT / "cases" / f"{name}.toml").read_text()
    text = re.sub(r"\[time\][^\[]*", f"[time]\nend = {end}\nsteps = {steps}\n\n", text, count=1)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return str(path)


class FakeEngine(Adapter):
    """The native solution moved by dt * 1e-3 L in x: errors grow with dt."""
    name = "pymunk"

    def version(self):
        return "fake-1"

    def defaults(self):
        return {"dt": 1e-3}

    def unsupported(self, model):
        return None

    def run(self, model, q0, qd0, settings=None):
        from kinem.analysis import solve
        from kinem.result import trajectory

        r = solve(model)
        q = r.q.copy()
        q[:, 0::3][:, :len(model.body_names)] += settings["dt"] * 1e-3 * model.length
        steps = int(round(model.case.end / settings["dt"]))
        return EngineRun("pymunk", "ok", trajectory(model, r.trajectory.t, q, r.qd), q, r.qd, r.wall_time,
                         steps, 1, dict(settings), "fake-1")


@pytest.fixture
def fake_engines(monkeypatch):
    def get(name):
        if name == "pymunk":
            return FakeEngine()
        raise ImportError(f"no module named {name}_sim (test)")

    monkeypatch.setattr(adapters, "get", get)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """One quick in-process report of two short cases with the fake engine."""
    tmp = tmp_path_factory.mktemp("report")
    mp = pytest.MonkeyPatch()
    mp.setattr(adapters, "get", lambda name: FakeEngine())
    try:
        cases = (short_case(tmp, "slider_crank", 0.2), short_case(tmp, "four_bar", 0.2))
        out = run(Options(cases=cases, engines=("pymunk",), out=str(tmp / "out"), quick=True, junit=True,
                          workers=0, progress=False, stress=False))
    finally:
        mp.undo()
    return out, tmp / "out"


def test_results_validate_against_schema(report):
    outcome, out = report
    doc = json.loads((out / "results.json").read_text())
    assert problems(doc, SCHEMA) == []
    assert doc["schema_version"] == results.SCHEMA_VERSION == SCHEMA["properties"]["schema_version"]["const"]
    assert outcome.exit_code == 0
    assert doc["machine"]["cores"] >= 1 and "numpy" in doc["machine"]["packages"]
    assert doc["engines"]["pymunk"]["version"] == "fake-1"
    case = doc["cases"][0]
    assert [r["engine"] for r in case["runs"]] == ["native", "pymunk"]
    assert case["runs"][0]["counts"]["newton_iterations"] > 0 and case["runs"][1]["counts"]["steps"] == 200
    # the fake's error is dt * 1e-3 (relative to L) at every instant
    assert case["runs"][1]["position_error_rel"] == pytest.approx(1e-6, rel=1e-6)
    curves = {c["engine"]: c for c in case["work_precision"]["curves"]}
    assert len(curves["native"]["points"]) >= 4 and len(curves["pymunk"]["points"]) >= 4
    errs = [p["error"] for p in curves["pymunk"]["points"]]
    assert errs == sorted(errs)                   # sorted by dt, error grows with dt
    # a schema violation is caught by the checker
    bad = copy.deepcopy(doc)
    del bad["cases"][0]["runs"][0]["status"]
    bad["machine"]["cores"] = "two"
    assert len(problems(bad, SCHEMA)) == 2


def test_html_is_self_contained_and_lists_every_case(report):
    outcome, out = report
    html = (out / "index.html").read_text()
    for ref in re.findall(r'(?:src|href)="([^"]*)"', html):   # images inline, links within the page
        assert ref.startswith(("data:image/png;base64,", "data:image/svg+xml;base64,", "#")), ref[:40]
        if ref.startswith("data:image/svg+xml"):                # an SVG plot refers only to itself
            svg = base64.b64decode(ref.partition(",")[2]).decode()
            assert not re.search(r'href="(?!#)|url\((?!#)|@import|<script', svg)
    text = re.sub(r'"data:[^"]*"', "", html)
    assert not re.search(r"[a-z]+://|url\(|@import|<script|<link|<iframe|<foreignObject", text)
    for case in outcome.doc["cases"]:
        assert f'id="case-{case["name"]}"' in html
    assert html.count('src="data:image/') >= 2 * 3  # trajectories, errors, work-precision
    # one animation per case, in that case's section: an inline SVG moved by SMIL, no script
    sections = re.split(r'<section id="case-', html)[1:]
    assert len(sections) == len(outcome.doc["cases"])
    for part in sections:
        motions = re.findall(r'<svg class="motion".*?</svg>', part, re.S)
        assert sum("<animateTransform" in m for m in motions) == 1, part[:40]
        assert sum("<animateTransform" not in m for m in motions) == 4      # the four snapshots
    md = (out / "summary.md").read_text()
    assert md.count("| slider_crank |") == 2 and md.count("| four_bar |") == 2
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert len(suite.findall("testcase")) == 4 and suite.get("failures") == "0"


def test_unchanged_results_pass_the_gate(report):
    doc = report[0].doc
    g = gate(doc, copy.deepcopy(doc), "base.json")
    assert g["findings"] == [] and g["regressions"] == 0
    assert set(g["verdicts"].values()) == {"pass"}
    assert problems(dict(doc, gate=g), SCHEMA) == []


def _regressions(doc, base, **kw):
    g = gate(doc, base, "base.json", **kw)
    return [(f["case"], f["engine"], f["where"], f["kind"], f["metric"]) for f in g["findings"] if f["fatal"]], g


@pytest.mark.parametrize("kind", ["status", "error", "residual", "count", "sweep-error", "sweep-count"])
def test_gate_flags_each_kind_of_regression(report, kind):
    base = report[0].doc
    doc = copy.deepcopy(base)
    case = doc["cases"][0]
    native, engine = case["runs"]
    sweep = next(c for c in case["work_precision"]["curves"] if c["engine"] == "pymunk")["points"][0]
    if kind == "status":
        engine["status"] = "failed: exploded"
        expect = ("engine", "main", "status")
    elif kind == "error":
        engine["angle_error"] = (ERROR_FACTOR + 1) * max(engine["angle_error"], ERROR_FLOOR)
        expect = ("engine", "main", "error")
    elif kind == "residual":
        native["constraint_residual"] = 1e-9
        expect = ("native", "main", "error")
    elif kind == "count":
        native["counts"]["newton_iterations"] += 1
        expect = ("native", "main", "count")
    elif kind == "sweep-error":
        sweep["error"] *= 10
        expect = ("engine", "dt", "error")
    else:
        sweep["counts"]["steps"] += 1
        expect = ("engine", "dt", "count")
    found, g = _regressions(doc, base)
    assert len(found) == 1, found
    (name, engine_name, where, k, _), = found
    assert name == case["name"] and k == expect[2] and where.startswith(expect[1])
    assert engine_name == ("native" if expect[0] == "native" else "pymunk")
    assert g["verdicts"][f"{name}/{engine_name}"].startswith("REGRESSED")


def test_gate_tolerates_noise_and_flags_slowdowns_only_on_request(report):
    base = report[0].doc
    doc = copy.deepcopy(base)
    native, engine = doc["cases"][0]["runs"]
    native["position_error_rel"] = 0.9 * ERROR_FLOOR        # grew from ~0 but below the floor
    engine["position_error_rel"] *= 0.9 * ERROR_FACTOR      # grew, by less than the factor
    for r in (native, engine):
        r["time_per_step"] *= 1.1 * SLOWDOWN_FACTOR
        r["wall_time"] = max(r["wall_time"], 1.0)
    for r in base["cases"][0]["runs"]:
        r["wall_time"] = max(r["wall_time"], 1.0)
    found, g = _regressions(doc, base)
    assert found == [] and g["slowdowns"] == 2
    found, _ = _regressions(doc, base, fail_on_slowdown=True)
    assert {f[3] for f in found} == {"slower"} and len(found) == 2
    # a case or engine the baseline lacks is new, never a regression
    nb = copy.deepcopy(base)
    nb["cases"] = nb["cases"][1:]
    found, g = _regressions(doc, nb)
    assert found == [] and g["verdicts"][f"{doc['cases'][0]['name']}/native"] == "new"


def test_missing_or_corrupt_baseline_is_an_input_error(tmp_path, report):
    with pytest.raises(InputError, match="no such file"):
        results.load(tmp_path / "none.json")
    p = tmp_path / "b.json"
    p.write_text("{not json")
    with pytest.raises(InputError, match="not JSON"):
        results.load(p)
    p.write_text(json.dumps({"schema_version": 99}))
    with pytest.raises(InputError, match="schema_version 99"):
        results.load(p)
    doc = copy.deepcopy(report[0].doc)
    del doc["cases"][0]["runs"][0]["counts"]
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="missing key 'counts'"):
        results.load(p)


def test_import_failure_makes_the_run_fail(tmp_path, fake_engines):
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    out = run(Options(cases=(case,), engines=("pymunk", "exudyn"), out=str(tmp_path / "o"), quick=True,
                      workers=0, progress=False, stress=False))
    runs = {r["engine"]: r for r in out.doc["cases"][0]["runs"]}
    assert runs["exudyn"]["status"].startswith("failed: import error")
    assert out.doc["engines"]["exudyn"]["status"].startswith("failed: import error")
    assert out.exit_code == 1 and "1 failed" in out.line


def test_known_engine_failure_passes_a_new_one_fails(report):
    from kinem.report import _exit_code

    base = copy.deepcopy(report[0].doc)
    opts = Options(cases=(), engines=("pymunk",))
    base["cases"][0]["runs"][1]["status"] = "failed: diverged"
    assert _exit_code(dict(base, gate=None), opts) == 1          # no baseline: any failure fails
    doc = copy.deepcopy(base)
    doc["gate"] = gate(doc, base, "base.json")                   # the baseline has it too: known
    assert doc["gate"]["findings"] == [] and _exit_code(doc, opts) == 0
    doc["cases"][0]["runs"][0]["status"] = "failed: no convergence"   # native: always fatal
    doc["gate"] = gate(doc, base, "base.json")
    assert _exit_code(doc, opts) == 1


def cli(*args):
    p = subprocess.run([sys.executable, "-m", "kinem", "report", "--no-stress", *map(str, args)], capture_output=True,
                       text=True, cwd=ROOT)
    return p.returncode, p.stdout, p.stderr


def test_cli_gate_round_trip(tmp_path):
    """--update-baseline writes a baseline; an unchanged rerun passes; a
    baseline with fewer Newton iterations makes the rerun a regression (exit 1);
    a corrupt one is a one-line input error (exit 2) that writes nothing."""
    case = short_case(tmp_path, "slider_crank", 0.1, steps=5)
    out, base = tmp_path / "out", tmp_path / "base.json"
    common = (case, "--engines", "native", "--quick", "--jobs", "1", "--out", out, "--baseline", base)
    code, stdout, err = cli(*common, "--update-baseline")
    assert code == 0, err
    assert len(stdout.strip().splitlines()) == 1 and base.exists()
    code, stdout, err = cli(*common, "--junit")
    assert code == 0, err + stdout
    doc = json.loads(base.read_text())
    doc["cases"][0]["runs"][0]["counts"]["newton_iterations"] -= 1
    base.write_text(json.dumps(doc))
    code, stdout, err = cli(*common, "--junit")
    assert code == 1 and "1 regressions" in stdout
    assert "### Regressions (1)" in (out / "summary.md").read_text()
    assert ET.parse(out / "junit.xml").getroot().find("testsuite").get("failures") == "1"
    base.write_text("]")
    fresh = tmp_path / "fresh"
    code, stdout, err = cli(case, "--engines", "native", "--out", fresh, "--baseline", base)
    assert code == 2 and err.count("\n") == 1 and "not JSON" in err and "Traceback" not in err
    assert not fresh.exists()


def test_progress_is_silent_off_a_terminal():
    import io

    from kinem.report.progress import Progress

    s = io.StringIO()
    p = Progress(3, stream=s)
    p.step("x")
    p.close()
    assert s.getvalue() == ""
    p = Progress(3, stream=s, enabled=True)
    p.step("case native")
    assert "1/3" in s.getvalue()


def test_numbers_in_results_are_finite(report):
    text = (report[1] / "results.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert np.isfinite(report[0].doc["duration"])


def test_stress_section(tmp_path):
    """The quick stress suite on native: in results.json (valid against the
    schema), as a table in index.html and a line in summary.md."""
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    out = run(Options(cases=(case,), engines=(), out=str(tmp_path / "o"), quick=True, workers=0, progress=False))
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert problems(doc, SCHEMA) == [] and out.exit_code == 0
    assert doc["stress"]["native_misses"] == []
    outcomes = {r["scenario"]: r["outcome"] for r in doc["stress"]["rows"]}
    assert outcomes["slider_dead_centre"] == "singular-detected" and outcomes["change_point"] == "accurate"
    assert "<h2>Stress suite</h2>" in (tmp_path / "o" / "index.html").read_text()
    assert "native met every expectation" in (tmp_path / "o" / "summary.md").read_text()
