"""kinem engines --tune: the sweep behind the engines' default settings."""
import json

from adapters import tune
from kinem.cli import main


def test_pareto_front_keeps_only_undominated_points():
    pts = [{"time_per_interval": c, "position_error_rel": e}
           for c, e in [(1.0, 1e-3), (2.0, 1e-5), (3.0, 1e-4), (4.0, 1e-7), (0.5, float("inf"))]]
    assert tune.pareto(pts) == [0, 1, 3]   # (3, 1e-4) is beaten by (2, 1e-5); inf errors never count
    # below the floor errors are equal: only the cheapest of them is on the front
    low = [{"time_per_interval": c, "position_error_rel": e} for c, e in [(1.0, 1e-3), (2.0, 3e-16), (3.0, 1e-16)]]
    assert tune.pareto(low) == [0, 1, 2] and tune.pareto(low, floor=1e-12) == [0, 1]


def test_families_hold_the_defaults_then_change_one_knob_to_its_ends():
    class A:
        knobs = {"substeps": (1, 2), "integrator": ("a", "b", "c"), "iterations": (3, 5, 10, 25, 100)}

    fams = tune.families(A, {"integrator": "a", "iterations": 100, "dt": 1e-3})
    assert fams == [{"integrator": "a", "iterations": 100}, {"integrator": "b", "iterations": 100},
                    {"integrator": "c", "iterations": 100}, {"integrator": "a", "iterations": 3},
                    {"integrator": "a", "iterations": 25}]


def test_tune_quick_smoke(capsys):
    assert main(["engines", "--tune", "mujoco", "--quick", "--json"]) == 0
    (r,) = json.loads(capsys.readouterr().out)
    assert r["engine"] == "mujoco" and len(r["points"]) == len(tune.grid(__import__("adapters").get("mujoco")))
    best = r["recommended"]
    assert best is not None and best["meets"]
    # the recommendation is the cheapest point that meets the tolerance
    assert all(best["time_per_interval"] <= p["time_per_interval"] for p in r["points"] if p["meets"])
    front = [r["points"][k] for k in r["front"]]
    assert all(a["time_per_interval"] <= b["time_per_interval"] and a["position_error_rel"] > b["position_error_rel"]
               for a, b in zip(front, front[1:]))


def test_tune_names_unknown_engines(capsys):
    assert main(["engines", "--tune", "nope"]) == 2
    assert "--tune: got 'nope'" in capsys.readouterr().err


def test_sweep_covers_the_auto_step_constant():
    # MuJoCo's dt = "auto" is swept as its constant, so --tune re-derives the default rate_step
    mujoco = __import__("adapters").get("mujoco")
    auto = [g for g in tune.grid(mujoco) if g.get("dt") == "auto"]
    assert [g["rate_step"] for g in auto] == list(mujoco.rate_steps)
    assert mujoco.defaults()["rate_step"] in mujoco.rate_steps
    # fixed steps are swept too: an explicit step is never retried
    assert any(g.get("substeps") for g in tune.grid(mujoco))
