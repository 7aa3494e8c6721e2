"""docs/ci.md as it stands: its GitHub Actions workflow and GitLab job are
valid YAML that install kinem from the repository's pinned requirement,
cache what can be cached, run ``kinem report`` on the repository's cases with
its baseline and publish summary.md and JUnit; its kinem commands, run in a
scratch repository (``.kinem-venv/bin/kinem`` as this checkout's kinem),
write a baseline, pass against it, and fail on a 1 mm case edit."""
import json
import os
import re
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "ci.md").read_text()
KINEM = ".kinem-venv/bin/kinem"


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", DOC, re.S)


def workflows():
    github, gitlab = (yaml.safe_load(b) for b in blocks("yaml"))
    return github, gitlab


def test_github_workflow_installs_caches_runs_and_publishes():
    github, _ = workflows()
    steps = github["jobs"]["report"]["steps"]
    runs = [s.get("run", "") for s in steps]
    uses = [s.get("uses", "") for s in steps]
    assert any("pip install -r ci/kinem-requirements.txt" in r for r in runs)
    cache = next(s for s in steps if s.get("uses", "").startswith("actions/cache"))
    assert cache["with"]["path"] == ".kinem-venv" and "hashFiles('ci/kinem-requirements.txt')" in cache["with"]["key"]
    report = next(r for r in runs if r.startswith(f"{KINEM} report"))
    assert "--baseline ci/kinem-baseline.json" in report and "--junit" in report
    assert any("summary.md >> \"$GITHUB_STEP_SUMMARY\"" in r for r in runs)
    junit = next(s for s in steps if "junit" in s.get("uses", ""))
    assert junit["with"]["report_paths"] == "kinem-report/junit.xml" and junit["if"] == "always()"
    assert any(u.startswith("actions/upload-artifact") for u in uses)


def test_gitlab_job_installs_caches_runs_and_publishes():
    _, gitlab = workflows()
    job = gitlab["kinem-report"]
    assert ".kinem-venv" in job["cache"]["paths"] and job["cache"]["key"]["files"] == ["ci/kinem-requirements.txt"]
    assert any("pip install -r ci/kinem-requirements.txt" in line for line in job["script"])
    assert any(line.startswith(f"{KINEM} report") and "--junit" in line for line in job["script"])
    assert job["artifacts"]["reports"]["junit"] == "kinem-report/junit.xml"
    assert job["artifacts"]["when"] == "always" and "kinem-report/" in job["artifacts"]["paths"]


def commands():
    """The documented kinem commands: the baseline's, then the job's (the
    same in both CI files)."""
    setup = [line for line in blocks("sh")[0].splitlines() if line.startswith(KINEM)]
    github, gitlab = workflows()
    job = next(s["run"] for s in github["jobs"]["report"]["steps"] if s.get("run", "").startswith(KINEM))
    assert job in gitlab["kinem-report"]["script"]
    return setup, job


def run(line, repo):
    """A documented command in the scratch repository: the glob expanded as a
    shell would, the venv's kinem replaced by this checkout's."""
    argv = []
    for word in shlex.split(line):
        argv += sorted(str(p.relative_to(repo)) for p in repo.glob(word)) if "*" in word else [word]
    assert argv[0] == KINEM
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "kinem", *argv[1:]], cwd=repo, capture_output=True, text=True,
                          env=env, timeout=600)


def test_recipe_runs_in_another_repository(tmp_path):
    repo = tmp_path / "their-repo"
    (repo / "cases").mkdir(parents=True)
    (repo / "ci").mkdir()
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    text = re.sub(r"\[time\][^\[]*", "[time]\nend = 0.1\nsteps = 5\n\n", text, count=1)
    (repo / "cases" / "linkage.toml").write_text(text.replace('name = "four_bar"', 'name = "linkage"'))
    setup, job = commands()
    first = run(setup[0], repo)
    assert first.returncode == 0, first.stdout + first.stderr
    base = json.loads((repo / "ci" / "kinem-baseline.json").read_text())
    assert [c["name"] for c in base["cases"]] == ["linkage"] and base["options"]["stress"] is None
    ok = run(job, repo)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    out = repo / "kinem-report"
    assert (out / "summary.md").read_text().startswith("## kinem report\n\n**PASS")
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert int(suite.get("tests")) == 4 and suite.get("failures") == "0"
    # a 1 mm edit of a link (the case is in metres) fails the job, naming the case
    (repo / "cases" / "linkage.toml").write_text(
        (repo / "cases" / "linkage.toml").read_text().replace("si = [0.15, 0.0]", "si = [0.151, 0.0]", 1))
    bad = run(job, repo)
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "case linkage changed: baseline stale" in (out / "summary.md").read_text()
    junit = (out / "junit.xml").read_text()
    assert 'classname="kinem.report.linkage"' in junit and "case changed: baseline stale" in junit


@pytest.mark.parametrize("edit", ['"status": "ok"', '"newton_iterations"'])
def test_an_edited_baseline_is_an_input_error(tmp_path, edit):
    """Issue 25 item 6 through the CLI: an edited status or count key exits 2
    with one line."""
    base = tmp_path / "b.json"
    doc = json.loads((ROOT / "reports" / "baseline.json").read_text())
    text = json.dumps(doc).replace(edit, edit.replace("ok", "OK").replace("newton_iterations", "newton"), 1)
    base.write_text(text)
    p = subprocess.run([sys.executable, "-m", "kinem", "report", str(ROOT / "cases" / "four_bar.toml"),
                        "--baseline", str(base), "--out", str(tmp_path / "o")], capture_output=True, text=True,
                       cwd=ROOT, timeout=600)
    assert p.returncode == 2, p.stdout + p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and ("status" in p.stderr or "counts" in p.stderr), p.stderr
