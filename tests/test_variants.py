"""Issue 31 item 5: variants of one mechanism solved together
(kinem.solve(model, parameters=...), kinem.variants) against separate
solves of each variant's own case, the affine tables against validated
cases', and per-variant failure, input errors and limits."""
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import kinem
from kinem import native
from kinem.errors import InputError
from kinem.moved_tables import _tables
from kinem.parameters import apply, apply_many, parameters
from kinem.variants import _tangents, affine

from test_bounds import interrupt

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml"))
TIMES = np.linspace(0.0, 0.6, 13)
SLIDER_CASE = kinem.load(ROOT / "cases" / "slider_crank.toml")
SLIDER = SLIDER_CASE, kinem.compile(SLIDER_CASE)


def alone(case, values, q0, outputs, times=TIMES, options=None):
    """The columns of one variant solved by itself (its own compiled case) from q0."""
    r = kinem.solve(kinem.compile(apply(case, values)), times=times, q0=q0, options=options)
    assert r.success, r.message
    return np.column_stack([r.trajectory[c] for c in outputs])


def nominal_start(model, times=TIMES):
    return kinem.solve(model, times=times[:1]).q[0]


@pytest.mark.parametrize("name, moves", [
    ("slider_crank", {"constraints.B.si.0": 6.0, "constraints.T.qi.1": 3.0, "constraints.crank-drive.d.poly.1": 0.2}),
    ("four_bar", {"points.B.at.0": 2e-3, "constraints.A.sj.0": 2e-3, "points.O4.at.1": 1e-3}),
])
def test_batch_equals_separate_solves(name, moves):
    """Each variant of the batch equals its own case solved alone from the
    nominal's first state, every column (named points, rates) to 1e-12 of
    the column's size."""
    case = kinem.load(ROOT / "cases" / f"{name}.toml")
    model = kinem.compile(case)
    listed = {p.path: p.value for p in parameters(case)}
    rng = np.random.default_rng(3)
    N = 5
    values = {path: listed[path] + rng.uniform(-1, 1, N) * dv for path, dv in moves.items()}
    r = kinem.solve(model, parameters=values, times=TIMES)
    assert r.data.shape == (N, len(TIMES), len(r.columns)) and r.success.all() and not r.merged
    assert not r.resolved.any() and not r.flipped.any()
    assert all(s == native.Why.ACCEPTED for s in r.status) and (r.failed_at == len(TIMES)).all()
    with pytest.raises(ValueError):
        r.data[0, 0, 0] = 1.0   # a frozen result
    q0 = nominal_start(model)
    for k in range(N):
        ref = alone(case, {p: v[k] for p, v in values.items()}, q0, r.columns)
        size = np.maximum(np.abs(ref).max(axis=0), 1e-300)
        assert (np.abs(r.data[k] - ref) <= 1e-12 * size).all()
    assert np.ptp(r.data[:, -1], axis=0).max() > 1e-6 * np.abs(r.data).max()   # the variants differ


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_affine_tables_are_a_validated_cases(path):
    """For random moves of three affine parameters at once, the nominal's
    tables plus sum dv tangent (what the core forms per variant) equal the
    tables of the variant's validated case (kinem.parameters.apply_many),
    relative 1e-12 of each column's size."""
    case = kinem.load(path)
    model = kinem.compile(case)
    listed = [p for p in parameters(case) if affine(case, p.path)]
    rng = np.random.default_rng(len(listed))
    picked = [listed[k] for k in rng.choice(len(listed), size=min(3, len(listed)), replace=False)]
    base, tangents = _tangents(model, picked)
    designs = [{p.path: p.value + rng.uniform(-1, 1) * 1e-3 * max(abs(p.value), model.length / 10)
                for p in picked} for _ in range(3)]
    checked = 0
    for design, variant in zip(designs, apply_many(case, designs)):
        if isinstance(variant, InputError):
            continue
        dv = [design[p.path] - p.value for p in picked]
        tables, functions, outlines, _ = _tables(variant, model.length)
        pairs = [(t0, t1, [fams[k][2] for (fams, _, _), _ in tangents])
                 for k, ((_, t0), (_, t1)) in enumerate(zip(base[0], tables))]
        pairs += [(base[1], functions, [f[1] for (_, f, _), _ in tangents]),
                  (base[2], outlines, [o[1] for (_, _, o), _ in tangents])]
        for t0, t1, tans in pairs:
            for key, v in t0.items():
                if v.dtype.kind in "iu":
                    assert np.array_equal(v, t1[key]), key
                    continue
                formed = v + sum(d * tan[key] for d, tan in zip(dv, tans) if key in tan)
                size = max(np.abs(t1[key]).max(initial=0.0), 1e-300)
                assert np.abs(formed - t1[key]).max(initial=0.0) <= 1e-12 * size, (path.stem, key)
        checked += 1
    assert checked >= 1


def test_a_failing_variant_is_reported_and_leaves_the_others_alone():
    """A four-bar whose coupler cannot close the loop fails on its own
    (success False, a status, a message, NaN rows); the other variants are
    the same numbers as in a batch without it."""
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    model = kinem.compile(case)
    path = "constraints.A.sj.0"
    v0 = next(p.value for p in parameters(case) if p.path == path)
    good = v0 + np.array([-1e-3, 0.0, 1e-3])
    bad = np.insert(good, 1, v0 - 10.0)   # a coupler 10 m long: no assembly
    r = kinem.solve(model, parameters={path: bad}, times=TIMES, outputs=["B.x", "B.y"])
    ok = kinem.solve(model, parameters={path: good}, times=TIMES, outputs=["B.x", "B.y"])
    assert r.success.tolist() == [True, False, True, True] and ok.success.all()
    assert r.status[1] != native.Why.ACCEPTED and r.failed_at[1] < len(TIMES) and r.messages[1]
    assert np.isnan(r.data[1]).all() and not r.messages[0]
    np.testing.assert_array_equal(r.data[[0, 2, 3]], ok.data)


def test_inputs_are_checked():
    case = kinem.load(ROOT / "cases" / "slider_crank.toml")
    model = kinem.compile(case)
    with pytest.raises(InputError, match="did you mean 'constraints.B.si.0'"):
        kinem.solve(model, parameters={"constraints.B.sii.0": [300.0]})
    with pytest.raises(InputError, match="different lengths"):
        kinem.solve(model, parameters={"constraints.B.si.0": [300.0, 301.0], "constraints.A.si.0": [1.0]})
    with pytest.raises(InputError, match="finite numbers"):
        kinem.solve(model, parameters={"constraints.B.si.0": [np.nan]})
    with pytest.raises(InputError, match="did you mean 'B.x'"):
        kinem.solve(model, parameters={"constraints.B.si.0": [300.0]}, outputs=["B.xx"])


def test_outputs_limit_the_columns():
    """outputs= column names give only those columns, in that order, the
    same numbers as the full batch's; stages give every column of them."""
    case = kinem.load(ROOT / "cases" / "slider_crank.toml")
    model = kinem.compile(case)
    values = {"constraints.B.si.0": [295.0, 300.0, 305.0]}
    full = kinem.solve(model, parameters=values, times=TIMES)
    few = kinem.solve(model, parameters=values, times=TIMES, outputs=["B.y", "slider.x"])
    assert few.columns == ("B.y", "slider.x") and few.data.shape == (3, len(TIMES), 2)
    np.testing.assert_allclose(few["B.y"], full["B.y"], rtol=1e-13, atol=1e-12)
    positions = kinem.solve(model, parameters=values, times=TIMES, outputs=("positions",))
    assert "B.x" in positions.columns and "B.vx" not in positions.columns
    assert positions.data.shape == (3, len(TIMES), len(positions.columns))


def test_a_named_dimension_and_a_drawn_frame():
    """A [parameters] name (the sum over its uses) is solved in the core; a
    parameter that moves a drawn body's frame takes the merged path; both
    equal separate solves."""
    named = kinem.load(ROOT / "tests" / "data" / "four_bar_named.toml")
    r = kinem.solve(kinem.compile(named), parameters={"coupler": [0.299, 0.301]}, times=TIMES, outputs=["B.x"])
    assert not r.merged and r.success.all()
    q0 = nominal_start(kinem.compile(named))
    for k, v in enumerate([0.299, 0.301]):
        ref = alone(named, {"parameters.coupler": v}, q0, ("B.x",))
        assert np.abs(r.data[k] - ref).max() <= 1e-12 * np.abs(ref).max()
    drawn = kinem.load(ROOT / "tests" / "data" / "drawn" / "four_bar.toml")
    path = "points.O4.at.0"
    assert not affine(drawn, path)
    v0 = next(p.value for p in parameters(drawn) if p.path == path)
    m = kinem.compile(drawn)
    r = kinem.solve(m, parameters={path: [v0 - 1e-3, v0 + 1e-3]}, times=TIMES, outputs=["B.x", "B.y"])
    assert r.merged and r.success.all()
    q0 = nominal_start(m)
    for k, v in enumerate([v0 - 1e-3, v0 + 1e-3]):
        ref = alone(drawn, {path: v}, q0, ("B.x", "B.y"))
        np.testing.assert_allclose(r.data[k], ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_the_time_limit_stops_every_variant():
    """A time limit already past: every variant out of time, reported, no exception."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    r = kinem.solve(model, parameters={"constraints.B.si.0": np.linspace(290, 310, 8)},
                    options=kinem.Options(max_seconds=1e-9))
    assert not r.success.any() and all(s == native.Why.OUT_OF_TIME for s in r.status)
    assert all("time limit" in m for m in r.messages)


SIGINT_BATCH = textwrap.dedent("""
    import time, traceback
    import numpy as np
    import kinem
    model = kinem.compile(kinem.load("cases/slider_crank.toml"))
    times = np.linspace(0.0, 5.0, 100_000)
    rods = {"constraints.B.si.0": np.linspace(290.0, 310.0, 64)}
    kinem.solve(model, outputs=["B.x"], times=times[:100], parameters=rods)   # warm
    start = time.perf_counter()
    kinem.solve(model, outputs=["B.x"], times=times[:10_000], parameters=rods)
    whole = 10 * (time.perf_counter() - start)   # the whole batch's time, estimated
    try:
        print("ready", whole, flush=True)
        kinem.solve(model, outputs=["B.x"], times=times, parameters=rods)
        print("finished", flush=True)
    except KeyboardInterrupt as e:
        # where it surfaced: inside kinem.solve, or before the call began
        inside = len(traceback.extract_tb(e.__traceback__)) > 1
        print("interrupted", "inside" if inside else "before", flush=True)
""")


def test_sigint_stops_a_batch():
    """SIGINT while the core marches 64 variants of 1e5 instants:
    KeyboardInterrupt comes long before the batch could have finished. The
    bound is relative, not a timing: half of what the batch had left by the
    child's own estimate (a tenth of it, timed in the same process), so it
    holds at any load; a core that did not poll would answer only at the end
    (the core polls every 2 ms: measured latencies are milliseconds). On a
    loaded machine the signal can land before the child enters the solve
    (it says so), or after the batch has ended ("finished"): that child
    proves nothing, and another is run (waits 0.1, 0.2, 0.3, 0.1 s; the
    batch takes about 0.7 s on a quiet machine)."""
    for wait in (0.1, 0.2, 0.3, 0.1):
        line, latency, whole = interrupt(SIGINT_BATCH, wait)
        if line == ["interrupted", "inside"]:
            break
    assert line == ["interrupted", "inside"]
    assert latency < 0.5 * (whole - wait), (latency, whole, wait)


def test_a_variant_the_march_stops_is_solved_alone():
    """Six instants over the four-bar's 2.5 s: the march stops every variant
    at a jump, and each is solved again by solve (sub-steps): resolved,
    successful, with the march's verdict kept, equal to its own solve."""
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    model = kinem.compile(case)
    coarse = np.linspace(0.0, 2.5, 6)
    values = 0.11 + np.array([-1e-3, 1e-3])
    r = kinem.solve(model, parameters={"points.B.at.0": values}, times=coarse, outputs=["B.x", "B.y"])
    assert r.success.all() and r.resolved.all()
    assert all(s == native.Why.JUMP for s in r.status) and (r.failed_at < len(coarse)).all()
    q0 = nominal_start(model, coarse)
    for k, v in enumerate(values):
        ref = alone(case, {"points.B.at.0": v}, q0, ("B.x", "B.y"), times=coarse)
        np.testing.assert_allclose(r.data[k], ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_options_the_march_does_not_take_use_the_merged_path():
    """Jacobian reuse (modified Newton, step by step) takes the merged path,
    to the same numbers as the batch within the tolerance; a trace or q0 is refused."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    values = {"constraints.B.si.0": [295.0, 305.0]}
    r = kinem.solve(model, parameters=values, times=TIMES, outputs=["B.x"],
                    options=kinem.Options(jacobian_reuse=True))
    ref = kinem.solve(model, parameters=values, times=TIMES, outputs=["B.x"])
    assert r.merged and not ref.merged and r.success.all()
    np.testing.assert_allclose(r.data, ref.data, rtol=0, atol=1e-8 * np.abs(ref.data).max())
    with pytest.raises(InputError, match="trace or q0"):
        kinem.solve(model, parameters=values, trace=True)


def test_a_radius_of_zero_or_less_is_bad_input_for_that_variant():
    """A gear's pitch radius must be positive: a variant setting it to 0 is
    refused as bad input (success False, its rows NaN), the others solved."""
    case = kinem.load(ROOT / "cases" / "gear_pair.toml")
    r0 = next(p.value for p in parameters(case) if p.path == "constraints.mesh.ri")
    r = kinem.solve(kinem.compile(case), parameters={"constraints.mesh.ri": [r0, 0.0, 1.01 * r0]}, times=TIMES)
    assert r.success.tolist() == [True, False, True]
    assert "bad input" in r.messages[1] and "positive" in r.messages[1] and np.isnan(r.data[1]).all()


@pytest.mark.parametrize("merged", [False, True])
def test_a_refused_variant_says_bad_input_in_its_status(merged):
    """A variant refused before the march has the status BAD_INPUT (with its
    message), on the lanes and on the merged path alike. It used to read
    ACCEPTED on the lanes (marched as the nominal), and the merged path
    solved it (a pitch radius of -1: its numbers set in place, unchecked)."""
    case = kinem.load(ROOT / "cases" / "gear_pair.toml")
    r0 = next(p.value for p in parameters(case) if p.path == "constraints.mesh.ri")
    options = kinem.Options(jacobian_reuse=True) if merged else None   # the march does not take it: merged
    r = kinem.solve(kinem.compile(case), parameters={"constraints.mesh.ri": [r0, -1.0]}, times=TIMES,
                    options=options)
    assert r.merged is merged and r.success.tolist() == [True, False]
    assert r.status == (native.Why.ACCEPTED, native.Why.BAD_INPUT), r.status
    assert r.status[1].message.startswith("bad input") and r.messages[1].startswith("bad input")


@settings(max_examples=8, deadline=None)
@given(st.lists(st.floats(-20.0, 20.0), min_size=1, max_size=3), st.floats(-5.0, 5.0))
def test_any_rod_and_offset_equals_its_own_solve(rods, offset):
    """Hypothesis: slider-cranks of any rod length within +-20 mm and slider
    line offset within +-5 mm, batched, equal their own solves to 1e-12."""
    case, model = SLIDER
    values = {"constraints.B.si.0": 300.0 + np.array(rods), "constraints.T.qi.1": np.full(len(rods), offset)}
    r = kinem.solve(model, parameters=values, times=TIMES, outputs=["B.x", "B.vy", "slider.ax"])
    assert r.success.all()
    q0 = nominal_start(model)
    for k in range(len(rods)):
        ref = alone(case, {p: v[k] for p, v in values.items()}, q0, r.columns)
        assert (np.abs(r.data[k] - ref) <= 1e-12 * np.abs(ref).max(axis=0)).all()


def test_the_monte_carlo_through_variants_equals_sample_by_sample():
    """kinem.tolerance's Monte Carlo band through the variants' batch equals
    the one solved sample by sample (chunk=1, each its own case) to 1e-12 of
    the band's size."""
    from kinem.tolerance import tolerance

    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    batch = tolerance(model, samples=24, outputs=["B.x", "B.y"])
    alone_ = tolerance(model, samples=24, outputs=["B.x", "B.y"], chunk=1)
    assert len(batch.rejected) == len(alone_.rejected) == 0
    for c in ("B.x.mc-", "B.x.mc+", "B.y.mc-", "B.y.mc+"):
        assert np.abs(batch[c] - alone_[c]).max() <= 1e-12 * np.abs(alone_[c]).max()
