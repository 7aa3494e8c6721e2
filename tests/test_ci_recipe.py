"""docs/ci.md as it stands: its GitHub Actions workflow and GitLab job are
valid YAML that install kinem from the repository's pinned wheel (never
compiling it), cache what can be cached, run ``kinem report`` on the
repository's cases with its baseline and publish summary.md and JUnit. In a
scratch repository, its install step, run as written on the wheel ``pip
wheel`` builds (tests/conftest.py) with no cargo on PATH, makes an
environment whose own ``kinem`` runs its commands: they write a baseline,
pass against it, and fail on a 1 mm case edit. The repository's release
workflow builds that wheel for Linux, macOS and Windows."""
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
INSTALL = "python -m venv .kinem-venv && .kinem-venv/bin/pip install --only-binary kinem -r ci/kinem-requirements.txt"


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
    assert any(INSTALL in r for r in runs)
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
    assert any(INSTALL in line for line in job["script"])
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


def run(line, repo, env=None):
    """A documented command in the scratch repository: the glob expanded as a
    shell would; the venv's kinem replaced by this checkout's unless ``env``
    (then the scratch repository's own .kinem-venv runs it, with that
    environment)."""
    argv = []
    for word in shlex.split(line):
        argv += sorted(str(p.relative_to(repo)) for p in repo.glob(word)) if "*" in word else [word]
    assert argv[0] == KINEM
    if env is not None:
        return subprocess.run([str(repo / KINEM), *argv[1:]], cwd=repo, capture_output=True, text=True, env=env,
                              timeout=600)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "kinem", *argv[1:]], cwd=repo, capture_output=True, text=True,
                          env=env, timeout=600)


def scratch_repository(tmp_path):
    """A repository with one short case, cases/linkage.toml (a four-bar in metres, 5 instants)."""
    repo = tmp_path / "their-repo"
    (repo / "cases").mkdir(parents=True)
    (repo / "ci").mkdir()
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    text = re.sub(r"\[time\][^\[]*", "[time]\nend = 0.1\nsteps = 5\n\n", text, count=1)
    (repo / "cases" / "linkage.toml").write_text(text.replace('name = "four_bar"', 'name = "linkage"'))
    return repo


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


def install(repo, wheel, tmp_path) -> dict:
    """The documented install step as written, on ``wheel`` committed under
    ci/wheels/ and pinned by path (docs/ci.md, "Building the wheel"), with no
    cargo or rustc on PATH. Offline here: pip is also given --no-index
    --no-deps, and the dependencies (numpy, the engines, ...) come from this
    test's environment through a .pth file after the wheel's own packages.
    Returns the environment to run the new .kinem-venv's kinem with."""
    import shutil
    import sysconfig

    (repo / "ci" / "wheels").mkdir()
    shutil.copy(wheel, repo / "ci" / "wheels" / wheel.name)
    (repo / "ci" / "kinem-requirements.txt").write_text(f"./ci/wheels/{wheel.name}\n")
    path = os.pathsep.join(p for p in os.environ["PATH"].split(os.pathsep)
                           if not (Path(p) / "cargo").exists() and not (Path(p) / "rustc").exists())
    env = {"PATH": path, "HOME": str(tmp_path / "home"), "PYTHONDONTWRITEBYTECODE": "1"}
    make, pip = (shlex.split(part) for part in INSTALL.split(" && "))
    assert make[:3] == ["python", "-m", "venv"] and pip[:2] == [".kinem-venv/bin/pip", "install"]
    subprocess.run([sys.executable, *make[1:]], cwd=repo, env=env, check=True)
    site = Path(subprocess.run([str(repo / ".kinem-venv/bin/python"), "-c",
                                "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True, env=env).stdout.strip())
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    r = subprocess.run([str(repo / pip[0]), *pip[1:], "--no-index", "--no-deps", "--disable-pip-version-check", "-q"],
                       cwd=repo, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert shutil.which("cargo", path=path) is None and shutil.which("rustc", path=path) is None
    where = subprocess.run([str(repo / ".kinem-venv/bin/python"), "-c", "import kinem; print(kinem.__file__)"],
                           cwd=repo, env=env, capture_output=True, text=True, check=True).stdout
    assert where.startswith(str(site)), where          # the wheel's kinem, not this checkout's
    return env


def test_recipe_installs_and_runs_in_another_repository(tmp_path, request):
    """The documented install step (``install``) on the wheel ``pip wheel``
    builds (tests/conftest.py), then the documented commands by the
    environment it made: a baseline, a passing job, and a 1 mm case edit that
    fails it. Without a Rust toolchain to build the wheel, the commands run
    on this checkout's kinem."""
    repo = scratch_repository(tmp_path)
    try:
        env = install(repo, request.getfixturevalue("wheel"), tmp_path)
    except pytest.skip.Exception:
        env = None
    setup, job = commands()
    first = run(setup[0], repo, env)
    assert first.returncode == 0, first.stdout + first.stderr
    base = json.loads((repo / "ci" / "kinem-baseline.json").read_text())
    assert [c["name"] for c in base["cases"]] == ["linkage"] and base["options"]["stress"] is None
    ok = run(job, repo, env)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    out = repo / "kinem-report"
    assert (out / "summary.md").read_text().startswith("## kinem report\n\n**PASS")
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert int(suite.get("tests")) == 4 and suite.get("failures") == "0"
    # a 1 mm edit of a link (the case is in metres) fails the job, naming the case
    (repo / "cases" / "linkage.toml").write_text(
        (repo / "cases" / "linkage.toml").read_text().replace("si = [0.15, 0.0]", "si = [0.151, 0.0]", 1))
    bad = run(job, repo, env)
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "case linkage changed: baseline stale" in (out / "summary.md").read_text()
    junit = (out / "junit.xml").read_text()
    assert 'classname="kinem.report.linkage"' in junit and "case changed: baseline stale" in junit


def test_the_release_workflow_builds_abi3_wheels_for_three_systems():
    """.github/workflows/release.yml: maturin's wheels (the crate's abi3
    feature) on Linux (manylinux), macOS and Windows, each installed and run
    before a tag's release gets them."""
    flow = yaml.safe_load((ROOT / ".github" / "workflows" / "release.yml").read_text())
    assert flow[True]["push"]["tags"] == ["v*"]          # YAML 1.1 reads the key "on" as True
    wheels = flow["jobs"]["wheels"]
    systems = {m["os"].split("-")[0] for m in wheels["strategy"]["matrix"]["include"]}
    assert systems == {"ubuntu", "macos", "windows"}
    assert all(m.get("manylinux") == "auto" for m in wheels["strategy"]["matrix"]["include"] if "ubuntu" in m["os"])
    build = next(s for s in wheels["steps"] if s.get("uses", "").startswith("PyO3/maturin-action"))
    assert "--release" in build["with"]["args"]
    assert any("pip install dist/*.whl" in s.get("run", "") and "kinem\" solve" in s.get("run", "")
               for s in wheels["steps"])
    assert flow["jobs"]["release"]["needs"] == ["wheels", "sdist"]
    assert 'features = ["abi3-py311"]' in (ROOT / "kinem" / "core" / "Cargo.toml").read_text()
