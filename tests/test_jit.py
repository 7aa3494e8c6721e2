"""Interpreted kernels give what compiled ones give (kinem.jit).

A short run in a new process runs the kernels' Python source instead of
loading numba (kinem.solver.interpret). Both do the same floating-point
operations in the same order; they may differ only where numba's and
numpy's elementary functions (sin, cos, complex exp) round differently, by
about an ulp, carried through a few operations. So values agree to TOL
relative to max(1, |value|), as in tests/test_batch_eval.py.
"""
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import kinem
from conftest import ROOT
from kinem import dense, jit
from kinem.solver import interpret
from test_batch_eval import CASES, TOL, assert_same, draw_batch, model_of


def evaluate(model, Q, QD, T):
    values = model.jac_values(Q, T)
    return {"phi": model.phi(Q, T), "jac_values": values, "nu": model.nu(T),
            "gamma": model.gamma(Q, QD, T), "assemble": model.assemble(values, sparse=False)}


@pytest.mark.parametrize("path", CASES)
@settings(max_examples=5)
@given(data=st.data())
def test_interpreted_families_equal_compiled(path, data):
    model = model_of(path)
    batch = draw_batch(data.draw, model, (data.draw(st.integers(1, 3), label="K"),))
    compiled = evaluate(model, *batch)
    with jit.interpreted():
        interpreted = evaluate(model, *batch)
    for what, value in compiled.items():
        assert_same(interpreted[what], value, what)


@settings(max_examples=20)
@given(st.integers(1, 3), st.integers(1, 8), st.data())
def test_interpreted_lu_equals_compiled(K, n, data):
    A = data.draw(arrays(float, (K, n, n), elements=st.floats(-1, 1)))
    B = data.draw(arrays(float, (K, n), elements=st.floats(-1, 1)))
    LU = A.copy()
    piv = dense.factor(LU)
    X = dense.solve(LU, piv, B.copy())
    with jit.interpreted():
        LU2 = A.copy()
        piv2 = dense.factor(LU2)
        X2 = dense.solve(LU2, piv2, B.copy())
    # the same operations on the same numbers, with no elementary functions
    np.testing.assert_array_equal(piv2, piv)
    np.testing.assert_array_equal(LU2, LU)
    np.testing.assert_array_equal(X2, X)


@pytest.mark.parametrize("path", CASES)
def test_interpreted_run_equals_compiled(path):
    """A short run (stress cases included), interpreted and compiled: the
    same status, iterations and events, and positions within TOL / (smallest pivot ratio), the residual
    difference carried through the Jacobian's inverse (tests/test_march.py)."""
    case = kinem.load(ROOT / path)
    model = kinem.compile(case.with_time(None, 8))
    compiled = kinem.solve(model)
    with jit.interpreted():
        interpreted = kinem.solve(model)
    assert (interpreted.status, interpreted.message) == (compiled.status, compiled.message)
    np.testing.assert_array_equal(interpreted.iterations, compiled.iterations)
    # events (singular configurations stepped over) at the same instants, to rounding
    assert [t for t, _ in interpreted.events] == pytest.approx([t for t, _ in compiled.events], abs=1e-9 * case.end)
    bound = TOL / max(compiled.conditioning.min(), 1e-8)
    for a, b in [(interpreted.q, compiled.q), (interpreted.qd, compiled.qd), (interpreted.qdd, compiled.qdd)]:
        scale = max(1.0, float(np.abs(b / model.col_scale).max()))
        assert np.abs((a - b) / model.col_scale).max() <= bound * scale


def test_nothing_is_interpreted_once_numba_is_loaded():
    # this process has loaded numba (tests/conftest.py)
    assert jit.loaded() and not interpret(model_of("cases/slider_crank.toml"), False, 2)


PROBE = """
import sys
from kinem.cli import main
code = main({args!r})
print("numba" in sys.modules, code)
"""


@pytest.mark.parametrize("steps, loads", [(1, False), (20, False), (200, True)])
def test_cli_loads_numba_only_for_long_runs(tmp_path, steps, loads):
    """A new process: a short run never imports numba; a run that takes the
    compiled march (kinem.march: at least 64 instants) does."""
    args = ["solve", str(ROOT / "cases" / "slider_crank.toml"), "--steps", str(steps), "--out", str(tmp_path / "x.csv")]
    p = subprocess.run([sys.executable, "-c", PROBE.format(args=args)], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == [str(loads), "0"]


def test_interpret_rule():
    """In a process without numba, step-by-step runs of up to INTERPRET_WORK
    interpret; block-march runs never do."""
    code = """
import kinem
from kinem.solver import interpret, INTERPRET_WORK
m = kinem.compile(kinem.load({path!r}))
limit = INTERPRET_WORK // (100 + m.n)
print(interpret(m, False, limit), interpret(m, False, limit + 1), interpret(m, True, 2))
""".format(path=str(ROOT / "cases" / "slider_crank.toml"))
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["True", "False", "False"]


def test_an_edited_kernel_source_removes_the_caches_that_may_hold_it(tmp_path):
    """numba checks a cache against its own function's file only, and a
    compiled caller holds the code of the kernels it calls or inlines from
    other modules: an edit of any kernel source removes every cache."""
    (tmp_path / "constraints" / "__pycache__").mkdir(parents=True)
    (tmp_path / "__pycache__").mkdir()
    kernels = tmp_path / "dense.py"
    kernels.write_text("@kernel\ndef f(x):\n    return x\n")
    (tmp_path / "cli.py").write_text("print('no kernel here')\n")
    caches = [tmp_path / "__pycache__" / "loop.run-1.py311.nbi", tmp_path / "__pycache__" / "loop.run-1.py311.1.nbc",
              tmp_path / "constraints" / "__pycache__" / "line._jac-9.py311.nbi"]

    def write_caches():
        for c in caches:
            c.write_bytes(b"x")

    write_caches()
    assert jit.refresh(tmp_path)            # no stamp yet: the caches' sources are unknown
    assert not any(c.exists() for c in caches)
    write_caches()
    assert not jit.refresh(tmp_path)        # the same sources: the caches stay
    assert all(c.exists() for c in caches)
    (tmp_path / "cli.py").write_text("print('still no kernel')\n")
    assert not jit.refresh(tmp_path)        # a source without kernels does not count
    kernels.write_text("@kernel\ndef f(x):\n    return 2 * x\n")
    assert jit.refresh(tmp_path)
    assert not any(c.exists() for c in caches)
