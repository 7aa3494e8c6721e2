"""Solver options are passed to ``solve`` (kinem.Options), not compiled into
the Model: another tolerance, block size or linear solver never recompiles."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import kinem
import kinem.model
from closed_form import slider_crank

CASES = Path(__file__).resolve().parents[1] / "cases"


@pytest.fixture(scope="module")
def model():
    return kinem.compile(kinem.load(CASES / "slider_crank.toml"))


def test_defaults_come_from_the_case_solver_section(model):
    o = kinem.Options.of(model.case)
    assert (o.tolerance, o.max_iterations, o.linear_solver, o.jacobian_reuse, o.block) == (1e-12, 25, "auto", False, 256)
    a, b = kinem.solve(model), kinem.solve(model, options=o)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.iterations, b.iterations)


def test_changing_options_never_recompiles(model, monkeypatch):
    def no_compile(*a, **k):
        raise AssertionError("recompiled")
    monkeypatch.setattr(kinem, "compile", no_compile)
    monkeypatch.setattr(kinem.model, "compile", no_compile)
    t = model.times
    ref = slider_crank(5.76 - 1.2 * t + np.pi, -1.2 + 0 * t, 0 * t, 200.0, 500.0)["x"]
    runs = {tol: kinem.solve(model, options=kinem.Options(tolerance=tol)) for tol in (1e-4, 1e-12)}
    assert all(r.success for r in runs.values())
    # a looser tolerance stops earlier: fewer iterations, and a larger residual bound
    assert runs[1e-4].iterations.sum() < runs[1e-12].iterations.sum()
    assert runs[1e-4].residual.max() > 1e-12 >= runs[1e-12].residual.max()
    # 1e-9 of the size (665 mm) at the default: positions are right to the tolerance over the conditioning
    assert np.abs(runs[1e-12].trajectory["slider.x"] - ref).max() < 1e-9 * 665
    # step by step, sparse LU and modified Newton from the same Model agree with the default
    for o in (kinem.Options(block=1), kinem.Options(linear_solver="sparse"), kinem.Options(jacobian_reuse=True)):
        r = kinem.solve(model, options=o)
        assert r.success and np.abs(r.trajectory["slider.x"] - ref).max() < 1e-9 * 665


@pytest.mark.parametrize("bad", [dict(tolerance=0.0), dict(tolerance=2.0), dict(max_iterations=0),
                                 dict(linear_solver="cholesky"), dict(block=0), dict(block=2.5)])
def test_bad_options_are_input_errors(bad):
    with pytest.raises(kinem.InputError, match="solver options: " + next(iter(bad))):
        kinem.Options(**bad)


def test_options_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        kinem.Options().tolerance = 1e-3


# -- lint: no solver option reaches solve through a recompiled case ----------------------

ROOT = CASES.parent
SCANNED = ("kinem", "adapters", "benchmarks", "tests")
# the Case's [solver] defaults: the fields Case and Options share
SOLVER_FIELDS = {f.name for f in dataclasses.fields(kinem.Case)} & {f.name for f in dataclasses.fields(kinem.Options)}


def solver_option_misuse(source: str) -> list:
    """(line, what) of each place in ``source`` that changes a solver option
    by replacing a case (``replace(case, tolerance=...)``, then compiling it)
    or reads one from a case (``case.tolerance``, ``model.case.block``)
    instead of taking it from the Options solve is given. A replace is
    allowed on what is named for Options (``options``, ``step_options``,
    ``Options.of(case)``): the first argument's text says "option"."""
    import ast

    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and node.args:
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
            fields = sorted(SOLVER_FIELDS & {k.arg for k in node.keywords})
            target = ast.unparse(node.args[0])
            if name == "replace" and fields and "option" not in target.lower():
                found.append((node.lineno, f"replace({target}, {', '.join(k + '=...' for k in fields)})"))
        elif isinstance(node, ast.Attribute) and node.attr in SOLVER_FIELDS and isinstance(node.ctx, ast.Load):
            v = node.value
            if (isinstance(v, ast.Name) and v.id == "case") or (isinstance(v, ast.Attribute) and v.attr == "case"):
                found.append((node.lineno, f"{ast.unparse(node)} read"))
    return sorted(found)


def test_the_solver_fields_are_the_cases_solver_section():
    assert SOLVER_FIELDS == {"tolerance", "max_iterations", "linear_solver", "jacobian_reuse", "block"}


def test_the_lint_finds_a_recompiled_case_and_a_case_read():
    bad = ("m = kinem.compile(dataclasses.replace(case, tolerance=1e-13))\n"
           "r = solve(compile(replace(model.case, block=1, outputs=2)))\n"
           "tol = model.case.tolerance\n")
    good = ("r = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(case), tolerance=1e-13))\n"
            "r = kinem.solve(model, options=replace(step_options, jacobian_reuse=True))\n"
            "case = replace(case, end=2.0)\ns = text.replace('a', 'b')\ntol = options.tolerance\n")
    assert solver_option_misuse(bad) == [(1, "replace(case, tolerance=...)"), (2, "replace(model.case, block=...)"),
                                         (3, "model.case.tolerance read")]
    assert solver_option_misuse(good) == []


def test_no_source_changes_a_solver_option_through_the_case():
    """Options are passed to solve; nothing in kinem, the adapters, the
    benchmarks or the tests compiles a replaced case to change one, or
    reads one from a case other than Options.of (kinem/options.py)."""
    found = []
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel == "kinem/options.py":
                continue
            found += [f"{rel}:{line}: {what}" for line, what in solver_option_misuse(path.read_text())]
    assert not found, "pass options=kinem.Options(...) to kinem.solve instead:\n" + "\n".join(found)
