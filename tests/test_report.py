"""kinem report: results.json against its schema, the baseline gate on
synthetic regressions, the self-contained HTML, junit.xml, and bad baselines
as input errors. Cases are shortened copies (20 instants); engines are a
fake adapter, run in this process (workers=0)."""
import base64
import dataclasses
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
from adapters.base import Adapter
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
    tolerance = {"position_error_rel": 1e-5, "angle_error": 1e-5}

    def version(self):
        return "fake-1"

    def defaults(self):
        return {"dt": 1e-3}

    def unsupported(self, model):
        return None

    def simulate(self, model, q0, qd0, settings, times):
        from kinem.solver import solve

        r = solve(model)
        q = r.q.copy()
        q[:, 0::3][:, :len(model.body_names)] += settings["dt"] * 1e-3 * model.length
        steps = int(round(model.case.end / settings["dt"]))
        return q, r.qd, r.wall_time, steps


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


def images_decode(html):
    """Every inline image is one data: URI whose bytes are the image it names
    (a doubled prefix or a bad payload shows as a broken picture)."""
    refs = re.findall(r'<img [^>]*src="([^"]*)"', html)
    for ref in refs:
        kind, _, payload = ref.partition(";base64,")
        data = base64.b64decode(payload, validate=True)
        assert data.startswith(b"\x89PNG") if kind == "data:image/png" else data.lstrip().startswith(b"<"), ref[:60]
    return len(refs)


def test_html_is_self_contained_and_lists_every_case(report):
    outcome, out = report
    html = (out / "index.html").read_text()
    assert images_decode(html) >= 2 * 3
    for ref in re.findall(r'(?:src|href)="([^"]*)"', html):   # images inline, links within the page
        assert ref.startswith(("data:image/png;base64,", "data:image/svg+xml;base64,", "#")), ref[:40]
        if ref.startswith("data:image/svg+xml"):                # an SVG plot refers only to itself
            svg = base64.b64decode(ref.partition(",")[2]).decode()
            assert not re.search(r'href="(?!#)|url\((?!#)|@import|<script', svg)
    text = re.sub(r'"data:[^"]*"', "", html)
    assert not re.search(r"[a-z]+://|url\(|@import|<script|<link|<iframe|<foreignObject", text)
    for case in outcome.value.doc["cases"]:
        assert f'id="case-{case["name"]}"' in html
    assert html.count('src="data:image/') >= 2 * 3  # trajectories, errors, work-precision
    # one animation per case, in that case's section: an inline SVG moved by SMIL, no script
    sections = re.split(r'<section id="case-', html)[1:]
    assert len(sections) == len(outcome.value.doc["cases"])
    for part in sections:
        motions = re.findall(r'<svg class="motion".*?</svg>', part, re.S)
        assert sum("<animateTransform" in m for m in motions) == 1, part[:40]
        assert sum("<animateTransform" not in m for m in motions) == 4      # the four snapshots
    md = (out / "summary.md").read_text()
    # the summary matrix: one row per case, one column per engine
    assert md.count("| slider_crank |") == 1 and md.count("| four_bar |") == 1
    assert "| case | native | pymunk |" in md and md.startswith("## kinem report\n\n**PASS: ")
    assert html.count("<tr><th class=l><a href=\"#case-") == 2
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert len(suite.findall("testcase")) == 4 and suite.get("failures") == "0"


def test_unchanged_results_pass_the_gate(report):
    doc = report[0].value.doc
    g = gate(doc, copy.deepcopy(doc), "base.json")
    assert g["findings"] == [] and g["regressions"] == 0
    assert set(g["verdicts"].values()) == {"pass"}
    assert problems(dict(doc, gate=g), SCHEMA) == []


def _regressions(doc, base, **kw):
    g = gate(doc, base, "base.json", **kw)
    return [(f["case"], f["engine"], f["where"], f["kind"], f["metric"]) for f in g["findings"] if f["fatal"]], g


@pytest.mark.parametrize("kind", ["status", "error", "residual", "count", "sweep-error", "sweep-count"])
def test_gate_flags_each_kind_of_regression(report, kind):
    base = report[0].value.doc
    doc = copy.deepcopy(base)
    case = doc["cases"][0]
    native, engine = case["runs"]
    sweep = next(c for c in case["work_precision"]["curves"] if c["engine"] == "pymunk")["points"][0]
    if kind == "status":
        engine.update(status="failed: exploded", outcome="failed")
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
    base = report[0].value.doc
    doc = copy.deepcopy(base)
    native, engine = doc["cases"][0]["runs"]
    native["position_error_rel"] = 0.9 * ERROR_FLOOR        # grew from ~0 but below the floor
    engine["position_error_rel"] *= 0.9 * ERROR_FACTOR      # grew, by less than the factor
    for c in doc["cases"]:          # a loaded machine: every case slower alike, the ratios unchanged
        for r in c["runs"]:
            r["time_per_step"] = (r["time_per_step"] or 0) * 1.1 * SLOWDOWN_FACTOR or None
            r["wall_time"] = max(r["wall_time"] or 0, 1.0)
    for c in base["cases"]:
        for r in c["runs"]:
            r["wall_time"] = max(r["wall_time"] or 0, 1.0)
    found, g = _regressions(doc, base)
    assert found == [] and g["slowdowns"] == 0
    found, _ = _regressions(doc, base, fail_on_slowdown=True)   # asked: native's own time too
    assert sorted((f[1], f[3]) for f in found) == [("native", "slower")] * 2
    engine["time_per_step"] *= 1.1 * SLOWDOWN_FACTOR ** 2        # this case slower than the engine's others
    found, g = _regressions(doc, base)
    assert found == [] and g["slowdowns"] == 1
    assert g["verdicts"][f"{doc['cases'][0]['name']}/pymunk"].startswith("pass, slower")
    found, _ = _regressions(doc, base, fail_on_slowdown=True)
    assert sorted((f[1], f[3]) for f in found) == [("native", "slower")] * 2 + [("pymunk", "slower")]
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
    doc = copy.deepcopy(report[0].value.doc)
    del doc["cases"][0]["runs"][0]["counts"]
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="missing key 'counts'"):
        results.load(p)


def test_import_failure_makes_the_run_fail(tmp_path, fake_engines):
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    out = run(Options(cases=(case,), engines=("pymunk", "exudyn"), out=str(tmp_path / "o"), quick=True,
                      workers=0, progress=False, stress=False))
    runs = {r["engine"]: r for r in out.value.doc["cases"][0]["runs"]}
    assert runs["exudyn"]["status"].startswith("failed: import error")
    assert out.value.doc["engines"]["exudyn"]["status"].startswith("failed: import error")
    assert out.exit_code == 1 and "1 failed" in out.detail


def test_known_engine_failure_passes_a_new_one_fails(report):
    from kinem.report import _exit_code

    base = copy.deepcopy(report[0].value.doc)
    opts = Options(cases=(), engines=("pymunk",))
    base["cases"][0]["runs"][1].update(status="failed: diverged", outcome="diverged")
    assert _exit_code(dict(base, gate=None), opts) == 1          # no baseline: any failure fails
    doc = copy.deepcopy(base)
    doc["gate"] = gate(doc, base, "base.json")                   # the baseline has it too: known
    assert doc["gate"]["findings"] == [] and _exit_code(doc, opts) == 0
    doc["cases"][0]["runs"][0].update(status="failed: no convergence", outcome="failed")   # native: always fatal
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
    assert np.isfinite(report[0].value.doc["duration"])


def test_stress_section(tmp_path):
    """The quick stress suite on native: in results.json (valid against the
    schema), as a table in index.html and a line in summary.md."""
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    out = run(Options(cases=(case,), engines=(), out=str(tmp_path / "o"), quick=True, workers=0, progress=False,
                      stress=True))
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert problems(doc, SCHEMA) == [] and out.exit_code == 0
    assert doc["options"]["stress"] == "--stress"
    assert doc["stress"]["native_misses"] == []
    outcomes = {r["scenario"]: r["outcome"] for r in doc["stress"]["rows"]}
    assert outcomes["slider_dead_centre"] == "singular-detected" and outcomes["change_point"] == "accurate"
    assert "<h2>Stress suite</h2>" in (tmp_path / "o" / "index.html").read_text()
    assert "native met every expectation" in (tmp_path / "o" / "summary.md").read_text()


def test_report_directory_is_consistent_through_its_manifest(report, tmp_path, monkeypatch):
    """manifest.json is written last and lists every file with its hash: a
    report directory is whole only when it matches (docs/report.md). A run
    interrupted part-way (here: the third file's write fails) leaves no
    manifest, so old and new files mixed are not taken for a report."""
    from kinem import report as rep
    from kinem.errors import OutputError

    outcome, out = report
    listed = json.loads((out / "manifest.json").read_text())["files"]
    assert set(listed) == {"results.json", "summary.md", "index.html", "junit.xml"}
    assert rep.complete(out)
    target = tmp_path / "r"
    rep.write_outputs(target, {"results.json": "old", "summary.md": "old", "index.html": "old"})
    assert rep.complete(target)
    real = rep._write

    def failing(path, body):
        if path.name == "index.html":
            raise OutputError(f"{path}: write failed: No space left on device")
        return real(path, body)

    monkeypatch.setattr(rep, "_write", failing)
    with pytest.raises(OutputError):
        rep.write_outputs(target, {"results.json": "new", "summary.md": "new", "index.html": "new"})
    assert (target / "results.json").read_text() == "new" and (target / "index.html").read_text() == "old"
    assert not rep.complete(target)               # the mix is detectable
    (target / "manifest.json").write_text(json.dumps({"files": {"index.html": {"sha256": "0" * 64}}}))
    assert not rep.complete(target)               # a file that does not match its manifest


def test_stress_runs_only_when_asked(report):
    """A report on the user's own case files leaves the stress suite out
    (it runs only with --stress: test_no_summary_cell_... checks a whole set)."""
    doc = report[0].value.doc
    assert "stress" not in doc and doc["options"]["stress"] is None and doc["options"]["whole_set"] is False
    assert "Stress suite" not in (report[1] / "index.html").read_text()


def _narrowed(doc, whole_set=False, quick=False, engines=("pymunk",)):
    return dict(doc, options=dict(doc["options"], whole_set=whole_set, quick=quick, engines=list(engines)))


def test_gate_fails_on_runs_the_baseline_has_and_the_run_lacks(report):
    """No blind spots: a baseline case, engine or sweep point missing from the
    run fails the gate unless the run was narrowed on purpose, and is listed
    in not_compared either way."""
    base = report[0].value.doc
    name = base["cases"][0]["name"]
    fewer_cases = dict(base, cases=base["cases"][1:])
    found, g = _regressions(_narrowed(fewer_cases, whole_set=True), base)   # the whole set, a case gone
    assert [(f[0], f[3]) for f in found] == [(name, "missing")] and g["regressions"] == 1
    found, g = _regressions(_narrowed(fewer_cases), base)                   # case files given: narrowed
    assert found == [] and name in g["not_compared"][0]
    no_engine = copy.deepcopy(base)
    for c in no_engine["cases"]:
        c["runs"] = c["runs"][:1]
        c["work_precision"]["curves"] = c["work_precision"]["curves"][:1]
    found, g = _regressions(_narrowed(no_engine, engines=("pymunk",)), base)   # pymunk was asked for
    assert {(f[1], f[3]) for f in found} == {("pymunk", "missing")}
    assert g["verdicts"][f"{name}/pymunk"].startswith("REGRESSED")
    found, g = _regressions(_narrowed(no_engine, engines=()), base)            # --engines without it
    assert found == [] and any(line.startswith("engine pymunk (--engines)") for line in g["not_compared"])
    fewer_points = copy.deepcopy(base)
    curve = fewer_points["cases"][0]["work_precision"]["curves"][0]
    curve["points"] = curve["points"][1:]
    found, g = _regressions(_narrowed(fewer_points), base)
    assert [f[3] for f in found] == ["missing"]
    found, g = _regressions(_narrowed(fewer_points, quick=True), base)         # --quick: fewer points
    assert found == [] and "work-precision point" in g["not_compared"][0]


def test_non_finite_or_null_baseline_figures_are_rejected(tmp_path, report):
    """A NaN (not JSON, but Python writes it) or a null error of an ok run
    would switch its check off: both are input errors on read."""
    text = results.dumps(report[0].value.doc)
    p = tmp_path / "b.json"
    p.write_text(text.replace('"position_error_rel": ' + json.dumps(report[0].value.doc["cases"][0]["runs"][1]
                                                                    ["position_error_rel"]),
                              '"position_error_rel": NaN', 1))
    assert "NaN" in p.read_text()
    with pytest.raises(InputError, match="non-finite number NaN"):
        results.load(p)
    doc = copy.deepcopy(report[0].value.doc)
    doc["cases"][1]["runs"][0]["angle_error"] = None
    doc["cases"][0]["work_precision"]["curves"][0]["points"][0]["error"] = None
    p.write_text(results.dumps(doc))
    with pytest.raises(InputError, match=r"error is null in an ok point; .*\(\+1 more\)$"):   # one line
        results.load(p)
    assert len(results.missing_figures(doc)) == 2
    assert "angle_error is null in an ok run" in results.missing_figures(doc)[1]
    base = copy.deepcopy(report[0].value.doc)
    base["cases"][0]["runs"][1]["position_error_rel"] = float("nan")   # built in memory: the gate flags it
    found, _ = _regressions(report[0].value.doc, base)
    assert [(f[1], f[4]) for f in found] == [("pymunk", "position_error_rel")]


def test_update_baseline_refuses_null_figures(tmp_path, monkeypatch):
    """An ok run whose figure came out non-finite (stored as null) is not
    written as a baseline: exit 1, the reason in the line, the report kept."""
    import kinem.report.runs as runs

    monkeypatch.setattr(runs, "_finite", lambda x: None)
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    base = tmp_path / "base.json"
    out = run(Options(cases=(case,), engines=(), out=str(tmp_path / "o"), quick=True, workers=0, progress=False,
                      baseline=str(base), update_baseline=True))
    assert out.exit_code == 1 and "baseline NOT written" in out.detail and not base.exists()
    assert (tmp_path / "o" / "index.html").exists()


def test_cli_uses_the_baseline_in_out_by_default(tmp_path):
    """Without --baseline the report gates against OUT/baseline.json when it
    exists, and says so; --baseline none skips it."""
    case = short_case(tmp_path, "slider_crank", 0.1, steps=5)
    out = tmp_path / "out"
    common = (case, "--engines", "native", "--quick", "--jobs", "1", "--out", out)
    code, stdout, err = cli(*common)
    assert code == 0 and "no baseline (none at" in stdout, err
    code, stdout, err = cli(*common, "--update-baseline")
    assert code == 0 and (out / "baseline.json").exists(), err
    code, stdout, err = cli(*common)
    assert code == 0 and "0 regressions" in stdout and "(default; --baseline none to skip)" in stdout, err
    assert json.loads((out / "results.json").read_text())["gate"]["default"] is True
    code, stdout, err = cli(*common, "--baseline", "none")
    assert code == 0 and "no baseline;" in stdout, err


def test_progress_says_what_it_waits_for():
    import io

    from kinem.report.progress import Progress, run_all

    s = io.StringIO()
    p = Progress(2, stream=s, enabled=True)
    assert run_all(abs, [-1, -2], ["first", "second"], workers=0, bar=p) == [1, 2]
    assert "waiting for first" in s.getvalue() and "2/2" in s.getvalue()


def test_native_rows_use_independent_references(report):
    """Native's position error is against kinem.reference's closed form where
    the case has one, and each row says what its figures are against."""
    for case in report[0].value.doc["cases"]:
        native, engine = case["runs"]
        assert native["reference"].startswith(f"closed form kinem.reference.{case['name']}")
        assert engine["reference"] == "native at the reference tolerance"
        # the solver converges far below the case tolerance; 1e-12 L leaves room for rounding in the closed form
        assert native["position_error_rel"] < 1e-12
    html = (report[1] / "index.html").read_text()
    assert "closed form kinem.reference.slider_crank" in html


def test_closed_form_takes_the_case_dimensions_and_needs_its_mechanism(tmp_path):
    """The closed form measures the case's own links (a longer rod still
    matches it); a case named like a repository case that is another
    mechanism gets none (it would compare against the wrong one)."""
    import kinem
    from adapters import references

    def check(path):
        model = kinem.compile(kinem.load(path))
        ref = kinem.solve(model)
        cf = references.closed_form(model, ref)
        return None if cf is None else references.error(model, ref.trajectory, cf).position_rel

    path = short_case(tmp_path, "slider_crank", 0.2)
    Path(path).write_text(Path(path).read_text().replace("si = [300.0, 0.0]", "si = [320.0, 0.0]"))  # longer rod
    assert check(path) < 1e-12          # the case converges to 1e-12 (scaled); rounding of the closed form below
    other = short_case(tmp_path, "four_bar", 0.2)
    Path(path).write_text(Path(other).read_text().replace('name = "four_bar"', 'name = "slider_crank"'))
    assert check(path) is None


def test_equivalent_models_agree_and_are_gated(tmp_path):
    """The quick-return models declare one [equivalent] group: the report
    shows their agreement over time, in results.json and the gate; a member
    without a closed form gets its native row against the group."""
    paths = [short_case(tmp_path, f"quick_return_{k}", 0.3) for k in (1, 2)]
    other = Path(paths[1]).read_text().replace('name = "quick_return_2"', 'name = "shaper_b"')
    Path(paths[1]).write_text(other)                       # no closed form under this name
    out = run(Options(cases=tuple(paths), engines=(), out=str(tmp_path / "o"), quick=True, workers=0,
                      progress=False))
    doc = out.value.doc
    (group,) = doc["equivalence"]
    assert group["group"] == "crank-shaper" and group["cases"] == ["quick_return_1", "shaper_b"]
    assert group["points"] == ["A", "B", "D"] and group["status"] == "ok"
    # two formulations, each converged to 1e-13 (scaled residual): their points agree to rounding
    assert group["max_deviation_rel"] < 1e-10
    runs = {c["name"]: c["runs"][0] for c in doc["cases"]}
    assert runs["quick_return_1"]["reference"].startswith("closed form kinem.reference.quick_return")
    assert runs["shaper_b"]["reference"] == "equivalence group crank-shaper (points A, B, D of quick_return_1)"
    assert runs["shaper_b"]["position_error_rel"] < 1e-10
    html = (tmp_path / "o" / "index.html").read_text()
    assert '<section id="equivalence">' in html and 'alt="agreement of group crank-shaper"' in html
    assert images_decode(html.partition('<section id="equivalence">')[2].partition("</section>")[0]) == 1
    assert "Equivalent models **crank-shaper**" in (tmp_path / "o" / "summary.md").read_text()
    base = copy.deepcopy(doc)
    base["equivalence"][0]["max_deviation_rel"] = group["max_deviation_rel"] / 10 if group["max_deviation_rel"] \
        else 0.0
    doc = copy.deepcopy(doc)
    doc["equivalence"][0]["max_deviation_rel"] = 1e-6                # the models drifted apart
    found, g = _regressions(doc, base)
    assert [(f[0], f[2], f[3]) for f in found] == [("crank-shaper", "equivalence", "error")]
    assert g["verdicts"]["equivalence/crank-shaper"].startswith("REGRESSED")


def test_equivalent_key_is_checked():
    from kinem.case import load_dict

    base = {"name": "x", "time": {"end": 1, "steps": 1}, "bodies": {"g": {"q": [0, 0, 0]}},
            "points": {"P": {"body": "g", "at": [0, 0]}}, "constraints": [{"type": "ground", "body": "g"}]}
    assert load_dict(dict(base, equivalent={"group": "g1", "points": ["P"]})).equivalent.points == ("P",)
    with pytest.raises(InputError, match=r"\[equivalent\]: key 'points': unknown point\(s\) Q"):
        load_dict(dict(base, equivalent={"group": "g1", "points": ["Q"]}))
    with pytest.raises(InputError, match=r"\[equivalent\]: key 'group': missing"):
        load_dict(dict(base, equivalent={"points": ["P"]}))


def test_update_baseline_replaces_a_stale_one(tmp_path):
    """A baseline of another schema version is an input error, except with
    --update-baseline, which rewrites it (the message says to)."""
    case = short_case(tmp_path, "four_bar", 0.1, steps=5)
    base = tmp_path / "base.json"
    base.write_text(json.dumps({"schema_version": 1}))
    opts = dict(cases=(case,), engines=(), out=str(tmp_path / "o"), quick=True, workers=0, progress=False,
                baseline=str(base))
    with pytest.raises(InputError, match="schema_version 1"):
        run(Options(**opts))
    out = run(Options(**opts, update_baseline=True))
    assert out.exit_code == 0 and results.load(base)["schema_version"] == results.SCHEMA_VERSION


def test_cli_scope_stress_and_default_baseline(monkeypatch, tmp_path):
    """kinem report with no case files is the whole case set (stress suite
    on, gate against reports/baseline.json); case files narrow it (no
    stress); --stress, --no-stress and --baseline none say otherwise."""
    import kinem.report
    from kinem import cli as kcli

    seen = []

    class Done:
        line, exit_code = "", 0

    monkeypatch.setattr(kinem.report, "run", lambda o: seen.append(o) or Done())
    monkeypatch.chdir(ROOT)
    kcli.main(["report"])
    kcli.main(["report", "cases/four_bar.toml", "--stress", "--baseline", "none"])
    kcli.main(["report", *sorted(str(p) for p in (ROOT / "cases").glob("*.toml")), "--no-stress",
               "--out", str(tmp_path)])
    whole, mine, listed = seen
    # whole_set is left to the report: the case files given against the baseline's set (test_whole_set_...)
    assert whole.whole_set is None and whole.stress is None and whole.baseline_default
    assert len(whole.cases) == len(list((ROOT / "cases").glob("*.toml")))
    assert Path(whole.baseline) == Path("reports/baseline.json")
    assert mine.whole_set is None and mine.stress is True and mine.baseline is None and not mine.baseline_default
    assert listed.whole_set is None and listed.stress is False and listed.baseline is None   # none in tmp_path
    assert kcli.main(["report", "--stress", "--no-stress"]) == 2


class KnobEngine(FakeEngine):
    """A fake with an accuracy knob besides the step: error dt * 1e-3 *
    (1 + 10 / iterations) of L, stepping cost steps * iterations * 1 us
    (synthetic, so the Pareto front is deterministic)."""
    knobs = {"substeps": (1, 10), "iterations": (1, 3, 10, 20)}

    def defaults(self):
        return {"dt": 1e-3, "substeps": None, "iterations": 3}

    def simulate(self, model, q0, qd0, settings, times):
        from kinem.solver import solve

        r = solve(model)
        q = r.q.copy()
        q[:, 0::3][:, :len(model.body_names)] += settings["dt"] * 1e-3 * (1 + 10 / settings["iterations"]) * model.length
        steps = settings["substeps"] * (len(times) - 1)
        return q, r.qd, steps * settings["iterations"] * 1e-6, steps


@pytest.fixture(scope="module")
def knob_report(tmp_path_factory):
    """A work-precision sweep over the fake's knob families (dt x 10 and 1 in each)."""
    from kinem.report import execute

    tmp = tmp_path_factory.mktemp("knobs")
    mp = pytest.MonkeyPatch()
    mp.setattr(adapters, "get", lambda name: KnobEngine())
    mp.setattr(execute, "QUICK", execute.Sweep(dt_factors=(10.0, 1.0), tolerances=(1e-6,), native_repeats=1,
                                               family_factors=(10.0, 1.0)))
    try:
        out = run(Options(cases=(short_case(tmp, "slider_crank", 0.2),), engines=("pymunk",), out=str(tmp / "out"),
                          quick=True, workers=0, progress=False, stress=False))
    finally:
        mp.undo()
    return out.value.doc, tmp / "out"


def test_work_precision_sweeps_knob_families_and_marks_the_pareto_front(knob_report):
    doc, out = knob_report
    assert problems(doc, SCHEMA) == []
    curves = [c for c in doc["cases"][0]["work_precision"]["curves"] if c["engine"] == "pymunk"]
    # the defaults' family first, then the knob's extremes besides the default (adapters.tune.families)
    assert [c["family"] for c in curves] == [{"iterations": 3}, {"iterations": 1}, {"iterations": 20}]
    points = [p for c in curves for p in c["points"]]
    assert len(points) == 6
    for c in curves:          # every point says which knob values it ran with
        for p in c["points"]:
            assert p["knobs"] == dict(c["family"], dt=pytest.approx(p["value"]))
            # the fake's error law: the knobs recorded are the ones the engine used
            assert p["error"] == pytest.approx(p["value"] * 1e-3 * (1 + 10 / p["knobs"]["iterations"]), rel=1e-6)

    def dominated(p):
        return any(q is not p and q["cost"] <= p["cost"] and q["error"] <= p["error"]
                   and (q["cost"], q["error"]) != (p["cost"], p["error"]) for q in points)

    marked = [p["front"] for p in points]
    assert marked == [not dominated(p) for p in points]
    # not trivial: the front spans families, and some point is off it
    assert 0 < sum(marked) < len(points) and len({p["knobs"]["iterations"] for p in points if p["front"]}) > 1
    assert "Pareto" in (out / "index.html").read_text()


def test_gate_matches_points_by_their_full_knob_setting(knob_report):
    doc = knob_report[0]
    found, g = _regressions(doc, doc)
    assert found == [] and not g["not_compared"]
    # a family gone: its points are missing, named by dt and the knob
    fewer = copy.deepcopy(doc)
    wp = fewer["cases"][0]["work_precision"]
    wp["curves"] = [c for c in wp["curves"] if c.get("family") != {"iterations": 1}]
    found, _ = _regressions(_narrowed(fewer), doc)
    assert len(found) == 2 and all(f[3] == "missing" and "iterations=1" in f[2] and "dt=" in f[2] for f in found)
    # a baseline written before the knob families (dt-only points, no knobs): its points are the
    # defaults' family (the baseline's main-run settings), compared as such; the new families are not missing
    legacy = copy.deepcopy(doc)
    wp = legacy["cases"][0]["work_precision"]
    wp["curves"] = [c for c in wp["curves"] if c["engine"] == "native" or c["family"] == {"iterations": 3}]
    for c in wp["curves"]:
        c.pop("family")
        for p in c["points"]:
            p.pop("knobs"), p.pop("front")
    found, g = _regressions(doc, legacy)
    assert found == [] and not g["not_compared"]
    bad = copy.deepcopy(legacy)
    bad["cases"][0]["work_precision"]["curves"][-1]["points"][0]["error"] /= 1e3   # so they were compared
    found, _ = _regressions(doc, bad)
    assert [(f[1], f[3]) for f in found] == [("pymunk", "error")] and "iterations=3" in found[0][2]


@pytest.mark.parametrize("edit", ["status OK", "status empty", "counts empty", "counts renamed", "point counts",
                                  "engine status", "outcome", "outcome against status"])
def test_edited_baselines_are_rejected(tmp_path, report, edit):
    """Issue 25 item 6: an edited status or count keys would switch the gate
    off (an unknown status ranked as failed, its figures never compared; no
    counts, no count check): each is an input error in one line."""
    doc = copy.deepcopy(report[0].value.doc)
    native = doc["cases"][0]["runs"][0]
    if edit == "status OK":
        native["status"] = "OK"
    elif edit == "status empty":
        native["status"] = ""
    elif edit == "counts empty":
        native["counts"] = {}
    elif edit == "counts renamed":
        native["counts"]["jacobians"] = native["counts"].pop("jacobian_evaluations")
    elif edit == "point counts":
        doc["cases"][0]["work_precision"]["curves"][0]["points"][0]["counts"] = {"steps": 1}
    elif edit == "engine status":
        doc["engines"]["pymunk"]["status"] = "fine"
    elif edit == "outcome":
        native["outcome"] = "OK"
    else:                          # a failed run edited to look ok by its outcome alone
        doc["cases"][0]["runs"][1].update(status="failed: diverged", outcome="ok")
    p = tmp_path / "b.json"
    p.write_text(results.dumps(doc))
    with pytest.raises(InputError) as e:
        results.load(p)
    assert "\n" not in str(e.value) and any(w in str(e.value) for w in ("status", "counts", "outcome"))
    # the untouched document loads, and a real regression in it is caught
    p.write_text(results.dumps(report[0].value.doc))
    base = results.load(p)
    now = copy.deepcopy(base)
    now["cases"][0]["runs"][0]["counts"]["jacobian_evaluations"] += 249
    found, _ = _regressions(now, base)
    assert [(f[1], f[3], f[4]) for f in found] == [("native", "count", "jacobian_evaluations")]


def test_whole_set_run_fails_on_runs_the_baseline_lacks(report):
    """Issue 25 item 6: in a run of the whole case set, a run present now and
    missing from the baseline fails the gate; a narrowed run only lists it."""
    doc = report[0].value.doc
    base = copy.deepcopy(doc)
    del base["cases"][0]["runs"][1]
    found, g = _regressions(doc, base)
    assert found == [] and g["verdicts"][f"{doc['cases'][0]['name']}/pymunk"] == "new"
    whole = _narrowed(doc, whole_set=True, engines=("pymunk", "mujoco", "exudyn"))
    found, g = _regressions(whole, base, scope=gate_scope())
    assert [(f[1], f[3]) for f in found] == [("pymunk", "new")]
    assert g["verdicts"][f"{doc['cases'][0]['name']}/pymunk"].startswith("REGRESSED")


def gate_scope():
    from kinem.report.gate import Scope

    return Scope()


def test_case_edit_makes_the_baseline_stale(tmp_path):
    """A 1 mm edit of a link (the case is in metres) changes the case's fingerprint: the gate says
    "case changed: baseline stale" naming the case, and fails."""
    from kinem.case import load
    from kinem.fingerprint import fingerprint

    path = short_case(tmp_path, "four_bar", 0.1, steps=5)
    text = Path(path).read_text()
    before = fingerprint(load(path))
    assert fingerprint(load(path)) == before                    # deterministic
    Path(path).write_text(text.replace("description", "# a comment\ndescription", 1))
    assert fingerprint(load(path)) == before                    # comments and layout are not the case
    edited = re.sub(r"(\bsi\s*=\s*\[\s*)(-?[0-9.]+)", lambda m: f"{m[1]}{float(m[2]) + 0.001}", text, count=1)
    assert edited != text
    Path(path).write_text(edited)
    assert fingerprint(load(path)) != before


def test_gate_sees_a_case_edit_and_a_moved_trajectory(report):
    """The gate fails on a changed fingerprint (case named) and on native's
    compact trajectory moving by 1e-9 L (case, quantity and size named),
    though no figure moved; an engine moving within its tolerance passes."""
    base = report[0].value.doc
    name = base["cases"][0]["name"]
    doc = copy.deepcopy(base)
    doc["cases"][0]["fingerprint"] = "0" * 16
    found, g = _regressions(doc, base)
    assert [(f[0], f[3]) for f in found] == [(name, "stale")]
    assert f"case {name} changed: baseline stale" in g["findings"][0]["message"]
    doc = copy.deepcopy(base)
    native, engine = doc["cases"][0]["runs"]
    column = next(c for c in native["trajectory"]["columns"] if c.endswith(".x"))
    native["trajectory"]["columns"][column][3] += 1e-9 * doc["cases"][0]["length"]
    found, g = _regressions(doc, base)
    assert [(f[0], f[1], f[3], f[4]) for f in found] == [(name, "native", "trajectory", column)]
    message = g["findings"][0]["message"]
    assert name in message and column in message and "1.00e-09 L" in message
    doc = copy.deepcopy(base)
    native = doc["cases"][0]["runs"][0]
    phi = next(c for c in native["trajectory"]["columns"] if c.endswith(".phi"))
    native["trajectory"]["columns"][phi][-1] += 2e-12                # angles: rad, same limit
    assert [f[4] for f in _regressions(doc, base)[0]] == [phi]
    doc = copy.deepcopy(base)
    engine = doc["cases"][0]["runs"][1]
    column = next(c for c in engine["trajectory"]["columns"] if c.endswith(".y"))
    engine["trajectory"]["columns"][column][2] += 1e-9 * doc["cases"][0]["length"]
    assert _regressions(doc, base)[0] == []                      # an engine: its tolerance
    engine["trajectory"]["columns"][column][2] += 1e-3 * doc["cases"][0]["length"]
    assert [f[3] for f in _regressions(doc, base)[0]] == ["trajectory"]


def test_no_summary_cell_compares_native_with_itself_silently(tmp_path):
    """A case without a closed form or equivalence group: native's cell says
    "no independent reference" (in summary.md and index.html), never a
    figure of native against itself."""
    from kinem.report.text import SELF

    case = short_case(tmp_path, "gear_pair", 0.1, steps=5)
    text = Path(case).read_text().replace('name = "gear_pair"', 'name = "gears"')   # no closed form under this name
    Path(case).write_text(text)
    out = run(Options(cases=(case,), engines=(), out=str(tmp_path / "o"), quick=True, workers=0, progress=False,
                      whole_set=True))   # stress None (the CLI's default): no stress suite, even for a whole set
    assert "stress" not in out.value.doc and out.value.doc["options"]["stress"] is None
    md = (tmp_path / "o" / "summary.md").read_text()
    row = next(line for line in md.splitlines() if line.startswith("| gears |"))
    assert SELF in row and "e+00" not in row and "e-" not in row
    html = (tmp_path / "o" / "index.html").read_text()
    cell = re.search(r'<a href="#case-gears">gears</a></th><td[^>]*>(.*?)</td>', html).group(1)
    assert SELF in cell and "e+00" not in cell
    assert out.value.doc["cases"][0]["runs"][0]["reference"].startswith("native")


def test_summary_figure_is_the_worst_moving_coordinate(report):
    """The summary figure is the worst of positions / L and angles (rad): a
    gear pair's engines, whose origins do not move, show their angle error;
    an out-of-tolerance cell names the metric, its value and its limit; the
    cost is per output interval with the engine steps beside it."""
    from kinem.report.text import _md_cell, figure

    engine = copy.deepcopy(report[0].value.doc["cases"][0]["runs"][1])
    engine.update(position_error_rel=0.0, angle_error=1.2e-10)
    assert figure(engine) == (1.2e-10, "angle, rad")
    engine.update(angle_error=1e-3, within_tolerance=False, tolerance={"angle_error": 1e-6}, verdict="outside tolerance")
    cell = _md_cell((engine, ("pass", "pass"), "warn"))
    assert "1.0e-03 (angle, rad)" in cell and "angle_error 1.00e-03 > 1e-06" in cell
    assert "µs/interval (200 steps)" not in cell and "µs/interval (" in cell
    native = report[0].value.doc["cases"][0]["runs"][0]
    assert figure(native)[1] == "position / L" and native["reference"].startswith("closed form")


def test_animation_label_says_slowed_or_faster():
    """The loop plays the run's span in dur seconds: slowed when longer."""
    from kinem.report.motion import speed_label

    assert speed_label(4.0, 2.5) == "slowed x1.6"
    assert speed_label(12.0, 30.0) == "x2.5 faster"
    assert speed_label(5.0, 5.0) == "real time"


def test_work_precision_is_asked_by_the_case_or_the_flag(tmp_path):
    """[report] work_precision = true sweeps a case; --work-precision every
    case; neither: none (no list of case names in the code)."""
    from kinem.case import load, loads
    from kinem.report.execute import FULL, wants_sweep

    plain = load(short_case(tmp_path, "gear_pair", 0.1, steps=5))
    asked = load(short_case(tmp_path, "four_bar", 0.1, steps=5))
    assert asked.report["work_precision"] is True and not wants_sweep(plain, FULL)
    assert wants_sweep(asked, FULL) and wants_sweep(plain, dataclasses.replace(FULL, every_case=True))
    text = (ROOT / "cases" / "gear_pair.toml").read_text() + "\n[report]\nwork_precision = 1\n"
    with pytest.raises(InputError, match="work_precision.*true or false"):
        loads(text)


def test_gate_verdicts_are_typed(report):
    """The report reads a verdict's kind (gate.Verdict), never its sentence:
    a regressed kind is red whatever the sentence says; the schema allows
    only the enum's values."""
    from kinem.report.gate import Verdict
    from kinem.report.text import matrix

    base = report[0].value.doc
    doc = copy.deepcopy(base)
    doc["cases"][0]["runs"][0]["counts"]["newton_iterations"] += 1
    g = gate(doc, base, "base.json")
    key = f"{doc['cases'][0]['name']}/native"
    assert g["kinds"][key] == Verdict.REGRESSED.value and set(g["kinds"].values()) <= {v.value for v in Verdict}
    g["verdicts"][key] = "pass"                      # the sentence edited: the kind still decides
    _, rows, _ = matrix(dict(doc, gate=g))
    cells = next(c for case, c in rows if case["name"] == key.split("/")[0])
    assert cells["native"][2] == "bad"
    g["kinds"][key] = "fine"
    assert any("kinds" in p for p in problems(dict(doc, gate=g), SCHEMA))


def test_one_outcome_type(report, tmp_path):
    """A report, a streamed solve and a stress scenario end in the same
    Outcome class; its status is a member of a kinem.outcome.Kind enum with
    its message, and a failure is exit code 1."""
    import kinem
    from kinem import stream, stress
    from kinem.outcome import Kind, Outcome

    solved = stream.run(kinem.compile(kinem.load(short_case(tmp_path, "four_bar", 0.1, steps=5))), ("positions",),
                        lambda r: None)
    scenario = next(s for s in stress.scenarios(quick=True) if s.name == "change_point")
    outcomes = [report[0], solved, stress.run_one((scenario, "native"))]
    assert [type(o) for o in outcomes] == [Outcome] * 3
    assert all(isinstance(o.status, Kind) and o.status.message for o in outcomes)
    assert [o.status.value for o in outcomes] == ["ok", "solved", "accurate"]
    assert [o.exit_code for o in outcomes] == [0, 0, 0]
    assert solved.message == "all instants solved" and solved.value.instants == 6
    assert stream.Run.STOPPED.failure and Outcome(stream.Run.STOPPED, "why").exit_code == 1


def _native(doc):
    return doc["cases"][0]["runs"][0]


def test_reference_kind_decides_not_the_label(report):
    """Whether native has an independent reference is its reference_kind
    (kinem.report.runs.Reference), whatever the label says."""
    from kinem.report.html import index_html
    from kinem.report.runs import Reference
    from kinem.report.text import SELF, figure

    doc = copy.deepcopy(report[0].value.doc)
    native = _native(doc)
    native.update(reference="closed form kinem.reference.slider_crank (edited)", reference_kind="native")
    assert figure(native) == (None, SELF)
    native.update(reference="something else", reference_kind=Reference.CLOSED_FORM.value)
    assert figure(native)[1] == "position / L" and "ᶜ" in index_html(doc, {})
    native["reference_kind"] = "closed form"
    assert any("reference_kind" in p for p in problems(doc, SCHEMA))


@pytest.mark.parametrize("status, detail, shown, bad", [
    ("one-case", "", "not compared: one case of the group in this run", False),
    ("no-shared-point", "", "failed: the cases share no named point", True),
    ("no-reference", "b, c", "failed: no reference solution of b, c", True)])
def test_equivalence_status_is_typed(report, status, detail, shown, bad):
    """A group's status is an Agreement value in JSON, shown with its message
    in index.html (red when it is a failure) and summary.md."""
    from kinem.report import equivalence

    doc = copy.deepcopy(report[0].value.doc)
    doc["equivalence"] = [{"group": "g", "cases": ["a", "b", "c"], "points": [], "reference": equivalence.LABEL,
                           "length": 1.0, "members": [], "max_deviation_rel": None, "status": status,
                           "detail": detail}]
    assert problems(doc, SCHEMA) == []
    doc = json.loads(results.dumps(doc))                     # through JSON
    assert equivalence.Agreement(doc["equivalence"][0]["status"]).failure is bad
    html = equivalence.html(doc, {})
    assert f"<td class='l {'bad' if bad else ''}'>{shown}</td>" in html
    assert f"; {shown}" in equivalence.line(doc)
    doc["equivalence"][0]["status"] = "failed: the cases share no named point"   # the old free text
    assert any("status" in p for p in problems(doc, SCHEMA))


def test_stress_outcomes_render_with_their_messages(report):
    """Stress rows in results.json carry their Class's value; index.html
    shows each with its message (red for a failure), summary.md counts them."""
    from kinem import stress
    from kinem.outcome import Outcome
    from kinem.report.stress_section import html, line

    rows = [Outcome(stress.Class.ACCURATE, "3 steps", stress.Row("g", "s1", "pymunk", 1e-9, 1e-12, 0.1)),
            Outcome(stress.Class.INACCURATE, "velocity_error_rel 2.00e-04 > 1e-05",
                    stress.Row("g", "s2", "pymunk", 1e-9, 1e-12, 0.1, (("velocity_error_rel", 2e-4, 1e-5),))),
            Outcome(stress.Class.UNSUPPORTED, "gear: no gear joint", stress.Row("g", "s3", "pymunk", *[float("nan")] * 2, 0.0))]
    doc = copy.deepcopy(report[0].value.doc)
    doc["stress"] = {"quick": True, "rows": results.clean([stress.as_dict(o) for o in rows]), "native_misses": []}
    assert problems(doc, SCHEMA) == []
    doc = json.loads(results.dumps(doc))
    assert [stress.from_dict(r).status for r in doc["stress"]["rows"]] == [o.status for o in rows]
    page = html(doc)
    assert 'title="within its tolerance: 3 steps">accurate 1e-09</td>' in page
    assert ('<td class=bad title="a figure outside its tolerance: velocity_error_rel 2.00e-04 &gt; 1e-05">'
            "inaccurate vel 2e-04</td>") in page
    assert 'title="the engine cannot represent the scenario: gear: no gear joint">unsupported</td>' in page
    assert line(doc).endswith("engines: 1 accurate, 1 inaccurate, 1 unsupported")
    doc["stress"]["rows"][2]["outcome"] = "unsupported: gear"          # the old free text
    assert any("outcome" in p for p in problems(doc, SCHEMA))


def test_unsupported_runs_are_grouped_by_their_typed_reason(tmp_path, monkeypatch):
    """Two cases that an engine cannot represent for the same reason, on
    constraints of different names, share one line under the matrix, read
    from each run's typed reason ([constraint type, why]; adapters.base.Reason),
    not from its text: the line names the type, the why and both cases, and
    neither constraint's name."""
    import kinem
    from adapters.base import Reason

    class Refuses(FakeEngine):
        def unsupported(self, model):
            driver = next(c for c in model.case.constraints if c.type == "driver")
            return Reason("driver", driver.name, "not this engine's kind of drive (test)")

    monkeypatch.setattr(adapters, "get", lambda name: Refuses())
    cases = (short_case(tmp_path, "slider_crank", 0.2), short_case(tmp_path, "four_bar", 0.2))
    run(Options(cases=cases, engines=("pymunk",), out=str(tmp_path / "out"), quick=True, workers=0, progress=False,
                stress=False))
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    reasons = [r["reason"] for c in doc["cases"] for r in c["runs"] if r["engine"] == "pymunk"]
    assert reasons == [["driver", "not this engine's kind of drive (test)"]] * 2
    names = [next(c.name for c in kinem.load(p).constraints if c.type == "driver") for p in cases]
    line = next(x for x in (tmp_path / "out" / "summary.md").read_text().splitlines() if x.startswith("- **pymunk**"))
    assert "driver: not this engine's kind of drive (test) (slider_crank, four_bar)" in line, line
    assert not any(n in line for n in names), (names, line)


def test_a_manifest_that_is_a_link_is_written_through_not_removed(tmp_path, monkeypatch):
    """A manifest.json that is the user's symbolic link stays a link: the
    report empties it through the link while it writes (no whole report
    meanwhile) and writes the new manifest through it last (it was
    removed, and a regular file written in its place)."""
    from kinem import report as rep

    out, elsewhere = tmp_path / "r", tmp_path / "kept"
    out.mkdir()
    elsewhere.mkdir()
    (elsewhere / "manifest.json").write_text("theirs")
    (out / "manifest.json").symlink_to(elsewhere / "manifest.json")
    seen = []
    real = rep._write

    def watching(path, body):
        seen.append((path.name, (elsewhere / "manifest.json").read_text()))
        return real(path, body)

    monkeypatch.setattr(rep, "_write", watching)
    rep.write_outputs(out, {"results.json": "new", "summary.md": "new", "index.html": "new"})
    assert (out / "manifest.json").is_symlink() and rep.complete(out)
    assert json.loads((elsewhere / "manifest.json").read_text())["files"].keys() == {"results.json", "summary.md",
                                                                                      "index.html"}
    assert [text for name, text in seen if name == "results.json"] == ["{}\n"]   # emptied before the files
