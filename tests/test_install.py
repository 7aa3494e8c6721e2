"""The package as users get it: ``pip wheel .`` builds a wheel with the
compiled core inside (the ``wheel`` fixture of tests/conftest.py, shared with
tests/test_ci_recipe.py), and that wheel, installed into a fresh virtual
environment on a machine without a Rust toolchain, solves a case and
writes nothing at run time but the output named (no cache folder, nothing
under the package, nothing in the temporary directory)."""
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def files(folder: Path) -> set:
    return {p.relative_to(folder) for p in folder.rglob("*")} if folder.exists() else set()


def test_the_wheel_carries_the_core_and_the_packages(wheel):
    import zipfile

    assert "-cp311-abi3-" in wheel.name   # one wheel for every CPython >= 3.11 (pyo3's abi3-py311)
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.startswith("kinem/_core") and n.endswith(".so") for n in names)
    assert "kinem/report/schema.json" in names and "adapters/base.py" in names
    assert not any("/core/src/" in n or n.endswith(".rs") for n in names)  # the crate's sources stay out


def test_the_wheel_solves_in_a_fresh_environment_without_rust_and_writes_nothing_else(wheel, tmp_path):
    env_dir, work, tmp = tmp_path / "venv", tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    tmp.mkdir()
    venv.create(env_dir, with_pip=False)
    site = Path(subprocess.run([str(env_dir / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--disable-pip-version-check", "-q",
                        "--target", str(site), str(wheel)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    # the dependencies (numpy, scipy, ...) from this environment, after the wheel's own packages
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    shutil.copy(ROOT / "cases" / "four_bar.toml", work / "four_bar.toml")
    before = {"site": files(site), "work": files(work), "tmp": files(tmp)}
    path = os.pathsep.join(p for p in os.environ["PATH"].split(os.pathsep)
                           if not (Path(p) / "cargo").exists() and not (Path(p) / "rustc").exists())
    env = {"PATH": path, "HOME": str(tmp_path / "home"), "TMPDIR": str(tmp), "PYTHONDONTWRITEBYTECODE": "1"}
    code = ("import kinem, sys; assert kinem.__file__.startswith(sys.argv[1]), kinem.__file__; "
            "r = kinem.solve(kinem.compile(kinem.load('four_bar.toml'))); assert r.success, r.message; "
            "import subprocess; raise SystemExit(subprocess.run([sys.executable, '-m', 'kinem', 'solve', "
            "'four_bar.toml', '--out', 'out.csv']).returncode)")
    r = subprocess.run([str(env_dir / "bin" / "python"), "-c", code, str(site)], cwd=work, env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert shutil.which("cargo", path=path) is None
    after = {"site": files(site), "work": files(work), "tmp": files(tmp)}
    assert after["site"] == before["site"]                       # nothing under the package
    assert after["tmp"] == before["tmp"]                         # no temporary leftovers
    assert after["work"] - before["work"] == {Path("out.csv")}   # the output named, nothing else
    assert not (tmp_path / "home").exists()                      # no cache folder in the home directory
