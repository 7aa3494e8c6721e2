"""The block march (kinem/march.py) gives what the step-by-step march gives:
the same branch, status, events and diagnosis, with positions within what
the Newton tolerance allows, and it hands singular configurations to the
tracker."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import march

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml")) + sorted((ROOT / "cases" / "stress").glob("*.toml"))
BOTH = [kinem.OUTPUTS, ("positions",)]


def pair(case, outputs, block=64):
    step = kinem.solve(kinem.compile(replace(case, block=1)), outputs)
    blocked = kinem.solve(kinem.compile(replace(case, block=block)), outputs)
    return step, blocked


def agreement(model, step, blocked):
    """Both stop at a scaled residual <= tol from different starts, so they
    may differ by about tol / (smallest pivot ratio) in dimensionless units
    (the Jacobian's inverse amplifies residual differences by at most
    1 / sigma_min, and the pivot ratio bounds sigma_min from below to within
    a modest factor); a factor 10 covers that bound's slack."""
    tol = model.case.tolerance
    cond = min(step.conditioning.min(), blocked.conditioning.min())
    return 10 * tol / max(cond, 1e-8)


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_block_agrees_with_step_by_step(path, outputs):
    case = kinem.load(path)
    model = kinem.compile(case)
    step, blocked = pair(case, outputs)
    assert (step.success, step.status, len(step.q)) == (blocked.success, blocked.status, len(blocked.q))
    assert [t for t, _ in step.events] == pytest.approx([t for t, _ in blocked.events], abs=1e-9 * case.end)
    if not step.success:
        assert step.message.split(":")[0] == blocked.message.split(":")[0]  # same instant
    bound = agreement(model, step, blocked)
    for a, b in [(step.q, blocked.q)] + ([(step.qd, blocked.qd)] if step.qd is not None else []):
        err = np.abs(a - b) / model.col_scale
        scale = 1.0 if a is step.q else max(1.0, float(np.abs(a / model.col_scale).max()))
        assert err.max() <= bound * scale
    ok = np.isfinite(step.conditioning) & (step.conditioning > 0)
    # the same configurations, so the same conditioning to a few digits
    assert np.allclose(step.conditioning[ok], blocked.conditioning[ok], rtol=1e-3)


@pytest.mark.parametrize("block", [2, 7, 4096])
def test_any_block_size_gives_the_same_run(block):
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    step, blocked = pair(case, kinem.OUTPUTS, block)
    assert blocked.success and np.abs(step.q - blocked.q).max() < 1e-9 * case.end


def test_block_is_used_and_cheaper_in_calls():
    """The default march solves instants together: fewer family calls than instants."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    calls = []
    fam = model.families[0]
    original = type(fam).phi

    def counting(self, q, t):
        calls.append(q.shape)
        return original(self, q, t)

    type(fam).phi = counting
    try:
        r = kinem.solve(model)
    finally:
        type(fam).phi = original
    assert r.success and len(calls) < len(r.q) / 4
    assert max(s[0] for s in calls if len(s) == 2) >= 32


def blocks(model, trace):
    return march.usable(model, trace, len(model.times))


def test_not_used_where_it_cannot_be():
    """Redundant (least squares), sparse, large, traced and modified-Newton runs go step by step."""
    par = kinem.compile(kinem.load(ROOT / "cases" / "stress" / "parallelogram_redundant.toml"))
    assert par.m > par.n and not blocks(par, False)
    fb = kinem.load(ROOT / "cases" / "four_bar.toml")
    assert blocks(kinem.compile(fb), False)
    assert not blocks(kinem.compile(fb), True)
    assert not blocks(kinem.compile(replace(fb, linear_solver="sparse")), False)
    assert not blocks(kinem.compile(replace(fb, jacobian_reuse=True)), False)
    assert not blocks(kinem.compile(replace(fb, block=1)), False)
    from kinem.reference import n_four_bar

    big = kinem.compile(kinem.load_dict(n_four_bar(34)))  # 70 bodies, one block of 210 coordinates: step by step
    assert big.blocks.size > march.LIMIT and not blocks(big, False)
    chain = kinem.compile(kinem.load_dict(n_four_bar(12)))  # 78 coordinates: blocks
    assert chain.blocks.count == 1 and blocks(chain, False)


class _Flip:
    """Newton that lands instant ``at`` of every block of more than one
    instant on the mirrored (other) assembly branch of a four-bar."""

    def __init__(self, block, at):
        self.block, self.at, self.original = block, at, block.newton

    def __call__(self, Q, t):
        Q, it, res, final, done = self.original(Q, t)
        if len(t) > self.at:
            Q = Q.copy()
            Q[self.at:] += 0.3  # far from every instant's predictor: a jump
        return Q, it, res, final, done


def test_a_jump_inside_a_block_is_cut_off_there():
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    from kinem.analysis import Data
    from kinem.tracking import Tracker

    for outputs in BOTH:
        need_a = "accelerations" in outputs
        need_v = need_a or "velocities" in outputs
        tracker = Tracker(model, Data(q=model.q0.copy()), need_v, need_a)
        tracker.start(model.times[0])
        block = march.Block(model, tracker)
        block.newton = _Flip(block, 5)
        got = block.advance(model.times[1:17])
        assert len(got) == 5 and tracker.history[-1].t == model.times[5]


def test_a_det_flip_inside_a_block_is_cut_off_there():
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    from kinem.analysis import Data
    from kinem.tracking import Tracker

    tracker = Tracker(model, Data(q=model.q0.copy()), True, True)
    tracker.start(model.times[0])
    block = march.Block(model, tracker)
    original = march.factorize

    def flipped(Js, blocks):
        f, pivot, det = original(Js, blocks)
        det = det.copy()
        det[3:] *= -1
        return f, pivot, det

    march.factorize = flipped
    try:
        got = block.advance(model.times[1:9])
    finally:
        march.factorize = original
    assert len(got) == 3


def test_factorize_matches_linalg_factor():
    """Pivot ratio and det sign of the batch equal those of kinem.linalg.Factor."""
    from kinem.linalg import Factor

    model = kinem.compile(kinem.load(ROOT / "cases" / "quick_return_1.toml"))
    r = kinem.solve(model)
    Q, t = r.q[::20], model.times[::20]
    Js = model.assemble(model.jac_values(Q, t) * model.entry_scale, sparse=False)
    (LU, P), pivot, det = march.factorize(Js, model.blocks)
    for k in range(len(t)):
        f = Factor(model, model.jac_values(Q[k], t[k]))
        assert pivot[k] == pytest.approx(f.pivot_ratio, rel=1e-12) and det[k] == f.det_sign
    x = march.solve_each(model, (LU, P), model.nu(t))
    assert np.allclose(x, r.qd[::20], rtol=1e-9, atol=1e-12 * model.length)


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1"])
def test_positions_only_blocks_start_as_well_as_full_ones(name):
    """A positions-only run computes the rates at the last accepted states
    for its blocks' starts (march.Block.rates), so its Newton iterations are
    those of the full run: without them its far instants start from a
    Lagrange extrapolation and take more (2.72 against 2.37 per instant on
    the slider-crank)."""
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    full, positions = kinem.solve(model), kinem.solve(model, ("positions",))
    assert full.success and positions.success
    np.testing.assert_array_equal(positions.iterations, full.iterations)
