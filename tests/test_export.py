"""kinem export: each exported artifact, run on its own in a subprocess with
only its engine and numpy imported, reproduces the harness's trajectory."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem
from adapters import get
from kinem.cli import main

ROOT = Path(__file__).resolve().parents[1]

MUJOCO_RUN = """
import json, sys
import mujoco, numpy as np
m = mujoco.MjModel.from_xml_path(sys.argv[1])
d = mujoco.MjData(m)
mujoco.mj_resetDataKeyframe(m, d, 0)
sub, n = int(m.numeric("kinem:substeps").data[0]), int(m.numeric("kinem:intervals").data[0])
bodies = sys.argv[2].split(",")
out = []
for k in range(n + 1):
    if k:
        mujoco.mj_step(m, d, sub)
    mujoco.mj_forward(m, d)
    out.append([float(v) for b in bodies for v in d.body(b).xpos[:2]])
print(json.dumps(out))
"""


def exported(name, engine, tmp_path, suffix):
    """(model, the harness's EngineRun at the defaults, the path kinem export wrote)."""
    case = ROOT / "cases" / f"{name}.toml"
    out = tmp_path / f"{name}{suffix}"
    assert main(["export", str(case), "--engine", engine, "--out", str(out)]) == 0
    model = kinem.compile(kinem.load(case))
    native = kinem.solve(model)
    return model, get(engine).run(model, native.q[0], native.qd[0]), out


def isolated(script, *args):
    """Runs a script with only the engine and numpy importable beside the
    standard library (no kinem, no adapters: -I ignores PYTHONPATH and the cwd)."""
    p = subprocess.run([sys.executable, "-I", "-c", script, *map(str, args)], capture_output=True, text=True,
                       cwd="/")
    assert p.returncode == 0, p.stderr
    return np.array(json.loads(p.stdout))


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1", "quick_return_2", "quick_return_3"])
def test_mujoco_export_runs_alone_and_matches_the_harness(name, tmp_path):
    model, run, out = exported(name, "mujoco", tmp_path, ".xml")
    xy = isolated(MUJOCO_RUN, out, ",".join(model.body_names))
    harness = run.q.reshape(len(run.q), -1, 3)[:, :, :2].reshape(len(run.q), -1)
    # The harness overwrites the driven joint before every step, the exported model holds it
    # by its armature: they differ by ~2e-8 L (measured), within MuJoCo's own tolerance.
    assert np.abs(xy - harness).max() / model.length <= get("mujoco").tolerance["position_error_rel"]


def test_export_of_an_unsupported_case_is_an_input_error(tmp_path, capsys):
    out = tmp_path / "cam.xml"
    assert main(["export", str(ROOT / "cases" / "cam_table41.toml"), "--engine", "mujoco", "--out", str(out)]) == 2
    assert "mujoco cannot represent this case" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1", "gear_pair"])
def test_pymunk_script_runs_alone_and_matches_the_harness(name, tmp_path):
    model, run, out = exported(name, "pymunk", tmp_path, ".py")
    p = subprocess.run([sys.executable, "-I", str(out), "--all"], capture_output=True, text=True, cwd="/")
    assert p.returncode == 0, p.stderr
    q = np.array(json.loads(p.stdout)["q"])
    # the same Space stepped the same way: equal up to the round trip of the tables
    # through the script (measured: bit-identical, or 2e-12 of L)
    assert q.shape == run.q.shape and np.abs(q - run.q).max() <= 1e-10 * model.length


from adapters.export import CURVE_TYPES  # noqa: E402

EXUDYN_CASES = sorted(str(p.relative_to(ROOT / "cases"))[:-5] for p in (ROOT / "cases").rglob("*.toml"))


def exudyn_script_matches_the_harness(model, out, settings=None):
    """Runs the exported script alone; (its q, qd, the harness's run) at every output instant."""
    from adapters.export import export

    native = kinem.solve(model)
    run = get("exudyn").run(model, native.q[0], native.qd[0], settings)
    out.write_text(export(model, "exudyn", native.q[0], native.qd[0], settings))
    p = subprocess.run([sys.executable, "-I", str(out), "--all", "--velocities"], capture_output=True, text=True,
                       cwd="/")
    if not run.ok:  # the stress cases where the engine stops: the script stops there too, and says so
        at = run.detail.split(":")[0].split("stopped ")[1]   # "at t = ..."
        assert run.status.failure and p.returncode != 0 and f"Exudyn solver failed: stopped {at}" in p.stderr, \
            (run.label, p.stderr)
        return None
    assert p.returncode == 0, p.stderr
    r = json.loads(p.stdout)
    assert r["bodies"] == list(model.body_names)
    q, qd = np.array(r["q"]), np.array(r["qd"])
    assert q.shape == run.q.shape and qd.shape == run.qd.shape
    # The same items, settings and user-function code solved by the same Exudyn: measured
    # bit-identical on every case; 1e-12 of L (velocities: of the largest velocity, far below
    # the engine's O(dt^2) velocity error) leaves room only for a different summation order.
    assert np.abs(q - run.q).max() <= 1e-12 * model.length
    assert np.abs(qd - run.qd).max() <= 1e-12 * max(1.0, np.abs(run.qd).max())
    return q, qd, run


@pytest.mark.parametrize("name", EXUDYN_CASES)
def test_exudyn_script_runs_alone_and_matches_the_harness(name, tmp_path, capsys):
    case = ROOT / "cases" / f"{name}.toml"
    spec = kinem.load(case)
    if any(c.type in CURVE_TYPES for c in spec.constraints):   # Python user functions at every Newton
        spec = spec.with_time(spec.end * 0.2, max(4, round(spec.steps * 0.2)))   # iteration: a fifth of the run
    model = kinem.compile(spec)
    out = tmp_path / "model.py"
    if get("exudyn").unsupported(model):
        assert main(["export", str(case), "--engine", "exudyn", "--out", str(out)]) == 2
        assert "exudyn cannot represent this case" in capsys.readouterr().err and not out.exists()
        return
    exudyn_script_matches_the_harness(model, out)


def _four_bar_driven_by(d, end=1.0):
    import tomllib

    with open(ROOT / "cases" / "four_bar.toml", "rb") as f:
        case = tomllib.load(f)
    case["time"] = {"end": end, "steps": 100}
    next(c for c in case["constraints"] if c.get("name") == "crank-drive")["d"] = d
    return case


@pytest.mark.parametrize("symbolic", [True, False])
def test_exudyn_script_reproduces_table_and_harmonic_drivers(symbolic, tmp_path):
    # kinem's not-a-knot spline, embedded as its piecewise coefficients; Python and symbolic user functions
    table = {"table": {"t": [0.0, 0.3, 0.6, 1.0, 1.4], "value": [0.7, 1.0, 1.5, 1.6, 2.2]}}
    harmonic = {"harmonic": {"amplitude": 0.8, "omega": 2.5, "phase": 0.3, "offset": 0.55}}
    for n, d in enumerate((table, harmonic)):
        model = kinem.compile(kinem.load_dict(_four_bar_driven_by(d)))
        exudyn_script_matches_the_harness(model, tmp_path / f"m{n}.py", {"symbolic_drivers": symbolic})


def test_exudyn_script_reproduces_a_distance_driver(tmp_path):
    import tomllib

    with open(ROOT / "cases" / "slider_crank.toml", "rb") as f:
        d = tomllib.load(f)
    d["time"] = {"end": 1.0, "steps": 100}
    d["constraints"] = [c for c in d["constraints"] if c.get("name") != "crank-drive"]
    d["constraints"].append({"type": "distance-driver", "name": "cylinder", "i": "ground", "si": [0.0, 0.0],
                             "j": "slider", "sj": [0.0, 0.0], "d": {"poly": [663.0, -100.0]}})
    exudyn_script_matches_the_harness(kinem.compile(kinem.load_dict(d)), tmp_path / "m.py")


def test_exudyn_script_writes_the_trajectory(tmp_path):
    model, run, out = exported("quick_return_2", "exudyn", tmp_path, ".py")
    csv = tmp_path / "trajectory.csv"
    p = subprocess.run([sys.executable, "-I", str(out), str(csv)], capture_output=True, text=True, cwd="/")
    assert p.returncode == 0, p.stderr
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert header == ["t"] + [c for c in run.trajectory.columns if c.split(".")[0] in model.body_names]
    assert np.allclose(data[:, 0], model.times, rtol=0, atol=1e-12)
    # written with numpy's %.18e: each column within a unit in the last place of the harness's
    assert np.allclose(data[:, 1:], np.column_stack([run.trajectory[c] for c in header[1:]]), rtol=1e-15, atol=0)


def test_exudyn_export_takes_the_case_files_engine_settings(tmp_path):
    # [engines.exudyn] in the case file: the harness runs with it (adapters.case_settings), so does the export
    from adapters import case_settings

    case = tmp_path / "four_bar.toml"
    text = (ROOT / "cases" / "four_bar.toml").read_text().replace("end = 2.5", "end = 0.5")
    case.write_text(text + '\n[engines.exudyn]\nintegrator = "trapezoidal-index2"\nsubsteps = 7\n')
    model = kinem.compile(kinem.load(case))
    native = kinem.solve(model)
    run = get("exudyn").run(model, native.q[0], native.qd[0], case_settings(model, "exudyn"))
    default = get("exudyn").run(model, native.q[0], native.qd[0])
    out = tmp_path / "m.py"
    assert main(["export", str(case), "--engine", "exudyn", "--out", str(out)]) == 0
    assert "trapezoidal-index2" in out.read_text() and "TrapezoidalIndex2" in out.read_text()
    p = subprocess.run([sys.executable, "-I", str(out), "--all"], capture_output=True, text=True, cwd="/")
    assert p.returncode == 0, p.stderr
    q = np.array(json.loads(p.stdout)["q"])
    # as in exudyn_script_matches_the_harness; the default settings give a different run (index-2 drifts ~1e-9 L)
    assert np.abs(q - run.q).max() <= 1e-12 * model.length < np.abs(q - default.q).max()


# A path, as the case's source, that closes a docstring, a string, a comment and an XML
# comment and then runs code, with backslashes, non-ASCII and an undecodable byte besides.
HOSTILE = ('x"""\n__import__("os").system("touch PWNED")\n"""\'\'\'\n'
           "__import__('os').system('touch PWNED2') # \\ \\n \\\\ é 雪 \udcff --> <b> <!-- ---")


@pytest.mark.parametrize("engine, suffix", [("pymunk", ".py"), ("exudyn", ".py"), ("mujoco", ".xml")])
def test_export_of_a_case_with_a_hostile_path_runs_only_the_mechanism(engine, suffix, tmp_path):
    folder = tmp_path / HOSTILE
    folder.mkdir()
    lines = (ROOT / "cases" / "slider_crank.toml").read_text().splitlines()
    assert lines[1].startswith("description = ")
    lines[1] = "description = " + json.dumps('"""\n__import__("os").system("touch PWNED3")\n--> \\ é')
    case = folder / "case.toml"
    case.write_text("\n".join(lines) + "\n")
    out = tmp_path / f"model{suffix}"
    assert main(["export", str(case), "--engine", engine, "--out", str(out)]) == 0
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    model = kinem.compile(kinem.load(case))
    if engine == "mujoco":
        p = subprocess.run([sys.executable, "-I", "-c", MUJOCO_RUN, str(out), ",".join(model.body_names)],
                           capture_output=True, text=True, cwd=scratch)
    else:
        p = subprocess.run([sys.executable, "-I", str(out)], capture_output=True, text=True, cwd=scratch)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout) and not p.stderr.strip() and list(scratch.iterdir()) == []
    if engine != "mujoco":
        assert json.loads(p.stdout)["bodies"] == list(model.body_names)
