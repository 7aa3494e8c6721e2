"""kinem compare: the JSON contract, settings overrides from the case file and
the command line, and verdicts that can fail."""
import json
import subprocess
import sys
from pathlib import Path

import kinem
from adapters.compare import run_case

ROOT = Path(__file__).resolve().parents[1]


def run(*args):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    return p.returncode, p.stdout, p.stderr


def test_compare_json_contract():
    code, out, err = run("compare", ROOT / "cases/four_bar.toml", "--engines", "native,pymunk,mujoco,exudyn", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["case"] == "four_bar" and set(d["engines"]) == {"native", "pymunk", "mujoco", "exudyn"}
    for name, row in d["engines"].items():
        for key in ("status", "position_error", "angle_error", "velocity_error", "constraint_residual",
                    "wall_time", "steps", "settings"):
            assert key in row, (name, key)
        assert row["status"] == "ok"


def test_unsupported_is_a_status_not_a_failure():
    code, out, err = run("compare", ROOT / "cases/cam_table41.toml", "--engines", "pymunk,mujoco")
    assert code == 0, err
    assert out.count("unsupported: cam-point") == 2


def test_settings_from_case_file_and_command_line(tmp_path):
    text = (ROOT / "cases/four_bar.toml").read_text() + "\n[engines.pymunk]\niterations = 50\n"
    path = tmp_path / "fb.toml"
    path.write_text(text)
    code, out, err = run("compare", path, "--engines", "pymunk", "--set", "pymunk.error_bias=0.0", "--dt", "2e-4", "--json")
    assert code == 0, err
    s = json.loads(out)["engines"]["pymunk"]["settings"]
    assert s["iterations"] == 50 and s["dt"] == 2e-4 and s["error_bias"] == 0.0


def test_unknown_setting_is_an_input_error(tmp_path):
    code, _, err = run("compare", ROOT / "cases/four_bar.toml", "--engines", "mujoco", "--set", "mujoco.intgrator=RK4")
    assert code == 2 and "intgrator" in err and len(err.strip().splitlines()) == 1


def test_a_coarse_engine_is_out_of_tolerance():
    """The verdict can fail: pymunk at a 100 x coarser step misses its documented tolerance."""
    model = kinem.compile(kinem.load(ROOT / "cases/slider_crank.toml"))
    native, rows = run_case(model, ["pymunk"], {"pymunk": {"dt": 1e-2}})
    assert rows[0].ok and rows[0].within_tolerance is False
    code, _, _ = run("compare", ROOT / "cases/slider_crank.toml", "--engines", "pymunk", "--dt", "1e-2")
    assert code == 1
