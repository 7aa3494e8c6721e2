"""Issue 31 item 5: variants marched as lanes (kinem/core/src/lanes.rs, 8
variants a group) give each variant the figures of the variants marched one
by one (lanes=False; tests/test_variants.py checks those against each
variant's own solve): every case in cases/, a lane that stops mid-march, a
count of variants that is not a multiple of the lane width."""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import kinem
from kinem import native
from kinem.parameters import parameters
from kinem.variants import affine, solve_variants

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml"))
MODELS = {}


def model_of(path):
    if path not in MODELS:
        case = kinem.load(path)
        MODELS[path] = case, kinem.compile(case)
    return MODELS[path]


def same(a, b):
    """Lanes a against one by one b: the same verdicts, and every column
    to 1e-12 of its size (the arithmetic is the same: in practice equal)."""
    assert a.status == b.status and (a.failed_at == b.failed_at).all()
    assert (a.success == b.success).all() and (a.resolved == b.resolved).all()
    assert np.array_equal(np.isnan(a.data), np.isnan(b.data))
    size = np.maximum(np.nanmax(np.abs(b.data), axis=(0, 1), initial=0.0), 1e-300)
    gap = np.nan_to_num(np.abs(a.data - b.data), nan=0.0)
    assert (gap <= 1e-12 * size).all(), gap.max()


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), count=st.integers(9, 19))
def test_lanes_equal_one_by_one_on_every_case(path, seed, count):
    """Hypothesis: up to three affine parameters of each case moved at
    random (1e-3 of their size), 9 to 19 variants (one or two groups of 8
    and the rest alone) over the case's first 13 instants, all stages."""
    case, model = model_of(path)
    listed = [p for p in parameters(case) if affine(case, p.path)]
    rng = np.random.default_rng(seed)
    picked = [listed[k] for k in rng.choice(len(listed), size=min(3, len(listed)), replace=False)]
    values = {p.path: p.value + rng.uniform(-1, 1, count) * 1e-3 * max(abs(p.value), 1.0) for p in picked}
    times = model.times[:13]
    lanes = solve_variants(model, values, times=times, lanes=True)
    alone = solve_variants(model, values, times=times, lanes=False)
    same(lanes, alone)


def test_a_lane_that_stops_leaves_its_group_alone():
    """A slider-crank whose rod (150 mm) is shorter than its crank (200 mm)
    stops at a limit position mid-march, in a group with seven good ones:
    it alone fails, with its verdict and message, its rows NaN from there
    on; the others run to the
    end with the numbers they have in a batch without it."""
    case, model = model_of(ROOT / "cases" / "slider_crank.toml")
    path = "constraints.B.si.0"
    good = 300.0 + np.arange(9.0)
    mixed = np.insert(good, 3, -50.0)
    r = solve_variants(model, {path: mixed}, outputs=["B.x", "slider.vx"], lanes=True)
    ok = solve_variants(model, {path: good}, outputs=["B.x", "slider.vx"], lanes=True)
    assert r.success.tolist() == [k != 3 for k in range(10)] and ok.success.all()
    assert r.status[3] != native.Why.ACCEPTED and 0 < r.failed_at[3] < len(model.times) and r.messages[3]
    stop = r.failed_at[3]   # its rows up to the limit position, NaN from there
    assert np.isfinite(r.data[3, :stop]).all() and np.isnan(r.data[3, stop:]).all()
    assert not any(r.messages[k] for k in range(10) if k != 3)
    np.testing.assert_array_equal(r.data[np.arange(10) != 3], ok.data)
    same(r, solve_variants(model, {path: mixed}, outputs=["B.x", "slider.vx"], lanes=False))


@pytest.mark.parametrize("count", [1, 7, 8, 13, 17])
def test_any_count_of_variants(count):
    """Counts below, at and off a multiple of the lane width: each variant
    as one by one, the variants distinct."""
    case, model = model_of(ROOT / "cases" / "four_bar.toml")
    values = {"points.B.at.0": 0.11 + np.linspace(-1e-3, 1e-3, count)}
    r = solve_variants(model, values, outputs=["B.x", "B.y"], lanes=True)
    assert r.data.shape == (count, len(model.times), 2) and r.success.all()
    same(r, solve_variants(model, values, outputs=["B.x", "B.y"], lanes=False))
    if count > 1:
        assert np.ptp(r.data[:, -1, 0]) > 1e-7
