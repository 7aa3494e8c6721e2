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
