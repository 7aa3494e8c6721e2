"""The march (kinem/march.py on the compiled core's loop,
kinem/core/src/march.rs) gives what the step-by-step march gives: the same branch, status, events and diagnosis,
with positions within what the Newton tolerance allows, and it hands every
instant it does not accept to the tracker."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import march
from kinem.model import BLOCK_LIMIT

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml")) + sorted((ROOT / "cases" / "stress").glob("*.toml"))
BOTH = [kinem.OUTPUTS, ("positions",)]


def pair(model, outputs, block=64):
    """The model solved step by step and by the march, with the case's other options."""
    options = kinem.Options.of(model.case)
    step = kinem.solve(model, outputs, options=replace(options, block=1))
    blocked = kinem.solve(model, outputs, options=replace(options, block=block))
    return step, blocked


def agreement(model, step, blocked):
    """Both stop at a scaled residual <= tol from different starts, so they
    may differ by about tol / (smallest pivot ratio) in dimensionless units
    (the Jacobian's inverse amplifies residual differences by at most
    1 / sigma_min, and the pivot ratio bounds sigma_min from below to within
    a modest factor); a factor 10 covers that bound's slack."""
    tol = kinem.Options.of(model.case).tolerance
    cond = min(step.conditioning.min(), blocked.conditioning.min())
    return 10 * tol / max(cond, 1e-8)


@pytest.mark.parametrize("outputs", BOTH)
@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_block_agrees_with_step_by_step(path, outputs):
    case = kinem.load(path)
    model = kinem.compile(case)
    step, blocked = pair(model, outputs)
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


def test_the_march_is_compiled_end_to_end():
    """The march evaluates nothing through Python per instant: Model.phi,
    jac_values, nu and gamma are called (if at all) only around it, not once
    per instant."""
    from kinem.model import Model

    model = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml"))
    kinem.solve(model)
    calls = []
    originals = {name: getattr(Model, name) for name in ("phi", "jac_values", "nu", "gamma")}

    def counting(name):
        def f(self, *args):
            calls.append(name)
            return originals[name](self, *args)
        return f

    for name in originals:
        setattr(Model, name, counting(name))
    try:
        r = kinem.solve(model)
    finally:
        for name, f in originals.items():
            setattr(Model, name, f)
    assert r.success and len(r.q) == 501 and len(calls) <= 10


def blocks(model, trace, options=None):
    return march.usable(model, trace, len(model.times), options or kinem.Options.of(model.case))


def test_not_used_where_it_cannot_be():
    """Redundant (least squares), sparse, large, traced and modified-Newton runs go step by step."""
    par = kinem.compile(kinem.load(ROOT / "cases" / "stress" / "parallelogram_redundant.toml"))
    assert par.m > par.n and not blocks(par, False)
    fb = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    assert blocks(fb, False)
    assert not blocks(fb, True)
    options = kinem.Options.of(fb.case)
    assert not blocks(fb, False, replace(options, linear_solver="sparse"))
    assert not blocks(fb, False, replace(options, jacobian_reuse=True))
    assert not blocks(fb, False, replace(options, block=1))
    from kinem.reference import n_four_bar

    big = kinem.compile(kinem.load_dict(n_four_bar(34)))  # 70 bodies, one block of 210 coordinates: a band
    assert big.blocks.size > BLOCK_LIMIT and blocks(big, False) and march.banded(big)
    chain = kinem.compile(kinem.load_dict(n_four_bar(12)))  # 78 coordinates: blocks
    assert chain.blocks.count == 1 and blocks(chain, False)


def _run(model, state, k=1):
    """The core's march (kinem._core.Plan.march) from ``state`` (q, qd, qdd,
    (t, det), H, T) over the model's output instants from k on: (first
    instant not taken, why)."""
    from kinem.tracking import singular_pivot

    t = model.times
    n, K = model.n, len(t)
    options = kinem.Options.of(model.case)
    tol = options.tolerance
    q, qd, qdd, last, H, T = state
    packed = kinem.native.MarchState.of(float(last[0]), q, qd, qdd, int(last[1]))
    settings = (tol, options.max_iterations, kinem.native.MAX_STEP, singular_pivot(tol), True, np.inf)
    return tuple(model.plan.march(t, k, packed, settings, np.zeros((3, K, n)), np.zeros((2, K)),
                                  np.zeros(K + 2, np.int64)))


def _start(model):
    r = kinem.solve(model)
    from kinem.linalg import Factor

    det = Factor(model, model.jac_values(r.q[0], model.times[0])).det_sign
    H, T = np.zeros((3, model.n)), np.full(3, np.nan)
    return r, (r.q[0].copy(), r.qd[0].copy(), r.qdd[0].copy(), np.array([model.times[0], float(det)]), H, T)


def test_the_loop_hands_back_a_jump_and_a_det_flip():
    """From the accepted state the loop takes every instant of the four-bar;
    with the rates zeroed the predictor stays put, the first step's correction
    is all of the motion (above KAPPA x 0 + 10 tol): a jump, handed back at
    instant 1; with the det sign of the other branch: a det flip there."""
    from kinem.native import NOT_CONVERGED
    from kinem.tracking import DET_FLIP, JUMP

    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    r, state = _start(model)
    assert _run(model, tuple(a.copy() for a in state)) == (len(model.times), 0)
    still = (state[0].copy(), np.zeros(model.n), np.zeros(model.n), *(a.copy() for a in state[3:]))
    assert _run(model, still) == (1, JUMP)
    flipped = tuple(a.copy() for a in state)
    flipped[3][1] *= -1
    assert _run(model, flipped) == (1, DET_FLIP)
    lost = tuple(a.copy() for a in state)
    lost[0][:] = np.nan
    assert _run(model, lost) == (1, NOT_CONVERGED)


def test_the_cores_pivot_ratio_and_det_sign_are_lapacks():
    """The det sign of the core's LU (kinem._core.Plan.factor, the march's)
    is that of LAPACK's getrf on the same dimensionless Jacobian; where the
    pivots of its fixed orders span more than 1e3 (lu::FALLBACK: near a
    singular configuration, where the acceptance test decides) it
    factorises with partial pivoting in the model's order, so its pivot
    ratio is LAPACK's too (the same pivots; the blocked order rounds
    differently: 1e-12), and elsewhere at least 1e-3; its solves agree with
    LAPACK's to rounding. Near-singular: one row of the loop scaled by 1e-6."""
    from kinem.linalg import Factor, Solver

    model = kinem.compile(kinem.load(ROOT / "cases" / "quick_return_1.toml"))
    r = kinem.solve(model)
    lapack = Solver(sparse=False, least_squares=False)
    loop_row = model.structure.blocks[-1][0][0]
    for k in range(0, len(r.q), 20):
        for near in (False, True):
            values = model.jac_values(r.q[k], model.times[k])
            if near:
                values[model.jac_rows == loop_row] *= 1e-6
            ours, theirs = Factor(model, values), Factor(model, values, lapack)
            assert ours.core and not theirs.core
            assert ours.det_sign == theirs.det_sign
            if near:
                assert theirs.pivot_ratio < 1e-5
                assert ours.pivot_ratio == pytest.approx(theirs.pivot_ratio, rel=1e-12)
            else:
                assert ours.pivot_ratio >= 1e-3 or ours.pivot_ratio == pytest.approx(theirs.pivot_ratio, rel=1e-12)
            b = model.nu(model.times[k]) + 1.0
            x, y = ours.solve(b), theirs.solve(b)
            # rounding times the conditioning (the pivot ratio bounds it within a modest factor)
            assert np.abs(x - y).max() <= 1e-12 / min(ours.pivot_ratio, theirs.pivot_ratio) * np.abs(y).max()


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_1"])
def test_positions_only_solves_no_rates_and_lands_where_the_full_run_does(name):
    """A positions-only run predicts by extrapolating through the last three
    states (the core's accept::lagrange) and solves no rate; its positions are those
    of the full run within what the Newton tolerance allows (``agreement``)."""
    model = kinem.compile(kinem.load(ROOT / "cases" / f"{name}.toml"))
    full, positions = kinem.solve(model), kinem.solve(model, ("positions",))
    assert full.success and positions.success and positions.qd is None
    assert np.abs(full.q - positions.q).max() / model.length <= agreement(model, full, positions)
    assert positions.jacobian_evaluations <= full.jacobian_evaluations + len(full.q)


def test_a_long_chain_marches_as_a_band_and_agrees_with_superlu():
    """A chain of four-bars over LIMIT coordinates: its rows with one entry
    (ground, driver) are solved first and the rest is a band of width 2 + 5
    (kinem.model.Band). Its march gives the step-by-step (SuperLU) march's
    positions within the agreement bound, the same det sign at every
    instant (the sign is independent of the elimination order; the pivot
    ratio is not), and velocities that satisfy Phi_q qd = nu to rounding."""
    from kinem.linalg import Factor
    from kinem.reference import n_four_bar

    model = kinem.compile(kinem.load_dict(n_four_bar(34)).with_time(None, 70))
    b = model.band
    assert (b.kl, b.ku, model.n - b.size) == (2, 5, 4) and march.banded(model)
    fast, step = kinem.solve(model), kinem.solve(model, options=kinem.Options(block=1))
    assert fast.success and step.success
    assert np.abs(fast.q - step.q).max() / model.length <= agreement(model, step, fast)
    for k in range(0, len(fast.q), 10):
        t = model.times[k]
        J = model.jacobian(fast.q[k], t, sparse=False)
        # rounding: a few ulps of the largest term, times the size of the system
        assert np.abs(J @ fast.qd[k] - model.nu(t)).max() <= 1e-13 * np.abs(J).max() * np.abs(fast.qd[k]).max()
    from kinem.linalg import Solver

    superlu = Solver(sparse=True, least_squares=False)
    for k in range(0, len(fast.q), 10):
        values = model.jac_values(fast.q[k], model.times[k])
        band = Factor(model, values)
        assert band.core and band.det_sign == Factor(model, values, superlu).det_sign


def test_a_model_solved_again_gives_the_same_numbers_and_other_instants_their_own():
    """A model solved over other instants, or with other outputs, gets what
    a fresh model gets, and solved again the same numbers as the first time
    (nothing of one solve leaks into the next)."""
    case = kinem.load(ROOT / "cases" / "slider_crank.toml")
    model = kinem.compile(case)
    first = kinem.solve(model)
    half = model.times * 0.5  # as many instants, other ones (the drive's values differ)
    other = kinem.solve(model, times=half)
    fresh = kinem.solve(kinem.compile(case), times=half)
    assert other.success and np.array_equal(other.q, fresh.q) and np.array_equal(other.qdd, fresh.qdd)
    only = kinem.solve(model, outputs=("positions",))
    assert only.qd is None and np.abs(only.q - first.q).max() < 1e-9  # the same branch, its own predictor
    again = kinem.solve(model)
    assert np.array_equal(again.q, first.q) and np.array_equal(again.qdd, first.qdd)


def _bits(r):
    """A solve's figures as raw bytes (signs of zeros and NaNs' bits included)."""
    arrays = (r.q, r.qd, r.qdd, r.iterations, r.residual, r.conditioning)
    return [None if a is None else np.ascontiguousarray(a).tobytes() for a in arrays] + \
        [r.status, r.factorizations, r.jacobian_evaluations]


@pytest.mark.parametrize("path", sorted((ROOT / "cases").glob("*.toml")), ids=lambda p: p.stem)
def test_a_march_after_others_on_its_model_is_a_fresh_models_to_the_bit(path):
    """Each march sets the room its plan keeps (kinem/core/src/march.rs
    `Room`) as a fresh one: after marches over other instants, from another
    start, of positions alone and with the sensitivities' hook, a solve's
    figures are a freshly compiled model's to the bit."""
    case = kinem.load(path)
    fresh = kinem.solve(kinem.compile(case))
    model = kinem.compile(case)
    kinem.solve(model, times=model.times[: max(2, len(model.times) // 3)] * 0.7)
    kinem.solve(model, q0=model.q0 + 0.3)   # assembles elsewhere, or fails
    kinem.solve(model, outputs=("positions",))
    names = [p.path for p in kinem.parameters(model)]
    if names:
        kinem.sensitivity(model, names[:2])
    assert _bits(kinem.solve(model)) == _bits(fresh)
