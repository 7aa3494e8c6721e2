"""``kinem.solve``: one model solved (kinem.solver), or, given
``parameters``, many variants of it together (kinem.variants). It sits on
top of both: nothing in the package imports it but kinem/__init__.py."""
from .options import Options
from .result import OUTPUTS, SolveResult
from .solver import _checked_model, solve as solve_one
from .variants import Variants, solve_variants


def solve(model, outputs=OUTPUTS, times=None, trace=False, options: Options | None = None,
          q0=None, parameters=None) -> SolveResult | Variants:
    """kinem.solver.solve's analysis (its arguments); ``parameters``:
    {design parameter path: N values}: N variants solved together, a
    kinem.variants.Variants (``outputs`` stages or column names); one
    warning counts the variants whose driver turns fast where the case's
    does not (a rate in degrees?), as kinem.sweep's."""
    if parameters is None:
        return solve_one(model, outputs, times, trace, options, q0)
    _checked_model(model)
    return solve_variants(model, parameters, outputs, times, options, trace, q0, warn=True)
