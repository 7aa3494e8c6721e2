"""Variants solved together equal the same variants solved one by one."""
import glob
import os

import numpy as np
import pytest

import kinem
from kinem import march
from kinem.batch import merge, split
from kinem.model import ONE_BLOCK
from kinem.reference import four_bar_case, n_four_bar, slider_crank_case

CASES = os.path.join(os.path.dirname(__file__), "..", "cases")


def assert_equal_to_singles(batch, cases, outputs=kinem.OUTPUTS, away=None):
    """Each variant's part of a merged solve equals its own solve: both are
    converged to the same tolerance (the merged one measured against the
    largest variant's size), so 1e-9 of each quantity's size apart at most;
    ``away``: a mask of the instants compared (default all)."""
    for k, c in enumerate(cases):
        single = kinem.solve(kinem.compile(c), outputs).trajectory
        part = split(batch.trajectory, k)
        assert part.columns == single.columns
        size = np.maximum(1.0, np.abs(single.data).max(axis=0))
        keep = slice(None) if away is None else away
        assert (np.abs(part.data - single.data)[keep] <= 1e-9 * size).all(), (c.name, outputs)


def watched(model, outputs=kinem.OUTPUTS):
    """kinem.solve with every march call recorded: (result, [(k, end, the
    call's own Jacobian evaluations)])."""
    calls, original = [], march.March.advance

    def advance(self, k):
        before = int(self.ints[-2])   # the march's counts are added to, call after call
        end = original(self, k)
        calls.append((k, end, int(self.ints[-2]) - before))
        return end

    march.March.advance = advance
    try:
        return kinem.solve(model, outputs), calls
    finally:
        march.March.advance = original


def test_merged_variants_equal_single_solves():
    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.1 * k), 0.3, 0.01 * k, end=1.0, steps=40)) for k in range(4)]
    cases.append(kinem.load_dict(four_bar_case(0.1, 0.3, 0.22, 0.2, end=1.0, steps=40)))  # any topology merges
    batch = kinem.solve(kinem.compile(merge(cases)))
    assert batch.success
    assert_equal_to_singles(batch, cases)


def test_variants_need_the_same_instants():
    a = kinem.load_dict(slider_crank_case(0.1, 0.3, end=1.0, steps=40))
    b = kinem.load_dict(slider_crank_case(0.1, 0.3, end=1.0, steps=41))
    with pytest.raises(kinem.InputError):
        merge([a, b])


def test_merged_variants_march_in_blocks_one_per_variant():
    """Merged models over model.ONE_BLOCK coordinates take the compiled march with
    one diagonal block per variant (padded to the largest): the blocks take
    the instants, and the results equal the variants solved one by one.
    An odd reordering sign or a wrong padding would make every block's det
    sign or solution differ from the step-by-step march's, and blocks would
    take no instant."""
    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.1 * k), 0.3, 0.01 * k, end=1.0, steps=80)) for k in range(4)]
    cases.append(kinem.load_dict(n_four_bar(2)).with_time(1.0, 80))  # 18 coordinates: the others are padded
    model = kinem.compile(merge(cases))
    b = model.blocks
    assert model.n > ONE_BLOCK and (b.count, b.size, b.pad.size) == (5, 18, 4 * 6)
    assert march.usable(model, False, len(model.times), kinem.Options.of(model.case))
    batch, calls = watched(model)
    assert batch.success and sum(end - k for k, end, _ in calls) >= len(model.times) // 2
    assert_equal_to_singles(batch, cases)


def test_every_family_marches_in_its_own_part():
    """Every case in cases/ (every constraint family of the core) merged into
    one model: each variant is a diagonal block that the core splits into a
    model of its own and marches on its own (kinem/core/src/parts.rs, which
    checks each part's residual and Jacobian against the whole model's to
    the bit when it splits). Each variant's answers equal its single solve,
    positions only (the Lagrange predictor) and with rates (Taylor)."""
    cases = [kinem.load(f).with_time(1.0, 30) for f in sorted(glob.glob(os.path.join(CASES, "*.toml")))]
    model = kinem.compile(merge(cases))
    assert model.n > ONE_BLOCK and model.blocks.count == len(cases)
    for outputs in (("positions",), kinem.OUTPUTS):
        batch = kinem.solve(model, outputs)
        assert batch.success, batch.message
        assert_equal_to_singles(batch, cases, outputs)


def test_a_variant_handed_to_the_tracker_and_the_parts_resuming_after_it():
    """A merged case whose one variant passes a change point (cases/stress/
    change_point.toml, singular at t = 1.5): its part stops the march there,
    the tracker takes that instant for the whole model, and the parts resume
    after it from the tracker's state (each part's det sign taken again
    there). Every variant still equals its single solve away from t = 1.5,
    and the change point is reported once. (At t = 1.5 itself the tracker
    interpolates the whole merged state between sub-steps on either side: the
    other variants' rates there are interpolated too, 4e-7 of their size off,
    and the singular variant's acceleration depends on where the sub-steps
    fall.)"""
    change = kinem.load(os.path.join(CASES, "stress", "change_point.toml"))
    slider, four_bar = (kinem.load(os.path.join(CASES, f)).with_time(change.end, change.steps)
                        for f in ("slider_crank.toml", "four_bar.toml"))
    cases = [slider, change, four_bar, slider, four_bar, slider]  # 72 coordinates: above ONE_BLOCK, 6 blocks
    model = kinem.compile(merge(cases))
    assert model.blocks.count == 6
    for outputs in (("positions",), kinem.OUTPUTS):
        batch, calls = watched(model, outputs)
        assert batch.success, batch.message
        assert [t for t, _ in batch.events] == [1.5]
        assert_equal_to_singles(batch, cases, outputs, away=~np.isclose(batch.trajectory.t, 1.5))
        # the parts marched again after the tracker's instants, to the end
        resumed = [(k, end) for k, end, _ in calls if k > 0]
        assert resumed and resumed[-1][1] == len(model.times)


def test_a_variant_handed_back_at_many_instants_keeps_the_march_linear():
    """One variant driven 600x faster than the others needs the tracker at
    every instant (6 rad per output step). After each hand-back the parts
    march over windows that double from 4 instants (kinem/core/src/parts.rs),
    so the others march only a few instants past each stop instead of to the
    end every time: the march's own Jacobian evaluations (the busiest part's,
    per window) stay a small multiple of the instants: each hand-back costs
    one window of 4 instants at 2 to 4 Jacobians each, about 17 measured,
    so below 25 per instant; marching every part to the end at each of the
    200 hand-backs would report about 200 per instant. Every variant still
    equals its single solve."""
    K = 200
    with pytest.warns(kinem.KinemWarning, match="1200 rad/s"):   # fast on purpose
        fast = kinem.load_dict(slider_crank_case(0.1, 0.3, 0.0, fn={"poly": [0.5, 1200.0]}, end=1.0, steps=K))
    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.02 * k), 0.3, 0.0, end=1.0, steps=K)) for k in range(6)]
    cases.insert(3, fast)
    model = kinem.compile(merge(cases))
    batch, calls = watched(model)
    assert batch.success and len(calls) > K // 2, (batch.message, len(calls))
    assert sum(own for _, _, own in calls) < 25 * len(model.times)
    assert_equal_to_singles(batch, cases)


NAMED = os.path.join(os.path.dirname(__file__), "data", "four_bar_named.toml")


@pytest.mark.parametrize("from_nominal", [False, True])
def test_solve_merged_halves_to_the_failing_variant(from_nominal):
    """kinem.batch.solve_merged (the merged path of sweeps, tolerance bands
    and variant batches): a coupler of 0.6 m cannot close the loop, so the
    batch is halved until that variant fails alone with its reason; the
    others equal their own solves (from their own estimates, or from the
    nominal's first state: ``start``) to 1e-10 (their tolerance, 0.3 m
    links), columns and first states; a case refused as input is bad input."""
    from kinem.batch import OWN, solve_merged

    couplers = [0.3, 0.6, 0.31, 0.29, 0.305]
    cases = [kinem.load(NAMED, parameters={"coupler": c}) for c in couplers] + [kinem.InputError("no case")]
    nominal = kinem.compile(cases[0])
    q0 = kinem.solve(nominal, times=nominal.times[:1]).q[0]
    start = dict(zip(nominal.coordinate_names, q0)) if from_nominal else OWN
    columns = ("B.x", "B.vy", "rocker.alpha")
    done = solve_merged(cases, columns, start=start)
    assert [d.data is not None for d in done] == [True, False, True, True, True, False]
    assert ("NOT_CONVERGED" in done[1].why or "SINGULAR" in done[1].why) and done[1].q is None
    assert done[5].why == "bad input: no case"
    for c, d in zip(cases, done):
        if d.data is None:
            continue
        r = kinem.solve(kinem.compile(c), q0=q0 if from_nominal else None)
        np.testing.assert_allclose(d.data, np.column_stack([r.trajectory[k] for k in columns]), rtol=0, atol=1e-10)
        np.testing.assert_allclose(d.q, r.q[0], rtol=0, atol=1e-10)
        assert d.why == ""
    with pytest.raises(kinem.InputError, match="start"):
        solve_merged(cases[:1], columns, start="nominal")
