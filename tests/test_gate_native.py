"""Issue 29: when kinem itself moves, the gate says so. On a small user
repository (a Watt II six-bar from tests/data, a rack-and-pinion and a cam
from cases/, copied into a folder not named cases/), an error injected into native's answer (a
patched solver in this process: the report runs with one job, in-process)
fails the gate as a regression of native on every case, the cam included,
naming native and the column, with the engines' cells consistent; one
verdict rule for compare, report and JUnit; edited baselines exit 2 in one
line; a solver-settings edit is compared, not called stale."""
import copy
import dataclasses
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import kinem.solver
from kinem import cli
from kinem.report import Options, results, run, runs
from kinem.result import Trajectory

ROOT = Path(__file__).resolve().parents[1]
CASES = ("watt2", "rack_pinion", "cam_roller_circle")
ENGINES = ("pymunk", "mujoco", "exudyn")
SUFFIXES = {"velocities": (".vx", ".vy", ".omega"), "accelerations": (".ax", ".ay", ".alpha"),
            "positions": (".x", ".y", ".phi")}


def user_repo(tmp, end=0.5, steps=50):
    """The three cases (a six-bar, a rack-and-pinion, a cam), shortened, in tmp/mech (not a folder named cases/)."""
    folder = tmp / "mech"
    folder.mkdir(exist_ok=True)
    paths = []
    for name in CASES:
        source = ROOT / "cases" / f"{name}.toml"
        text = (source if source.exists() else ROOT / "tests" / "data" / f"{name}.toml").read_text()
        text = re.sub(r"\[time\][^\[]*", f"[time]\nend = {end}\nsteps = {steps}\n\n", text, count=1)
        path = folder / f"{name}.toml"
        path.write_text(text)
        paths.append(str(path))
    return tuple(paths)


def report(paths, out, baseline=None, update=False, **kw):
    runs.reference.cache_clear()   # the reference is cached per case file: solve it again (patched or not)
    return run(Options(cases=paths, engines=ENGINES, out=str(out), baseline=baseline, update_baseline=update,
                       quick=True, junit=True, workers=0, progress=False, stress=False, **kw))


@pytest.fixture(scope="module")
def repo(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("user")
    paths = user_repo(tmp)
    base = tmp / "baseline.json"
    out = report(paths, tmp / "clean", str(base), update=True)
    assert out.exit_code == 0, out.detail
    return paths, base, out.value.doc, tmp


def inject(monkeypatch, what, factor):
    """Every native answer with one kind of columns scaled by factor (and its q, qd or qdd)."""
    solve = kinem.solver.solve
    array = {"velocities": "qd", "accelerations": "qdd", "positions": "q"}[what]

    def patched(*a, **k):
        r = solve(*a, **k)
        tr = r.trajectory
        scale = np.array([factor if c.endswith(SUFFIXES[what]) else 1.0 for c in tr.columns])
        out = dataclasses.replace(r, trajectory=Trajectory(tr.t.copy(), tr.columns, tr.data * scale))
        if getattr(r, array) is not None:
            out = dataclasses.replace(out, **{array: getattr(r, array) * factor})
        return out

    monkeypatch.setattr(kinem.solver, "solve", patched)


def steps(doc):
    return {(c["name"], r["engine"]): r["counts"]["steps"] for c in doc["cases"] for r in c["runs"]
            if r["engine"] != "native" and r["outcome"] == "ok"}


@pytest.mark.parametrize("what, factor", [("velocities", 1.001), ("accelerations", 1.05), ("positions", 1 + 1e-10)])
def test_a_native_error_is_a_regression_of_native_on_every_case(repo, tmp_path, monkeypatch, what, factor):
    paths, base, clean, _ = repo
    inject(monkeypatch, what, factor)
    out = report(paths, tmp_path / "o", str(base))
    doc, g = out.value.doc, out.value.doc["gate"]
    assert out.exit_code == 1
    assert f"{g['regressions']} regressions ({g['regressions']} of native)" in out.detail
    for name in CASES:
        mine = [f for f in g["findings"] if f["case"] == name and f["fatal"]]
        assert mine and all(f["engine"] == "native" for f in mine), (name, mine)
        moved = [f for f in mine if f["kind"] == "trajectory"]
        assert moved and moved[0]["metric"].endswith(SUFFIXES[what]), moved
        assert name in moved[0]["message"] and "regression of native" in moved[0]["message"]
        assert moved[0]["metric"] in moved[0]["message"]
        assert g["kinds"][f"{name}/native"] == "regressed"
        for e in ENGINES:   # the engines' cells: consistent (pass), the cam's: unsupported, not failing
            # pass; "slower" is a pass too (a wall-time flag a loaded machine can raise, never a regression)
            assert g["kinds"][f"{name}/{e}"] in ("pass", "slower"), (name, e, g["verdicts"][f"{name}/{e}"])
    # the engines' cost: not refined towards a wrong native answer (each engine starts from the model's own
    # assembly and chooses its steps from its own figures: exactly the clean run's steps)
    now, before = steps(doc), steps(clean)
    assert now == before, (now, before)
    assert not any(r["verdict"] == "cannot reach the tolerance within the cost cap"
                   for c in doc["cases"] for r in c["runs"])
    html = (tmp_path / "o" / "index.html").read_text()   # regression text below the summary table, not in its cells
    table = html[html.index("<table class=matrix>"):html.index("</table>", html.index("<table class=matrix>"))]
    table = re.sub(r' title="[^"]*"', "", table)   # the hover text may say it all
    notes = html[html.index("<ol class=notes>"):]
    assert "moved by" not in table and "regressed <sup>" in table and "regression of native" in notes[:5000]
    suites = ET.parse(tmp_path / "o" / "junit.xml").getroot()
    failed = {(t.get("classname").rsplit(".", 1)[1], t.get("name")) for t in suites.iter("testcase")
              if t.find("failure") is not None}
    assert failed == {(name, "native") for name in CASES}


def test_velocities_off_native_disagrees_with_the_engines_consensus(repo, tmp_path, monkeypatch):
    """Without a baseline too: the engines agree, native is off: native's
    cell says so with the figure, the engines' are consistent; compare too."""
    paths = repo[0]
    inject(monkeypatch, "velocities", 1.001)
    out = report(paths, tmp_path / "o", None)
    assert out.exit_code == 1
    four = next(c for c in out.value.doc["cases"] if c["name"] == "watt2")
    native = four["runs"][0]
    assert native["verdict"] == "native disagrees with the engines' consensus"
    assert native["attributed"]["figure"] in ("velocity_error_rel", "angular_velocity_error_rel")
    assert 5e-4 < native["attributed"]["value"] < 2e-3   # the 0.1 % injected, scale-free
    assert {r["verdict"] for r in four["runs"][1:]} == {"consistent with the engines' consensus"}
    md = (tmp_path / "o" / "summary.md").read_text()
    assert "native disagrees with the engines' consensus" in md
    junit = (tmp_path / "o" / "junit.xml").read_text()
    assert "native disagrees with the engines' consensus" in junit
    code = cli.main(["compare", paths[0], "--engines", "native," + ",".join(ENGINES)])
    assert code == 1


def test_a_clean_rerun_passes_and_native_says_no_independent_reference(repo, tmp_path, capsys):
    paths, base, _, _ = repo
    out = report(paths, tmp_path / "o", str(base))
    assert out.exit_code == 0 and out.value.doc["gate"]["regressions"] == 0, out.detail
    assert out.value.doc["options"]["whole_set"]   # the files given cover the baseline's set: whatever their folder
    by_name = {c["name"]: c for c in out.value.doc["cases"]}
    assert by_name["watt2"]["runs"][0]["verdict"] == "no independent reference"
    assert by_name["cam_roller_circle"]["runs"][0]["verdict"] == "within tolerance"   # Example 4.4's closed form
    junit = ET.parse(tmp_path / "o" / "junit.xml").getroot()
    six_bar = next(t for t in junit.iter("testcase") if t.get("classname").endswith("watt2")
                   and t.get("name") == "native")
    assert six_bar.find("system-out").text == "no independent reference"
    html = (tmp_path / "o" / "index.html").read_text()
    assert "no independent reference" in html
    assert cli.main(["compare", paths[0], "--engines", "native"]) == 0
    shown = capsys.readouterr().out
    native_line = next(line for line in shown.splitlines() if line.startswith("native"))
    assert "no independent reference" in native_line and "0.00e+00" not in native_line
    assert cli.main(["compare", paths[2], "--engines", "native"]) == 0   # Example 4.4's closed form here too
    native_line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("native"))
    assert native_line.endswith("within tolerance") and "no independent reference" not in native_line
    narrowed = report(paths[:1], tmp_path / "n", str(base))
    assert not narrowed.value.doc["options"]["whole_set"] and narrowed.exit_code == 0


def test_report_and_compare_agree_on_a_coarse_engine(repo, tmp_path):
    """One verdict rule: an engine outside its tolerance at the settings used
    fails compare, the report and JUnit; recorded in a baseline it is a
    known state that passes, and only a worse figure fails."""
    path = Path(repo[0][0])
    coarse = tmp_path / "watt2.toml"
    coarse.write_text(path.read_text() + "\n[engines.pymunk]\ndt = 5e-3\n")
    assert cli.main(["compare", str(coarse), "--engines", "native,pymunk"]) == 1
    out = run(Options(cases=(str(coarse),), engines=("pymunk",), out=str(tmp_path / "o"), quick=True,
                      junit=True, workers=0, progress=False, stress=False))
    assert out.exit_code == 1
    pymunk = out.value.doc["cases"][0]["runs"][1]
    assert pymunk["verdict"] == "outside tolerance"
    junit = ET.parse(tmp_path / "o" / "junit.xml").getroot()
    failed = [t.get("name") for t in junit.iter("testcase") if t.find("failure") is not None]
    assert failed == ["pymunk"]
    base = tmp_path / "b.json"
    opts = dict(cases=(str(coarse),), engines=("pymunk",), quick=True, workers=0, progress=False, stress=False)
    assert run(Options(**opts, out=str(tmp_path / "u"), baseline=str(base), update_baseline=True)).exit_code == 1
    base.write_text(results.dumps(out.value.doc))   # recorded as a known state
    again = run(Options(**opts, out=str(tmp_path / "k"), baseline=str(base)))
    assert again.exit_code == 0, again.detail
    assert any(f["kind"] == "known" for f in again.value.doc["gate"]["findings"])
    coarse.write_text(path.read_text() + "\n[engines.pymunk]\ndt = 1e-2\n")   # worse: fails
    worse = run(Options(**opts, out=str(tmp_path / "w"), baseline=str(base)))
    assert worse.exit_code == 1


EDITS = {
    "null trajectory": lambda d: d["cases"][2]["runs"][0].update(trajectory=None),
    "truncated": lambda d: _each(d["cases"][0]["runs"][0]["trajectory"], lambda v: v[:-1]),
    "re-timed": lambda d: d["cases"][1]["runs"][0]["trajectory"].update(
        t=[x + 0.01 for x in d["cases"][1]["runs"][0]["trajectory"]["t"]]),
    "missing column": lambda d: d["cases"][0]["runs"][0]["trajectory"]["columns"].pop("crank.omega"),
    "missing item": lambda d: [d["cases"][0]["runs"][2]["trajectory"]["columns"].pop(c) for c in
                               [c for c in d["cases"][0]["runs"][2]["trajectory"]["columns"] if c.startswith("crank.")]],
    "engine null": lambda d: d["cases"][0]["runs"][3].update(trajectory=None),
    "null speed": lambda d: d["cases"][0].update(speed=None),
}


def _each(traj, f):
    traj["t"] = f(traj["t"])
    for k in traj["columns"]:
        traj["columns"][k] = f(traj["columns"][k])


@pytest.mark.parametrize("edit", [*EDITS, "non-finite figure"])
def test_every_baseline_edit_exits_2_in_one_line(repo, tmp_path, capsys, edit):
    paths, base, clean, _ = repo
    doc = copy.deepcopy(results.load(base))
    bad = tmp_path / "edited.json"
    if edit == "non-finite figure":
        text = results.dumps(doc)
        key = '"velocity_error_rel": '
        at = text.index(key, text.index('"engine": "mujoco"'))
        text = text[:at + len(key)] + "1e999" + text[text.index(",", at):]
        bad.write_text(text)
    else:
        EDITS[edit](doc)
        bad.write_text(json.dumps(doc))
    code = cli.main(["report", *paths, "--engines", ",".join(ENGINES), "--quick", "--jobs", "0",
                     "--baseline", str(bad), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and str(bad) in err
    case = {"null trajectory": "cam_roller_circle", "re-timed": "rack_pinion"}.get(edit, "watt2")
    assert f"cases.{case}" in err, err
    assert not (tmp_path / "o" / "results.json").exists()


def test_a_solver_settings_edit_is_compared_not_stale(repo, tmp_path):
    """Tighter tolerance: the answers stay within the baseline's tolerance
    (pass); a far looser one moves them (a regression of native, named),
    never "baseline stale"."""
    paths, base, _, _ = repo
    cam = Path(paths[2])
    text = cam.read_text()
    mine = tmp_path / "mech"
    mine.mkdir()
    for tol, fails in ((1e-13, False), (1e-3, True)):
        edited = re.sub(r"(?m)^tolerance\s*=.*$", f"tolerance = {tol}", text) if "tolerance" in text else \
            text.replace("[time]", f"[solver]\ntolerance = {tol}\n\n[time]", 1)
        (mine / cam.name).write_text(edited)
        runs.reference.cache_clear()
        out = run(Options(cases=(str(mine / cam.name),), engines=(), out=str(tmp_path / "o"), baseline=str(base),
                          quick=True, workers=0, progress=False, stress=False))
        kinds = {f["kind"] for f in out.value.doc["gate"]["findings"] if f["fatal"]}
        assert "stale" not in kinds
        assert (out.exit_code == 1) is fails and (("trajectory" in kinds) is fails), out.value.doc["gate"]
        assert any("solver settings changed" in x for x in out.value.doc["gate"]["not_compared"])


def test_kinem_diff_names_what_moved(repo, tmp_path, capsys):
    _, base, clean, tmp = repo
    assert cli.main(["diff", str(base), str(base)]) == 0
    assert "nothing moved" in capsys.readouterr().out
    doc = copy.deepcopy(results.load(base))
    native = doc["cases"][0]["runs"][0]
    native["trajectory"]["columns"]["coupler.vx"][4] *= 1.01
    doc["cases"][0]["runs"][1]["counts"]["steps"] += 1
    moved = tmp_path / "moved.json"
    moved.write_text(results.dumps(doc))
    assert cli.main(["diff", str(base), str(moved)]) == 1
    out = capsys.readouterr().out
    assert "REGRESSED: watt2/native (main): watt2: native (a regression of native): coupler.vx moved" in out
    assert "watt2/pymunk" in out and "steps" in out


def test_summary_figure_is_the_worst_of_positions_angles_and_rates():
    from kinem.report.text import figure

    run = {"engine": "exudyn", "outcome": "ok", "position_error_rel": 1e-9, "angle_error": 2e-9,
           "velocity_error_rel": 7e-8, "angular_velocity_error_rel": 3e-8}
    assert figure(run) == (7e-8, "velocity / V")
    assert figure(dict(run, angular_velocity_error_rel=9e-8)) == (9e-8, "angular velocity / (V/L)")


def test_a_slowdown_needs_its_repeats(repo):
    """A first look flags a ratio x2.6 (the baseline's reference case paid an
    engine's warm-up); the repeats, fastest of 3 in turn with the reference
    case, are no slower than the baseline's own time: nothing is flagged.
    Repeats slower than both: flagged."""
    from kinem.report.gate import gate

    base = results.load(repo[1])
    doc = copy.deepcopy(base)
    rack = next(c for c in doc["cases"] if c["name"] == "rack_pinion")
    four = next(c for c in base["cases"] if c["name"] == "watt2")
    run = next(r for r in rack["runs"] if r["engine"] == "exudyn")
    ref = next(r for r in four["runs"] if r["engine"] == "exudyn")["time_per_step"]
    a = run["time_per_step"]
    run["time_per_step"] = 3 * a
    run["wall_time"] = max(run["wall_time"], 0.02)
    next(r for r in next(c for c in base["cases"] if c["name"] == "rack_pinion")["runs"]
         if r["engine"] == "exudyn")["wall_time"] = 0.02
    run["retimed"] = {"reference_case": "watt2", "time_per_step": a, "reference_time_per_step": ref / 2.6,
                      "repeats": 3}
    slow = [f for f in gate(doc, base, "b")["findings"] if f["kind"] == "slower"]
    assert slow == []
    run["retimed"].update(time_per_step=2.5 * a, reference_time_per_step=ref)
    slow = [f for f in gate(doc, base, "b")["findings"] if f["kind"] == "slower"]
    assert [(f["case"], f["engine"]) for f in slow] == [("rack_pinion", "exudyn")] and "fastest of 3" in slow[0]["message"]


def test_a_known_disagreement_passes_and_a_worse_one_fails(repo):
    """A baseline may record native disagreeing with the engines' consensus
    as a known state: the same figure passes (listed as known), a worse one
    fails as a regression of native."""
    from kinem.report.gate import gate

    base = copy.deepcopy(results.load(repo[1]))
    native = base["cases"][0]["runs"][0]
    said = {"figure": "velocity_error_rel", "value": 1e-3, "column": "coupler.vx", "t": 0.25,
            "engines": ["pymunk", "mujoco"], "spread": 1e-7}
    native.update(verdict="native disagrees with the engines' consensus", attributed=said)
    doc = copy.deepcopy(base)
    g = gate(doc, base, "b")
    assert g["regressions"] == 0 and [f["kind"] for f in g["findings"] if f["engine"] == "native"] == ["known"]
    doc["cases"][0]["runs"][0]["attributed"] = dict(said, value=2e-3)
    g = gate(doc, base, "b")
    bad = [f for f in g["findings"] if f["fatal"]]
    assert [(f["engine"], f["kind"]) for f in bad] == [("native", "consensus")]
    assert "watt2: native disagrees with the engines' consensus: velocity_error_rel 2.00e-03" in bad[0]["message"]
