"""The core's step (kinem/core/src/step.rs): one instant from a
typed MarchState (predict, settle, accept, rates), run by the march, by
Plan.step and, on Python's operations (kinem.analysis.Steps: any linear
solver), by native.step; the tracker's policy calls it for every attempt."""
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import analysis, native
from kinem.errors import WorkLimitError
from kinem.linalg import choose
from kinem.native import MarchState, Mode, Why
from kinem.tracking import singular_pivot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def four_bar():
    return kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))


def settings(model, rates=True):
    o = kinem.Options.of(model.case)
    return (o.tolerance, o.max_iterations, native.MAX_STEP, singular_pivot(o.tolerance), rates)


def python_step(model, state, t, mode=Mode.TRACK, solver=None, rates=True):
    """native.step on the step-by-step analysis's operations with ``solver`` (default: the core's LU)."""
    data = analysis.Data(q=model.q0.copy(), solver=choose(model, kinem.Options()) if solver is None else solver)
    ops = analysis.Steps(model, data, None, t, None, False)
    return native.step(ops, model.core, state, t, settings(model, rates), int(mode))


@pytest.mark.parametrize("rates", [True, False])
def test_pythons_operations_on_the_cores_lu_take_the_cores_steps_to_the_bit(four_bar, rates):
    """The same Newton, test and rates on the same LU: Plan.step and
    native.step on kinem.analysis.Steps (the core's LU through kinem.linalg.Factor)
    give the same states and figures, to the bit, over ten instants."""
    m = four_bar
    ours, theirs = MarchState(m.q0), MarchState(m.q0)
    for k, t in enumerate(m.times[:10]):
        mode = Mode.ASSEMBLE if k == 0 else Mode.TRACK
        a = m.plan.step(ours, float(t), settings(m, rates), int(mode))
        b = python_step(m, theirs, float(t), mode, rates=rates)
        assert a.why == b.why == Why.ACCEPTED
        assert (a.iterations, a.residual, a.pivot, a.det, a.correction) == \
               (b.iterations, b.residual, b.pivot, b.det, b.correction)
        assert np.array_equal(ours.q, theirs.q) and ours.t == theirs.t == t
        if rates:
            assert np.array_equal(ours.qd, theirs.qd) and np.array_equal(ours.qdd, theirs.qdd)
        else:
            assert ours.qd is None and theirs.qd is None


def test_lapacks_steps_land_where_the_cores_do(four_bar):
    """Another linear solver (LAPACK getrf) through the same step: the same
    verdicts, positions within 1e-12 of the size and rates within 1e-10 of
    their peak (different pivoting, the same roots to rounding)."""
    m = four_bar
    dense = choose(m, kinem.Options(linear_solver="dense"))
    dense = type(dense)(sparse=False, least_squares=False)   # LAPACK even where the model has a plan
    ours, theirs = MarchState(m.q0), MarchState(m.q0)
    for k, t in enumerate(m.times[:10]):
        mode = Mode.ASSEMBLE if k == 0 else Mode.TRACK
        a = m.plan.step(ours, float(t), settings(m), int(mode))
        b = python_step(m, theirs, float(t), mode, solver=dense)
        assert a.why == b.why == Why.ACCEPTED and a.det == b.det
        assert np.abs(ours.q - theirs.q).max() <= 1e-12 * m.length
        assert np.abs(ours.qd - theirs.qd).max() <= 1e-10 * np.abs(ours.qd).max()


def test_a_step_not_accepted_leaves_the_state_as_it_was(four_bar):
    """Rates zeroed: the predictor stays put and the whole motion is the
    correction (a jump); a det sign of the other branch: a det flip, which a
    step over a bifurcation (Mode.OVER) accepts. The state moves only when
    a step is accepted."""
    m = four_bar
    r = kinem.solve(m)
    det = m.plan.factor(m.jac_values(r.q[0], m.times[0])).det_sign
    t1 = float(m.times[1])
    still = MarchState.of(float(m.times[0]), r.q[0], np.zeros(m.n), np.zeros(m.n), det)
    o = m.plan.step(still, t1, settings(m))
    assert o.why == Why.JUMP and o.corr > native.KAPPA * o.motion
    assert still.t == m.times[0] and np.array_equal(still.q, r.q[0])
    flipped = MarchState.of(float(m.times[0]), r.q[0], r.qd[0], r.qdd[0], -det)
    assert m.plan.step(flipped, t1, settings(m)).why == Why.DET_FLIP and flipped.t == m.times[0]
    assert m.plan.step(flipped, t1, settings(m), int(Mode.OVER)).why == Why.ACCEPTED
    assert flipped.t == t1 and flipped.det == det
    assert np.abs(flipped.q - r.q[1]).max() <= 1e-12 * m.length


def test_rates_mode_solves_the_states_own_rates(four_bar):
    """Mode.RATES: the velocities and accelerations at the state's q and t,
    those of a full solve to 1e-12 of their peaks; nothing else moves."""
    m = four_bar
    r = kinem.solve(m)
    state = MarchState(m.q0)
    m.plan.step(state, float(m.times[0]), settings(m, rates=False), int(Mode.ASSEMBLE))
    for k in range(1, 4):
        assert m.plan.step(state, float(m.times[k]), settings(m, rates=False)).why == Why.ACCEPTED
    assert state.qd is None
    q = state.q
    o = m.plan.step(state, state.t, settings(m, rates=False), int(Mode.RATES))
    assert o.why == Why.ACCEPTED and np.array_equal(state.q, q) and state.t == m.times[3]
    assert np.abs(state.qd - r.qd[3]).max() <= 1e-12 * np.abs(r.qd).max()
    assert np.abs(state.qdd - r.qdd[3]).max() <= 1e-12 * np.abs(r.qdd).max()


def test_an_error_of_pythons_operations_comes_back_and_the_state_stays(four_bar):
    """A work limit raised inside Python's operations (kinem.budget checks
    the time at every Newton iteration) reaches the caller as itself."""
    m = four_bar
    state = MarchState(m.q0)
    python_step(m, state, 0.0, Mode.ASSEMBLE)
    before = state.q

    class OutOfTime(analysis.Steps):
        def evaluate(self, it):
            raise WorkLimitError("out of time")

    data = analysis.Data(q=m.q0.copy(), solver=choose(m, kinem.Options()))
    with pytest.raises(WorkLimitError, match="out of time"):
        native.step(OutOfTime(m, data, None, 0.1, None, False), m.core, state, 0.1, settings(m))
    assert state.t == 0.0 and np.array_equal(state.q, before)


def test_the_state_and_a_mode_are_checked(four_bar):
    m = four_bar
    with pytest.raises(ValueError, match="size"):
        m.plan.step(MarchState(m.q0[:-1]), 0.0, settings(m))
    with pytest.raises(ValueError, match="mode"):
        m.plan.step(MarchState(m.q0), 0.0, settings(m), 9)
    state = MarchState(m.q0)
    assert np.isnan(state.t) and state.qd is None and state.det == 0
    m.plan.step(state, 0.0, settings(m), int(Mode.ASSEMBLE))
    copy = state.copy()
    state.restart(m.q0)
    assert np.isnan(state.t) and copy.t == 0.0 and copy.qd is not None


def test_no_assembly_and_no_rates_where_the_factorisation_is_singular():
    """At the change point of a four-bar (Phi_q singular there) the core's
    assembly is not accepted (the tracker then diagnoses it: "assembled in
    a singular configuration") and Mode.RATES gives NEAR_SINGULAR with
    pivot ratio 0, the state's rates left as they were."""
    from test_newton import change_point

    model, exact = change_point()
    state = MarchState(exact)
    o = model.plan.step(state, 1.5, settings(model), int(Mode.ASSEMBLE))
    assert o.why == Why.NEAR_SINGULAR and o.pivot == 0.0 and np.isnan(state.t)
    r = kinem.solve(model, times=[1.5], q0=exact)
    assert r.status == kinem.Status.SINGULAR and "singular" in r.message, r.message
    state = MarchState.of(1.5, exact, np.ones(model.n), np.ones(model.n), 1)
    o = model.plan.step(state, 1.5, settings(model), int(Mode.RATES))
    assert o.why == Why.NEAR_SINGULAR and o.pivot == 0.0 and np.array_equal(state.qd, np.ones(model.n))
