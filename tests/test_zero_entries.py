"""Issue 31 round 18: the Jacobian entries exactly zero at every
configuration (a revolute's B s' where its local point is zero; a
translational joint's u . A_b s'_b where its point on b is) are left out
of the block-triangular solve and elimination (kinem/core/src/plan.rs,
order.rs, triangular.rs). A variant that moves such a local point away
from zero, marched on the nominal model's layout (as lanes and one by
one), must not lose them: each factorisation checks them there and falls
back to partial pivoting. Each variant against its own model solved alone."""
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem.parameters import apply

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import peers  # noqa: E402


@pytest.mark.parametrize("path", ["constraints.O.sj.0", "constraints.O.si.1"])
def test_a_variant_moving_a_zero_local_point_keeps_its_entries(path):
    case = kinem.load_dict(peers.slider_crank_case())
    assert dict((p.path, p.value) for p in kinem.parameters(case))[path] == 0.0   # a pin at the origin
    model = kinem.compile(case)
    # the crank's own coordinates and rates: what a lost entry on its angle would change first
    outputs = [f"{b}.{c}" for b in ("crank", "rod", "B") for c in ("x", "y", "vx", "vy", "ax", "ay")]
    # 9 variants where the point stays at zero and 3 that move it (lanes of 8, then one by one)
    values = np.array([0.0] * 9 + [1e-3, 0.0, 0.02])
    batch = kinem.solve(model, parameters={path: values}, outputs=outputs)
    assert batch.success.all()
    for k, v in enumerate(values):
        alone = kinem.solve(kinem.compile(apply(case, {path: float(v)}))).trajectory
        want = np.stack([np.asarray(alone[o]) for o in outputs], axis=1)
        # the same mechanism, another linear solver's rounding at most: 1e-12 of its size
        size = np.abs(want).max(axis=0) + 1.0
        assert (np.abs(batch.data[k] - want) <= 1e-12 * size).all(), (path, v)
