"""The stress suite's situations, each with its stated behaviour (the
singular-configuration, branch and redundancy cases are in test_stability)."""
import math
import subprocess
import sys

import numpy as np
import pytest

import kinem
from kinem import stress
from kinem.reference import four_bar, four_bar_case, n_four_bar, slider_crank, slider_crank_case


def test_length_scale_gives_the_same_normalised_result():
    """The same slider-crank in lengths x 1e-3, 1 and 1e3: positions / L agree
    to 1e-9 (the Newton tolerance is relative to L), angles and rates alike."""
    runs = []
    for s in (1e-3, 1.0, 1e3):
        model = kinem.compile(kinem.load_dict(slider_crank_case(0.1 * s, 0.3 * s, 0.02 * s, end=1.0, steps=50)))
        r = kinem.solve(model)
        assert r.success
        runs.append((s, r.trajectory))
    ref = runs[1][1]
    for s, tr in runs:
        assert np.abs(tr["slider.x"] / s - ref["slider.x"]).max() <= 1e-9 * 0.4
        assert np.abs(tr["rod.phi"] - ref["rod.phi"]).max() <= 1e-9
        assert np.abs(tr["slider.ax"] / s - ref["slider.ax"]).max() <= 1e-9 * np.abs(ref["slider.ax"]).max()


@pytest.mark.parametrize("margin", [1e-2, 1e-4, 1e-6, 1e-8])
def test_near_change_point_four_bar_stays_on_branch(margin):
    """s + l - (p + q) = -margin: the four-bar nearly folds once per turn but
    must stay on its assembly branch, as accurate as anywhere."""
    g = 2.0 + margin
    case = kinem.load_dict(four_bar_case(1.0, 3.0, 2.0, g, {"poly": [0.5, 2.0]}, 0.5, end=math.pi, steps=200))
    r = kinem.solve(kinem.compile(case), ("positions",))
    assert r.success, r.message
    t = r.trajectory.t
    th4 = four_bar(0.5 + 2 * t, 2 + 0 * t, 0 * t, 1.0, 3.0, 2.0, g)["th4"]
    d = np.abs((r.trajectory["rocker.phi"] - th4 + np.pi) % (2 * np.pi) - np.pi)
    # on the branch: the other branch is at least ~sqrt(margin) >= 1e-4 rad away at the fold
    assert d.max() < 1e-6
    # and as accurate as the conditioning allows: the residual tolerance over the smallest
    # conditioning figure of the run bounds the coordinate error (x 10 for the geometry)
    assert d.max() <= 10 * kinem.Options.of(case).tolerance / r.conditioning.min()


@pytest.mark.parametrize("n", [1, 2, 5, 40])
def test_n_four_bar_passes_the_horizontal_position(n):
    """IFToMM N-four-bar: every bar parallel at the horizontal position, rank
    short by N; the chain stays a chain of parallelograms."""
    r = kinem.solve(kinem.compile(kinem.load_dict(n_four_bar(n))))
    assert r.success, r.message
    tr = r.trajectory
    th = math.pi / 2 + 0.5 - tr.t
    assert max(np.abs(tr[f"crank{k}.phi"] - th).max() for k in range(n + 1)) < 1e-8
    assert max(np.abs(tr[f"coupler{k}.phi"]).max() for k in range(n)) < 1e-8
    assert max(np.abs(tr[f"crank{k}.omega"] + 1.0).max() for k in range(n + 1)) < 1e-7


def test_long_run_does_not_drift():
    """2,000 crank turns at 8 instants per turn (kinem stress runs 10,000):
    the error at the end is that of the start, 1e-9 of the size."""
    w = 20 * math.pi
    turns = 2000
    case = kinem.load_dict(slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, w]}, 0.5, end=turns / 10, steps=turns * 8))
    r = kinem.solve(kinem.compile(case), ("positions",))
    assert r.success
    t = r.trajectory.t
    err = np.abs(r.trajectory["slider.x"] - slider_crank(0.5 + w * t, w + 0 * t, 0 * t, 0.1, 0.3)["x"])
    assert err[-100:].max() <= 1e-9 * 0.4 and err.max() <= 1e-9 * 0.4


@pytest.mark.parametrize("engine", ["pymunk", "mujoco", "exudyn"])
def test_mass_ratio_runs_are_classified(engine):
    scenario = next(s for s in stress.scenarios(quick=True) if s.group == "mass-ratio")
    out = stress.run_one((scenario, engine))
    assert out.status in (stress.Class.ACCURATE, stress.Class.INACCURATE, stress.Class.BRANCH_FLIP,
                          stress.Class.DIVERGED, stress.Class.NAN)


def test_classify():
    C, tol = stress.Class, {"position_error_rel": 1e-8}
    assert stress.classify({"position_error_rel": 1e-12}, 1e-12, tol) == (C.ACCURATE, ())
    assert stress.classify({"position_error_rel": 1e-5}, 1e-9, tol) == (C.INACCURATE, (("position_error_rel", 1e-5, 1e-8),))
    assert stress.classify({"position_error_rel": 0.5}, 1e-9, tol)[0] is C.BRANCH_FLIP
    assert stress.classify({"position_error_rel": 0.5}, 1e-3, tol)[0] is C.INACCURATE
    assert stress.classify({}, 0.0, tol, finite=False)[0] is C.NAN


def _engine_run(model, native, q, qd):
    from adapters.base import EngineRun, Status
    from kinem.result import trajectory

    return EngineRun("fake", Status.OK, "", trajectory(model, native.trajectory.t, q, qd), q, qd,
                     steps=len(q), intervals=len(q) - 1)


@pytest.mark.parametrize("speed", [0.25, 1.0, 4.0])
def test_stress_judges_velocity_with_the_scale_free_table(speed):
    """An engine run with exact positions and velocities off by 1e-4 of the
    run's peak speed: inaccurate by velocity_error_rel at every speed of the
    same mechanism (the table's limit 1e-5 is relative), accurate at 1e-6 of it."""
    from adapters.compare import tolerance_of
    from adapters.pymunk_sim import PymunkAdapter

    w = 2.0 * speed
    model = kinem.compile(kinem.load_dict(slider_crank_case(0.1, 0.3, 0.0, {"poly": [0.5, w]}, 0.5,
                                                            end=2.0 / speed, steps=50)))
    native = kinem.solve(model)
    table = tolerance_of(PymunkAdapter())
    assert table["velocity_error_rel"] == 1e-5
    tr = native.trajectory
    items = model.body_names + model.point_names
    peak = max(model.length * max(np.abs(tr[f"{b}.omega"]).max() for b in model.body_names),
               max(np.hypot(tr[f"{i}.vx"], tr[f"{i}.vy"]).max() for i in items))   # V of docs/engines.md
    for off, want in ((1e-4, stress.Class.INACCURATE), (1e-6, stress.Class.ACCURATE)):
        qd = native.qd.copy()
        qd[:, 3 * model.body_names.index("slider")] += off * peak     # the slider's vx
        cls, figures, _, exceeded = stress.judge(model, native, _engine_run(model, native, native.q, qd), None, table)
        assert cls is want, (figures, exceeded)
        assert figures["velocity_error_rel"] == pytest.approx(off, rel=1e-6)
        assert figures["position_error_rel"] == 0.0
        assert [k for k, *_ in exceeded] == (["velocity_error_rel"] if off > 1e-5 else [])


def test_stress_outcome_round_trips_through_json():
    """An outcome's class goes to JSON as its value and comes back as the same
    member, its message with it."""
    import json

    from kinem.outcome import Outcome

    o = Outcome(stress.Class.INACCURATE, "velocity_error_rel 1.00e-04 > 1e-05",
                stress.Row("g", "s", "pymunk", 1e-9, 1e-12, 0.1, (("velocity_error_rel", 1e-4, 1e-5),)))
    back = stress.from_dict(json.loads(json.dumps(stress.as_dict(o))))
    assert back == o and back.status is stress.Class.INACCURATE
    assert back.message == "a figure outside its tolerance: velocity_error_rel 1.00e-04 > 1e-05"


def test_native_meets_every_expectation_quick():
    p = subprocess.run([sys.executable, "-m", "kinem", "stress", "--quick", "--engines", "native", "--jobs", "0"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "singular-detected" in p.stdout and "N-four-bar, N = 20" in p.stdout
