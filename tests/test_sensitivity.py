"""Issue 30 item 2: exact design sensitivities (kinem.sensitivity) against
Richardson-extrapolated central differences of kinem's own solves, against
differentiated closed forms, and at a singular position."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import kinem
from kinem.moved import _replaced, moved_cases
from kinem.moved_tables import _difference, _reached, _tables, moved_tangent, same
from kinem.parameters import apply, parameters
from kinem.sensitivity import sensitivity
from kinem.tangents import _direct, _function_tangents, _landed, _spline_tangents, _stacked, _tangent

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml"))
TIGHT = kinem.Options(tolerance=1e-14, max_iterations=50)
STEPS = 23
H = 5e-4
# a named dimension's case and the drawn ones (frames from drawn points): the tangents' shortcuts checked there too
DRAWN = [ROOT / "tests" / "data" / "four_bar_named.toml"] + sorted((ROOT / "tests" / "data" / "drawn").glob("*.toml"))


def times(case):
    """STEPS + 1 instants off the case's grid: a cam's contact exactly on a
    knot of its outline's spline (where the third derivative of s jumps, so
    the acceleration is not differentiable) at an instant is avoided."""
    return case.end * (np.arange(STEPS + 1) + 0.37) / (STEPS + 1)


def richardson(case, p, h):
    """Central differences D(h) of kinem's solves at p +- h (tight
    tolerance), extrapolated twice: R(h) = (4 D(h) - D(2h)) / 3, then
    (16 R(h) - R(2h)) / 15; error O(h^6)."""
    def traj(v):
        r = kinem.solve(kinem.compile(apply(case, {p.path: v})), times=times(case), options=TIGHT)
        assert r.success, r.message
        return r.trajectory

    runs = {k: traj(p.value + k * h) for k in (1, -1, 2, -2, 4, -4)}
    runs[0] = traj(p.value)

    def d(k, col):
        return (runs[k][col] - runs[-k][col]) / (2 * k * h)

    def r(k, col):
        return (4 * d(k, col) - d(2 * k, col)) / 3

    return {col: (16 * r(1, col) - r(2, col)) / 15 for col in runs[1].columns}, same_pieces(case, runs)


def same_pieces(case, runs):
    """Instants where every run has each contact on the same piece of its
    outline's spline as the nominal: across a knot the third derivative of
    s jumps and the acceleration is differentiable only one-sidedly, so a
    difference across it is no reference."""
    ok = np.ones(len(runs[0].t), bool)
    for c in case.constraints:
        o = c.get("outline")
        if o is None or o.kind != "spline":
            continue
        knots = np.array(o.theta)

        def piece(theta):
            if o.periodic:
                theta = knots[0] + np.mod(theta - knots[0], knots[-1] - knots[0])
            return np.searchsorted(knots, theta)

        nominal = piece(runs[0][f"{c.name}.theta"])
        for run in runs.values():
            ok &= piece(run[f"{c.name}.theta"]) == nominal
    return ok


def step(model, p):
    """A difference step of H of the parameter's own scale (a length: the mechanism's size)."""
    return H * (max(abs(p.value), model.length) if p.unit == model.case.length_unit else max(abs(p.value), 1.0))


STAGES = {"x": 0, "y": 0, "phi": 0, "theta": 0, "vx": 1, "vy": 1, "omega": 1, "dtheta": 1,
          "ax": 2, "ay": 2, "alpha": 2, "ddtheta": 2}


def worst(model, sens, p, fd, ok):
    """The largest error of any column's derivative along p, relative to the
    larger of that derivative's peak and its stage's size per unit of p (the
    largest column of the stage over the parameter's scale): a derivative
    that vanishes (a ground moved rigidly leaves every velocity alone) is
    measured against the motion's own size."""
    scale = max(abs(p.value), model.length) if p.unit == model.case.length_unit else 1.0
    stage = [0.0, 0.0, 0.0]
    for c in fd:
        k = STAGES[c.rsplit(".", 1)[1]]
        stage[k] = max(stage[k], float(np.max(np.abs(sens.trajectory[c]))) / scale)
    out = 0.0
    for col, approx in fd.items():
        exact = sens.of(col, p.path)
        peak = max(float(np.max(np.abs(exact))), stage[STAGES[col.rsplit(".", 1)[1]]], 1e-300)
        out = max(out, float(np.max(np.abs(exact - approx)[ok], initial=0.0)) / peak)
    return out


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_every_parameter_matches_extrapolated_differences(path):
    """Every design parameter of every case, every output column, 1e-8 of the peak."""
    case = kinem.load(path).with_time(steps=STEPS)
    model = kinem.compile(case)
    listed = parameters(case)
    sens = sensitivity(model, [p.path for p in listed], times=times(case), options=TIGHT)
    assert not sens.singular.any(), sens.message
    bad = {}
    for p in listed:
        fd, ok = richardson(case, p, step(model, p))
        assert ok.sum() >= len(ok) // 2, f"{p.path}: most differences cross a knot"
        e = worst(model, sens, p, fd, ok)
        if not e <= 1e-8:
            bad[p.path] = e
    assert not bad, f"{path.stem}: derivatives off extrapolated differences (relative to peak): {bad}"


def test_four_bar_output_angle_matches_freudenstein():
    """d(rocker angle)/d(each link length) from Freudenstein's equation
    F = K1 cos th4 - K2 cos th2 + K3 - cos(th2 - th4) = 0, K1 = d/a,
    K2 = d/c, K3 = (a^2 - b^2 + c^2 + d^2)/(2 a c), differentiated
    implicitly (dth4/dp = -F_p / F_th4): crank a (points.A.at.0), coupler b
    (constraints.B.si.0), rocker c (points.B.at.0), ground d
    (points.O4.at.0); 1e-11 of the peak."""
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    paths = ["points.A.at.0", "constraints.B.si.0", "points.B.at.0", "points.O4.at.0"]
    sens = sensitivity(kinem.compile(case), paths)
    a, b, c, d = 0.1, 0.3, 0.22, 0.2            # the case's links
    th2, th4 = sens.trajectory["crank.phi"], sens.trajectory["rocker.phi"]
    F = d / a * np.cos(th4) - d / c * np.cos(th2) + (a * a - b * b + c * c + d * d) / (2 * a * c) - np.cos(th2 - th4)
    assert np.max(np.abs(F)) < 1e-12            # the solution obeys the closed form
    F_th4 = -d / a * np.sin(th4) - np.sin(th2 - th4)
    F_p = {"points.A.at.0": -d / a**2 * np.cos(th4) + (a * a + b * b - c * c - d * d) / (2 * a * a * c),
           "constraints.B.si.0": -b / (a * c) + 0 * th2,
           "points.B.at.0": d / c**2 * np.cos(th2) + (c * c + b * b - a * a - d * d) / (2 * a * c * c),
           "points.O4.at.0": np.cos(th4) / a - np.cos(th2) / c + d / (a * c)}
    for path in paths:
        want = -F_p[path] / F_th4
        got = sens.of("rocker.phi", path)
        assert np.max(np.abs(got - want)) <= 1e-11 * np.max(np.abs(want)), path


def test_slider_crank_piston_matches_the_closed_form():
    """Piston x = r cos th - sqrt(l^2 - r^2 sin^2 th) (crank r = 200, rod
    l = 500, th the crank's direction, the piston left of the pivot): dx/dr
    (constraints.B.sj.0: r = 100 - it), dx/dl (constraints.B.si.0: l = it +
    200) and the piston velocity's d/dl, 1e-11 of the peak."""
    case = kinem.load(ROOT / "cases" / "slider_crank.toml")
    sens = sensitivity(kinem.compile(case), ["constraints.B.sj.0", "constraints.B.si.0"])
    tr = sens.trajectory
    r, l = 200.0, 500.0
    th, w = tr["crank.phi"] + np.pi, tr["crank.omega"]   # O -> B is the crank's -x direction
    root = np.sqrt(l * l - (r * np.sin(th)) ** 2)
    assert np.max(np.abs(tr["A.x"] - (r * np.cos(th) - root))) < 1e-9 * l
    want = {("A.x", "constraints.B.sj.0"): -(np.cos(th) + r * np.sin(th) ** 2 / root),
            ("A.x", "constraints.B.si.0"): -l / root,
            ("A.vx", "constraints.B.si.0"): -r * r * w * np.sin(th) * np.cos(th) * l / root**3}
    for (column, path), v in want.items():
        got = sens.of(column, path)
        assert np.max(np.abs(got - v)) <= 1e-11 * np.max(np.abs(v)), (column, path)


def test_singular_position_is_infinite_and_said():
    """The stress suite's four-bar through its change point (solved, with
    Phi_q singular at the change point): there every derivative is inf, the
    instant is flagged and the message names it; elsewhere they are finite."""
    case = kinem.load(ROOT / "cases" / "stress" / "change_point.toml")
    model = kinem.compile(case)
    sens = sensitivity(model, [parameters(case)[-1].path])
    assert sens.singular.any() and not sens.singular.all()
    assert np.isinf(sens.derivatives.data[sens.singular]).all()
    assert "singular" in sens.message and f"{sens.derivatives.t[sens.singular][0]:.6g}" in sens.message
    assert np.isfinite(sens.derivatives.data[~sens.singular]).all()


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(CASES), st.data())
def test_random_parameter_and_configuration(path, data):
    """A random parameter, moved to a random nearby design: the derivative
    there matches extrapolated differences (hypothesis over configurations)."""
    case = kinem.load(path)
    p = data.draw(st.sampled_from(parameters(case)))
    model0 = kinem.compile(case)
    shift = data.draw(st.floats(-0.02, 0.02)) * step(model0, p) * 1e3 * 0.05
    try:
        moved = apply(case, {p.path: p.value + shift})
    except kinem.InputError:
        return
    model = kinem.compile(moved)
    if not kinem.solve(model, times=times(moved), options=TIGHT).success:
        return
    q = next(x for x in parameters(moved) if x.path == p.path)
    sens = sensitivity(model, [p.path], times=times(moved), options=TIGHT)
    fd, ok = richardson(moved, q, step(model, q))
    assert worst(model, sens, q, fd, ok) <= 1e-8


def test_cli_writes_every_column_derivative(tmp_path):
    out = tmp_path / "s.csv"
    run = [sys.executable, "-m", "kinem", "sensitivity", str(ROOT / "cases" / "slider_crank.toml"),
           "--parameters", "constraints.A.si.0,constraints.B.si.0", "--out", str(out)]
    subprocess.run(run, check=True, capture_output=True, text=True)
    head = out.read_text().splitlines()[0].split(",")
    assert head[0] == "t" and "d(slider.x)/d(constraints.A.si.0)" in head and "d(B.vx)/d(constraints.B.si.0)" in head
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    sens = sensitivity(model, ["constraints.A.si.0", "constraints.B.si.0"])
    k = head.index("d(slider.x)/d(constraints.A.si.0)")
    assert np.array_equal(table[:, k], sens["d(slider.x)/d(constraints.A.si.0)"])
    bad = subprocess.run(run[:-4] + ["--parameters", "constraints.A.si.9", "--out", str(out)],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "did you mean" in bad.stderr and len(bad.stderr.splitlines()) == 1


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_coordinates_moved_in_place_give_the_validated_tables(path):
    """kinem.sensitivity moves a point's or a vector key's coordinate in
    place (no validated case per parameter): the model's tables from that
    case equal, to 1e-15 relative, those of the validated case that
    kinem.parameters.apply gives."""
    case = kinem.load(path)
    length = kinem.compile(case).length
    fast = 0
    for p in parameters(case):
        value = p.value + 0.25 * max(abs(p.value), 1e-3)
        moved = _replaced(case, p.path, value)
        if moved is None:
            continue
        fast += 1
        a, b = _tables(moved, length), _tables(apply(case, {p.path: value}), length)
        pairs = [(x[1], y[1]) for x, y in zip(a[0], b[0])] + [(a[1], b[1]), (a[2], b[2])]
        assert len(a[0]) == len(b[0])
        for x, y in pairs:
            assert x.keys() == y.keys(), p.path
            for key in x:
                assert np.allclose(x[key], y[key], rtol=1e-15, atol=0), (p.path, key)
    assert fast > 0 or not any(p.path.startswith("points.") for p in parameters(case))
    # and the tangents built from the reached families alone equal those of every table rebuilt
    base = _tables(case, length)
    for p in parameters(case):
        h = 0.125 * max(abs(p.value), 1.0)
        moved = _replaced(case, p.path, p.value + h)
        if moved is None or _reached(case, moved, length, base) is None:
            continue
        (families, functions, outlines), _ = _tangent(case, length, base, p, moved, h)
        tables, f1, o1, _ = _tables(moved, length)
        for (_, t0, d), (_, t1) in zip(families, tables):
            full = _difference(t0, t1, h, p.path)
            assert full.keys() == d.keys() and all(np.array_equal(full[k], d[k]) for k in full), p.path
        for (t0, d), t1 in ((functions, f1), (outlines, o1)):
            full = _difference(t0, t1, h, p.path)
            assert full.keys() == d.keys() and all(np.array_equal(full[k], d[k]) for k in full), p.path


def test_spline_values_tangents_in_one_spline_equal_their_differences():
    """kinem.sensitivity takes every spline.s.j of an outline from one
    spline through unit vectors (_spline_tangents): the outline table's
    tangents equal those of the case moved by h (_tangent, S5), to 1e-12 of
    the largest, on the cam of Table 4.1 (periodic) and every other case
    with a spline outline."""
    checked = 0
    for path in CASES:
        case = kinem.load(path)
        listed = [p for p in parameters(case) if ".spline.s." in p.path]
        if not listed:
            continue
        model = kinem.compile(case)
        base = _tables(case, model.length)
        fast = _spline_tangents(case, listed, base)
        slow = {k: _tangent(case, model.length, base, p, moved, h)
                for k, (p, (moved, h)) in enumerate(zip(listed, moved_cases(case, listed)))}
        for k, ((families, functions, (_, d)), dlocal) in fast.items():
            (_, _, (_, want)), want_local = slow[k]
            assert families == [] and functions[1] == {} and np.array_equal(dlocal, want_local), listed[k].path
            for key in want:
                scale = max(float(np.max(np.abs(want[key]), initial=0.0)), 1e-300)
                assert np.max(np.abs(d[key] - want[key]), initial=0.0) <= 1e-12 * scale, (listed[k].path, key)
            checked += 1
    assert checked >= 10


def _every_parameter_moved(path):
    """(case, model, its parameters, the model's tables, [(k, parameter,
    moved case, step)]) for the tangent-building tests."""
    case = kinem.load(path)
    model = kinem.compile(case)
    listed = parameters(case)
    base = _tables(case, model.length)
    return case, model, listed, base, [(k, p, moved, h) for k, (p, (moved, h))
                                       in enumerate(zip(listed, moved_cases(case, listed)))]


@pytest.mark.parametrize("path", CASES + DRAWN, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_families_built_once_for_every_parameter_give_each_ones_tangent(path):
    """kinem.sensitivity builds a family once over its constraints and every
    parameter's moved ones (_stacked): each parameter's tangent equals the
    one of its own moved case (moved_tangent) exactly."""
    case, model, listed, base, items = _every_parameter_moved(path)
    stacked = _stacked(case, model.length, base, items)
    # a drawn case's moved cases are validated ones (kinem.parameters.apply_many): left to moved_tangent
    assert stacked or any(b.carries for b in case.bodies) or not any(p.path.startswith("points.") for p in listed)
    for k, ((families, functions, outlines), dlocal) in stacked.items():
        _, p, moved, h = items[k]
        (want, _, _), want_local = moved_tangent(case, model.length, base, p, moved, h)
        assert [f[:2] for f in families] == [f[:2] for f in want] and functions[1] == outlines[1] == {}, p.path
        assert np.array_equal(dlocal, want_local), p.path
        for (_, _, _, d), (_, _, _, w) in zip(families, want):
            assert d.keys() == w.keys() and all(np.array_equal(d[key], w[key]) for key in w), p.path


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_driving_coefficients_are_taken_directly(path):
    """A driving function's ``poly.k`` and ``harmonic.NAME`` (not in degrees)
    take _direct's way, a unit of the function table where the nominal is
    (test_numbers_taken_directly_equal_the_rebuilt_tangents compares each
    with its moved case's rebuilt tangent exactly)."""
    case, model, listed, base, items = _every_parameter_moved(path)
    got = _direct(model, [(k, p) for k, p, _, _ in items])
    wanted = [k for k, p in enumerate(listed) if ".poly." in p.path or ".harmonic." in p.path]
    if case.units.get("angle") != "deg":
        assert all(k in got for k in wanted), [listed[k].path for k in wanted if k not in got]
    for k in wanted:
        if k in got:
            d = got[k][0][1][1]["data"]
            assert np.count_nonzero(d) >= 1 and np.all(np.abs(d[d != 0] - 1.0) <= 2e-16), listed[k].path


@pytest.mark.parametrize("path", CASES + DRAWN, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_points_that_land_as_they_are_give_the_rebuilt_tangents(path):
    """kinem.sensitivity takes the tangent of a point that lands as it is in
    its families' tables (Family.lands: a revolute's, a distance's, a
    follower's point; _landed) at its entries directly: each parameter's
    tangent equals the one of its own moved case (moved_tangent: its
    families rebuilt) exactly, every column of every family (a column it
    leaves out: zero), the functions and outlines unmoved; not in a drawn
    case."""
    case, model, listed, base, items = _every_parameter_moved(path)
    got = _landed(model, [(k, p) for k, p, _, _ in items])
    drawn = any(b.carries for b in case.bodies)
    assert not (got and drawn)
    assert got or drawn or not any(c.type in ("revolute", "cam-point") for c in case.constraints), path
    for k, ((families, functions, outlines), dlocal) in got.items():
        _, p, moved, h = items[k]
        (want, (_, wf), (_, wo)), want_local = moved_tangent(case, model.length, base, p, moved, h)
        assert functions[1] == outlines[1] == {} and wf == wo == {}, p.path
        assert [f[:2] for f in families] == [f[:2] for f in want] and np.array_equal(dlocal, want_local), p.path
        for (_, _, _, d), (_, _, _, w) in zip(families, want):   # a column left out is zero
            assert d.keys() <= w.keys() and all(np.array_equal(d.get(key, 0 * w[key]), w[key]) for key in w), p.path


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_functions_numbered_once_for_every_parameter_give_each_ones_tangent(path):
    """kinem.sensitivity numbers every parameter's moved driving function
    once after the model's (_function_tangents): each parameter's tangent
    equals the one of its own moved case (moved_tangent) exactly."""
    case, model, listed, base, items = _every_parameter_moved(path)
    got = _function_tangents(case, base, items)
    assert got or not any(".poly." in p.path for p in listed)
    for k, ((families, (_, d), (_, o)), dlocal) in got.items():
        _, p, moved, h = items[k]
        (want, (_, w), (_, wo)), want_local = moved_tangent(case, model.length, base, p, moved, h)
        assert families == want == [] and o == wo == {} and np.array_equal(dlocal, want_local), p.path
        assert d.keys() == w.keys() and all(np.array_equal(d[key], w[key]) for key in w), p.path


@pytest.mark.parametrize("path", CASES + DRAWN, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_numbers_taken_directly_equal_the_rebuilt_tangents(path):
    """kinem.sensitivity takes a ground's or an absolute constraint's value,
    an outline's centre and a circle's radius directly as a unit of the
    function or outline table (_direct): each parameter's tangent equals
    the one of its own moved case with every family rebuilt
    (moved_tangent) exactly, and moves no family; not in a drawn case,
    where the ground's value moves a drawn frame's tables too."""
    case, model, listed, base, items = _every_parameter_moved(path)
    got = _direct(model, [(k, p) for k, p, _, _ in items])
    drawn = any(b.carries for b in case.bodies)   # left to the moved case: the ground's value places a frame
    assert (got or drawn or not any(p.path.endswith((".value.0", ".center.0", ".radius")) for p in listed))
    assert not (got and drawn)
    for k, ((families, (_, df), (_, do)), dlocal) in got.items():
        _, p, moved, h = items[k]
        (want, (_, wf), (_, wo)), want_local = moved_tangent(case, model.length, base, p, moved, h)
        assert families == [] and all(not v.any() for _, _, _, d in want for v in d.values()), p.path
        assert np.array_equal(dlocal, want_local), p.path
        for d, w in ((df, wf), (do, wo)):
            assert all(np.array_equal(d[key], w[key]) for key in w) and all(not v.any() for key, v in d.items()
                                                                            if key not in w), p.path


def test_public_tangents_rebuild_a_moved_design():
    """kinem.tangents.tangents(model, paths): per path every family's,
    function's and outline's tangent (kinem.tangents._tangent's format);
    the nominal tables plus (value - nominal) x tangent give the tables of
    the case with two parameters moved at once, to 1e-12 of the largest
    (the tables are affine in the case's numbers)."""
    import importlib

    S = importlib.import_module("kinem.tangents")
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    model = kinem.compile(case)
    paths = ["points.A.at.0", "constraints.crank-drive.d.poly.1"]
    tangents = S.tangents(model, paths)
    values = {q.path: q.value for q in parameters(case) if q.path in paths}
    moved = {paths[0]: values[paths[0]] + 0.01, paths[1]: values[paths[1]] * 1.25}
    want = _tables(apply(case, moved), model.length)
    base = _tables(case, model.length)
    assert len(tangents) == 2 and all(len(t[0][0]) == len(base[0]) for t in tangents)
    got = [dict(t) for _, t in base[0]] + [dict(base[1]), dict(base[2])]
    for path, ((families, (_, df), (_, do)), _) in zip(paths, tangents):
        step = moved[path] - values[path]
        for k, d in enumerate([f[2] for f in families] + [df, do]):
            for key, v in d.items():
                got[k][key] = got[k][key] + step * v
    for g, w in zip(got, [t for _, t in want[0]] + [want[1], want[2]]):
        for key in w:
            scale = max(float(np.max(np.abs(w[key]), initial=0.0)), 1.0)
            assert np.max(np.abs(np.asarray(g[key]) - w[key]), initial=0.0) <= 1e-12 * scale, key


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_one_pass_equals_the_solve_and_the_separate_sensitivities(path):
    """kinem.sensitivity's one pass (the march's own factorisation at each
    instant, Plan.march_sensitivity) gives solve's trajectory to the bit and
    the derivatives of the separate pass (a solve, then Plan.sensitivity
    factorising again) to 1e-13 of the largest: the same Phi_q, factorised
    the same way, at the same q. The pivot ratios agree to 8 ulps of the
    largest, not to the bit: the march's Phi_q takes e^{i q} turned by the
    last correction's small angle (kinem/core/src/model.rs, follow: a few
    roundings from sin_cos), the separate pass sin_cos's own."""
    from kinem.parameters import resolve
    from kinem.sensitivity import _derived_frames, _fused, _kept, _layout, core_inputs

    model = kinem.compile(kinem.load(path))
    paths = [p.path for p in parameters(model.case)]
    if not paths or model.m != model.n:
        pytest.skip("no design parameters, or not square")
    listed = resolve(model.case, paths)
    call = _kept(model).call(model, listed)
    named = call.named(model, 3)
    fused = _fused(model, call, kinem.result.OUTPUTS, None, None, named)
    result = kinem.solve(model)
    if fused is None:
        pytest.skip("the march does not take this model or every instant: the separate pass serves it")
    traj, derivatives, data, ratio, least, singular = fused
    assert derivatives.columns == named[2] and derivatives.data is data and not singular.any()
    assert least == ratio.min() or (np.isnan(least) and np.isnan(ratio).any())   # the core's least ratio
    assert np.array_equal(traj.data, result.trajectory.data) and traj.columns == result.trajectory.columns
    separate, ratio2 = model.plan.sensitivity(*core_inputs(model, listed, result))
    columns = _layout(model, 3)[0]
    w = len(columns)
    for k, p in enumerate(listed):
        _derived_frames(model.case, p.path, columns, separate[:, k * w:(k + 1) * w], result.trajectory)
    assert np.abs(ratio - ratio2).max() <= 8 * np.finfo(float).eps * ratio2.max()
    assert np.array_equal(ratio >= 1e-6, ratio2 >= 1e-6)
    whole = sensitivity(model, paths)
    regular = ratio >= 1e-6
    scale = np.abs(separate[regular]).max()
    assert np.abs(whole.derivatives.data[regular] - separate[regular]).max() <= 1e-13 * scale


def test_the_time_limit_holds_for_the_whole_call(monkeypatch):
    """Under Options.max_seconds a sensitivity counts the whole call against
    the limit: the solve it falls back to when the one pass does not serve
    it (here a pass made to spend 0.3 s of a 0.2 s limit, then decline)
    gets what is left, not a fresh limit, and stops at the time limit; the
    same call without the spent time succeeds."""
    import importlib
    import time

    from kinem.errors import AnalysisError

    S = importlib.import_module("kinem.sensitivity")
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    path, options = parameters(model.case)[0].path, kinem.Options(max_seconds=0.2)
    sensitivity(model, path)   # the lazy imports and the model's march layout, outside the limit
    assert sensitivity(model, path, options=options).derivatives.data.shape[0] == len(model.times)

    def spent(*args):
        time.sleep(0.3)
        return None

    monkeypatch.setattr(S, "_fused", spent)
    with pytest.raises(AnalysisError, match="time limit"):
        sensitivity(model, path, options=options)


def test_derivative_columns_are_found_by_name():
    """The derivatives' column index is computed from the columns' and the
    parameters' places (kinem.sensitivity._Places), not stored per name:
    every name finds its own column, in the columns' order, and a name
    that is none is not found (an UnknownColumn with a suggestion)."""
    from kinem.errors import UnknownColumn

    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    paths = [p.path for p in parameters(model.case)][:3]
    d = sensitivity(model, paths).derivatives
    assert list(d._index) == list(d.columns) and len(d._index) == len(d.columns) == 3 * len(d.columns) // 3
    for k, name in enumerate(d.columns):
        assert d._index[name] == k and name in d
        assert np.array_equal(d[name], d.data[:, k], equal_nan=True)
    for bad in ("B.x", f"d(B.x)/d({paths[0]}", f"d(nothing)/d({paths[0]})", "d(B.x)/d(points.nowhere.at.0)", 3):
        assert bad not in d
    with pytest.raises(UnknownColumn, match="did you mean"):
        d[f"d(B.x)/d({paths[0]}.0)"]


def test_results_made_without_init_have_every_field_and_are_read_only():
    """kinem.result.frozen makes a Sensitivity, its derivatives' Trajectory
    and a SolveResult from a dict (no __init__): each has every field of its
    dataclass (a field added later and not filled would fail here), and the
    arrays a user gets are read-only, as __init__ makes them."""
    from dataclasses import fields

    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    s = sensitivity(model, [p.path for p in parameters(model.case)][:2])
    r = kinem.solve(model)
    for obj in (s, s.derivatives, s.trajectory, r, r.trajectory):
        assert {f.name for f in fields(obj)} <= obj.__dict__.keys()
    for a in (s.derivatives.t, s.derivatives.data, s.trajectory.t, s.trajectory.data, r.q, r.qd, r.qdd,
              r.trajectory.t, r.trajectory.data):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = 1.0


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_compile_keeps_the_tables_the_tangents_move(path):
    """compile keeps the families' tables with every function and outline
    its own number (Model.tables, what the tangents move), read-only: the
    same as those built again from the case (kinem.moved_tables._tables),
    column by column to the bit, with the same functions and outlines
    numbered by each family."""
    model = kinem.compile(kinem.load(path))
    kept, again = model.tables, _tables(model.case, model.length)
    assert [k for k, _ in kept[0]] == [k for k, _ in again[0]] and kept[3] == again[3]
    for a, b in [(x[1], y[1]) for x, y in zip(kept[0], again[0])] + [(kept[1], again[1]), (kept[2], again[2])]:
        assert a.keys() == b.keys()
        for key in a:
            assert a[key].dtype == b[key].dtype and same(a[key], b[key]), key
            assert not a[key].flags.writeable, key


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_the_cores_tables_taken_from_the_kept_ones_are_those_made_again(path):
    """compile gives the core its tables, equal functions and outlines
    sharing a number, with their arrays taken from the tables it keeps
    (kinem.model.core_tables(..., separate)), no spline fitted twice: the
    same, to the bit, as the shared tables made again from the families."""
    from kinem.model import core_tables

    model = kinem.compile(kinem.load(path))
    taken, made = core_tables(model.families, separate=model.tables), core_tables(model.families)
    assert [k for k, _ in taken[0]] == [k for k, _ in made[0]]
    for a, b in [(x[1], y[1]) for x, y in zip(taken[0], made[0])] + [(taken[1], made[1]), (taken[2], made[2])]:
        assert a.keys() == b.keys()
        for key in a:
            assert a[key].dtype == b[key].dtype and a[key].shape == b[key].shape, key
            assert a[key].tobytes() == b[key].tobytes(), key


@pytest.mark.parametrize("name", ["four_bar", "cam_table41"])
def test_a_models_kept_tangents_give_the_first_calls_figures(name):
    """A model's later calls take each parameter's tangent as its first
    call built it (kinem.sensitivity._KEPT): the same derivatives to the
    bit as a fresh model's, whatever the parameters asked with it, and the
    kept arrays cannot be written."""
    from kinem.sensitivity import tangent_inputs, _resolved
    case = kinem.load(ROOT / "cases" / f"{name}.toml")
    every = [p.path for p in parameters(case)]
    model = kinem.compile(case)
    first = sensitivity(model, every[:3])
    again = sensitivity(model, every[1:5])   # two kept, two new
    fresh = sensitivity(kinem.compile(case), every[1:5])
    assert np.array_equal(again.derivatives.data, fresh.derivatives.data)
    assert np.array_equal(first["d(" + first.trajectory.columns[0] + ")/d(" + every[1] + ")"],
                          fresh["d(" + fresh.trajectory.columns[0] + ")/d(" + every[1] + ")"])
    core = tangent_inputs(model, _resolved(model, every[:5]))[1]
    arrays = [v for part in core for table in [d for _, d in part[0]] + [part[1], part[2]] for v in table.values()]
    assert arrays and not any(v.flags.writeable for v in arrays)


def test_the_kept_core_setup_gives_a_fresh_ones_figures_and_fits_its_plan_alone():
    """A model's kept core set-up (Plan.sensitivity_setup, kept per list of
    parameters: kinem.sensitivity._Call.setup) is made once and gives, call
    after call, the derivatives of a set-up made anew to the bit; a set-up
    made by another plan, even one of a model of the same size, is
    refused (ValueError), never run."""
    from kinem.result import OUTPUTS, _layout
    from kinem.sensitivity import _fused, _kept, _resolved
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    paths = [p.path for p in parameters(model.case)][:4]
    first = sensitivity(model, paths)
    call = _kept(model).call(model, _resolved(model, paths))
    kept = call.setup(model, 3)
    again = sensitivity(model, paths)
    assert call.setup(model, 3) is kept
    assert np.array_equal(first.derivatives.data, again.derivatives.data)
    src = _layout(model, 3)[1]
    tables, core, pattern, (pc, local, dlocal) = call.tangents
    new = model.plan.sensitivity_setup(tables, core, pattern, (src, pc, local, dlocal))
    assert new is not kept
    call._setups[3] = (model.plan, new)
    named = call.named(model, 3)
    fused = _fused(model, call, OUTPUTS, None, None, named)
    assert fused is not None and np.array_equal(fused[2], again.derivatives.data)
    twin = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))   # the same tables, its own plan
    foreign = twin.plan.sensitivity_setup(tables, core, pattern, (src, pc, local, dlocal))
    call._setups[3] = (model.plan, foreign)
    with pytest.raises(ValueError, match="not this model's"):
        _fused(model, call, OUTPUTS, None, None, named)


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "cam_table41", "quick_return_1"])
def test_the_fused_pass_in_its_kept_room_gives_a_fresh_runs_figures(name):
    """The fused pass's run of instants (crate::sensitivity::Room, kept by
    its core set-up, SensSetup) is entered again by the next call of the
    same parameters instead of made anew: call after call, with other
    lists' calls and other instants between, every derivative and pivot
    ratio is a fresh model's first call's to the bit (a parameter alone,
    a ground's shift with its fixed row, four, all of them)."""
    case = kinem.load(ROOT / "cases" / f"{name}.toml")
    every = [p.path for p in parameters(case)]
    model = kinem.compile(case)
    lists = [every[:1], every[-1:], every[:4], every]
    half = model.times[: len(model.times) // 2 + 1]
    fresh = {}
    for k, paths in enumerate(lists):
        for times in (None, half):
            f = sensitivity(kinem.compile(case), paths, times=times)
            fresh[k, times is None] = (f.derivatives.data.tobytes(), f.conditioning.tobytes())
    for _ in range(2):
        for k, paths in list(enumerate(lists)) + list(enumerate(lists))[::-1]:
            for times in (None, half, None):
                s = sensitivity(model, paths, times=times)
                assert (s.derivatives.data.tobytes(), s.conditioning.tobytes()) == fresh[k, times is None], (k, times)


def test_the_separate_pass_keeps_its_setup_per_levels_and_gives_a_fresh_ones_figures():
    """The separate pass (outputs the fused pass does not take: positions
    alone, positions and velocities) runs from a set-up kept per model,
    parameters and levels (Plan.sensitivity_kept): made once, the figures
    of Plan.sensitivity with a set-up made anew to the bit, call after
    call; a set-up another plan made is refused (ValueError)."""
    from kinem.sensitivity import _kept, _resolved, core_inputs
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    paths = [p.path for p in parameters(model.case)][:3]
    listed = _resolved(model, paths)
    call = _kept(model).call(model, listed)
    for outputs, levels in ((("positions",), 1), (("positions", "velocities"), 2)):
        first = sensitivity(model, paths, outputs=outputs)
        kept = call._setups[levels][1]
        again = sensitivity(model, paths, outputs=outputs)
        assert call._setups[levels][1] is kept
        result = kinem.solve(model, outputs)
        fresh, ratio = model.plan.sensitivity(*core_inputs(model, listed, result))
        assert np.array_equal(first.derivatives.data, fresh) and np.array_equal(again.derivatives.data, fresh)
        assert np.array_equal(first.conditioning, ratio)
    twin = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    X = [np.ascontiguousarray(result.q), np.ascontiguousarray(result.qd)]
    with pytest.raises(ValueError, match="not this model's"):
        twin.plan.sensitivity_kept(kept, np.ascontiguousarray(result.trajectory.t), X)
