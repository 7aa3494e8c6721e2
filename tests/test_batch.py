"""Variants solved together equal the same variants solved one by one."""
import numpy as np

import kinem
from kinem.batch import merge, split
from kinem.reference import four_bar_case, slider_crank_case


def test_merged_variants_equal_single_solves():
    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.1 * k), 0.3, 0.01 * k, end=1.0, steps=40)) for k in range(4)]
    cases.append(kinem.load_dict(four_bar_case(0.1, 0.3, 0.22, 0.2, end=1.0, steps=40)))  # any topology merges
    batch = kinem.solve(kinem.compile(merge(cases)))
    assert batch.success
    for k, c in enumerate(cases):
        single = kinem.solve(kinem.compile(c)).trajectory
        part = split(batch.trajectory, k)
        assert part.columns == single.columns
        # both are converged to the same tolerance: 1e-9 of the size (0.4) apart at most
        assert np.abs(part.data - single.data).max() <= 1e-9 * max(1.0, np.abs(single.data).max())


def test_variants_need_the_same_instants():
    import pytest

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
    from kinem import march
    from kinem.model import ONE_BLOCK
    from kinem.reference import n_four_bar

    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.1 * k), 0.3, 0.01 * k, end=1.0, steps=80)) for k in range(4)]
    cases.append(kinem.load_dict(n_four_bar(2)).with_time(1.0, 80))  # 18 coordinates: the others are padded
    model = kinem.compile(merge(cases))
    b = model.blocks
    assert model.n > ONE_BLOCK and (b.count, b.size, b.pad.size) == (5, 18, 4 * 6)
    assert march.usable(model, False, len(model.times), kinem.Options.of(model.case))
    taken, original = [], march.March.advance

    def advance(self, k, q0=None):
        end = original(self, k, q0)
        taken.append(end - k)
        return end

    march.March.advance = advance
    try:
        batch = kinem.solve(model)
    finally:
        march.March.advance = original
    assert batch.success and sum(taken) >= len(model.times) // 2
    for k, c in enumerate(cases):
        single = kinem.solve(kinem.compile(c)).trajectory
        part = split(batch.trajectory, k)
        assert part.columns == single.columns
        # both converged to the same tolerance: 1e-9 of the size apart at most
        assert np.abs(part.data - single.data).max() <= 1e-9 * max(1.0, np.abs(single.data).max())


def test_every_family_marches_in_its_own_part():
    """Every case in cases/ (every constraint family of the core) merged into
    one model: each variant is a diagonal block that the core splits into a
    model of its own and marches on its own (kinem/core/src/parts.rs, which
    checks each part's residual and Jacobian against the whole model's to
    the bit when it splits). Each variant's answers equal its single solve,
    positions only (the Lagrange predictor) and with rates (Taylor)."""
    import glob
    import os

    from kinem.model import ONE_BLOCK

    root = os.path.join(os.path.dirname(__file__), "..", "cases")
    cases = [kinem.load(f).with_time(1.0, 30) for f in sorted(glob.glob(os.path.join(root, "*.toml")))]
    model = kinem.compile(merge(cases))
    assert model.n > ONE_BLOCK and model.blocks.count == len(cases)
    for outputs in (("positions",), ("positions", "velocities", "accelerations")):
        batch = kinem.solve(model, outputs)
        assert batch.success, batch.message
        for k, c in enumerate(cases):
            single = kinem.solve(kinem.compile(c), outputs).trajectory
            part = split(batch.trajectory, k)
            assert part.columns == single.columns
            # both converged to the tolerance (the merged one measured against the largest variant's size):
            # 1e-9 of each quantity's size apart at most
            size = np.maximum(1.0, np.abs(single.data).max(axis=0))
            assert (np.abs(part.data - single.data) <= 1e-9 * size).all(), c.name


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
    import os

    from kinem import march

    root = os.path.join(os.path.dirname(__file__), "..", "cases")
    change = kinem.load(os.path.join(root, "stress", "change_point.toml"))
    slider, four_bar = (kinem.load(os.path.join(root, f)).with_time(change.end, change.steps)
                        for f in ("slider_crank.toml", "four_bar.toml"))
    cases = [slider, change, four_bar, slider, four_bar, slider]  # 72 coordinates: above ONE_BLOCK, 6 blocks
    model = kinem.compile(merge(cases))
    assert model.blocks.count == 6
    resumed, original = [], march.March.advance

    def advance(self, k, q0=None):
        end = original(self, k, q0)
        if k > 0:
            resumed.append((k, end))
        return end

    march.March.advance = advance
    try:
        for outputs in (("positions",), kinem.OUTPUTS):
            batch = kinem.solve(model, outputs)
            assert batch.success, batch.message
            assert [t for t, _ in batch.events] == [1.5]
            for k, c in enumerate(cases):
                single = kinem.solve(kinem.compile(c), outputs).trajectory
                part = split(batch.trajectory, k)
                size = np.maximum(1.0, np.abs(single.data).max(axis=0))
                away = ~np.isclose(single.t, 1.5)
                # 1e-9 of each quantity's size, as above
                assert (np.abs(part.data - single.data)[away] <= 1e-9 * size).all(), (c.name, outputs)
    finally:
        march.March.advance = original
    # the parts marched again after the tracker's instants, to the end
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
    from kinem import march
    from kinem.reference import slider_crank_case

    K = 200
    fast = kinem.load_dict(slider_crank_case(0.1, 0.3, 0.0, fn={"poly": [0.5, 1200.0]}, end=1.0, steps=K))
    cases = [kinem.load_dict(slider_crank_case(0.1 * (1 + 0.02 * k), 0.3, 0.0, end=1.0, steps=K)) for k in range(6)]
    cases.insert(3, fast)
    model = kinem.compile(merge(cases))
    evaluations, original = [], march.March.advance

    def advance(self, k, q0=None):
        end = original(self, k, q0)
        evaluations.append(int(self.ints[-2]))   # this march call's own count (Plan.march)
        return end

    march.March.advance = advance
    try:
        batch = kinem.solve(model)
    finally:
        march.March.advance = original
    assert batch.success and len(evaluations) > K // 2, (batch.message, len(evaluations))
    assert sum(evaluations) < 25 * len(model.times), sum(evaluations)
    for k, c in enumerate(cases):
        single = kinem.solve(kinem.compile(c)).trajectory
        size = np.maximum(1.0, np.abs(single.data).max(axis=0))
        # 1e-9 of each quantity's size, as above
        assert (np.abs(split(batch.trajectory, k).data - single.data) <= 1e-9 * size).all(), c.name
