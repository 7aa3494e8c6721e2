"""The peer comparison of benchmarks/issue14_bench.py and issue23_bench.py compares like with like:
the hand-tight floor and kinem solve the same slider-crank to the closed
form, and pylinkage (when installed: a benchmark-only dependency) follows
the same geometry as kinem's cases."""
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem
from closed_form import four_bar, rel_error, slider_crank

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import peers  # noqa: E402

# 1e-12: positions to the Newton tolerance over conditioning ~1e2 of these mechanisms, rates to rounding
TOL = 1e-12


def crank(t):
    return peers.PHI0 + peers.OMEGA * t, peers.OMEGA + 0 * t, 0 * t


def _floor():
    """The C floor's library, or a skip without a C compiler."""
    try:
        return peers.floor_library()
    except RuntimeError as e:
        pytest.skip(str(e))


def _columns(tr, quantities):
    return np.stack([tr[f"{b}.{c}"] for b in ("ground", "crank", "rod", "slider") for c in quantities], axis=1)


def test_floor_and_kinem_solve_the_same_slider_crank():
    _floor()
    t = np.arange(peers.INSTANTS) * peers.DT
    ref = slider_crank(*crank(t), peers.R, peers.L_ROD)
    Q, QD, QDD, iterations = peers.floor_slider_crank()
    for k, key in ((Q, "x"), (QD, "vx"), (QDD, "ax")):
        assert rel_error(k[:, 9], ref[key]) <= TOL  # slider x is coordinate 9
    assert iterations <= 2 * peers.INSTANTS  # one or two Newton iterations per instant: a real Newton march
    r = kinem.solve(kinem.compile(kinem.load_dict(peers.slider_crank_case())))
    assert r.success and np.allclose(r.trajectory.t, t, rtol=0, atol=1e-12)
    for col, key in (("slider.x", "x"), ("slider.vx", "vx"), ("slider.ax", "ax")):
        assert rel_error(r.trajectory[col], ref[key]) <= TOL
    # the same trajectory, coordinate by coordinate: positions to 1e-12 of the size, rates to 1e-10 of their peaks
    tr = r.trajectory
    assert np.abs(Q - _columns(tr, ("x", "y", "phi"))).max() <= 1e-12 * peers.L_ROD
    for got, quantities in ((QD, ("vx", "vy", "omega")), (QDD, ("ax", "ay", "alpha"))):
        want = _columns(tr, quantities)
        assert np.abs(got - want).max() <= 1e-10 * np.abs(want).max()
    # the floor: one Newton iteration and two factorisations per instant; kinem's march: its chord
    # from the last instant's factorisation, no more iterations and one factorisation per instant
    assert r.iterations.sum() <= iterations
    assert r.factorizations <= peers.INSTANTS + 4


def test_floor_pivot_order_is_the_greedy_markowitz_order_of_its_structure():
    _floor()
    pivots, pattern = peers.floor_pivots()
    assert pivots == peers.markowitz_order(pattern)
    assert sorted(i for i, _ in pivots) == list(range(12)) and sorted(j for _, j in pivots) == list(range(12))


def test_floor_dense_fallback_gives_the_same_trajectory():
    import ctypes

    lib = _floor()
    Q, QD, QDD, it = peers.floor_slider_crank()
    assert peers.floor_info()[1] == 0  # no pivot check fails on this crank turn
    flag = ctypes.c_int.in_dll(lib, "force_dense")
    flag.value = 1
    try:
        assert peers.floor_info()[1] == 2 * peers.INSTANTS  # two factorisations per instant, all dense
        Q2, QD2, QDD2, it2 = peers.floor_slider_crank()
    finally:
        flag.value = 0
    assert it2 == it
    assert np.abs(Q2 - Q).max() <= 1e-14 * peers.L_ROD
    for a, b in ((QD, QD2), (QDD, QDD2)):
        assert np.abs(a - b).max() <= 1e-13 * np.abs(a).max()


def test_four_bar_and_jansen_cases_assemble_as_built():
    r = kinem.solve(kinem.compile(kinem.load_dict(peers.four_bar_case())))
    t = r.trajectory.t
    ref = four_bar(*crank(t), peers.FA, peers.FB, peers.FC, peers.FG)
    assert rel_error(r.trajectory["rocker.phi"], ref["th4"], angle=True) <= TOL
    assert rel_error(r.trajectory["rocker.alpha"], ref["a4"]) <= TOL
    r = kinem.solve(kinem.compile(kinem.load_dict(peers.jansen_case())))
    assert r.success, r.message
    G = np.array([peers.jansen_geometry(p)[-1] for p in crank(r.trajectory.t)[0]])
    # 1e-12 of the leg's size (~100 mm)
    assert np.abs(r.trajectory["G.x"] + 1j * r.trajectory["G.y"] - G).max() <= TOL * 100


@pytest.mark.parametrize("name, make, points", [
    ("slider-crank", peers.slider_crank_case, ("B", "A")),
    ("four-bar", peers.four_bar_case, ("A", "B", "P")),
    ("jansen", peers.jansen_case, ("C", "B", "D", "E", "F", "G")),
])
def test_pylinkage_follows_the_same_mechanism(name, make, points):
    pytest.importorskip("pylinkage")
    r = kinem.solve(kinem.compile(kinem.load_dict(make())))
    p, v, a, names = peers.pylinkage_run(name)
    tr = r.trajectory
    size = max(np.abs(p).max(), 1.0)
    for k in points:
        j = names.index(k)
        # pylinkage's first output is after one step: kinem's instants 1.. against its 0..
        got = tr[f"{k}.x"][1:] + 1j * tr[f"{k}.y"][1:]
        assert np.abs(got - (p[:-1, j, 0] + 1j * p[:-1, j, 1])).max() <= 1e-10 * size
        vel = tr[f"{k}.vx"][1:] + 1j * tr[f"{k}.vy"][1:]
        # 1e-9 of the peak: pylinkage's rates are closed forms, ours to rounding; both far below
        assert np.abs(vel - (v[:-1, j, 0] + 1j * v[:-1, j, 1])).max() <= 1e-9 * np.abs(v[:, j]).max()
