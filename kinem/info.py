"""``kinem info``: counts, degrees of freedom and redundant equations of a model.

Assembly for info uses Gauss-Newton with minimum-norm least-squares steps,
so that it also settles redundant (consistent) or non-square systems. Ranks
are taken on the dimensionless Jacobian (rows divided by their residual
scale, length columns multiplied by the characteristic length L), where a
singular value below kinem.diagnose.RANK_TOL of the largest counts as zero.
"""
from dataclasses import asdict, dataclass

import numpy as np

DENSE_RANK_LIMIT = 3000  # coordinates; above, the structural rank is reported


@dataclass(frozen=True)
class Info:
    case: str
    coordinates: int
    artificial_coordinates: int
    equations: int
    driving_equations: int
    jacobian_nonzeros: int
    dof: int
    residual: float
    assembled: bool
    rank_method: str
    redundant_equations: tuple
    diagnosis: str = ""  # why it does not assemble (kinem.diagnose.explain_assembly), when it does not

    def as_dict(self) -> dict:
        d = asdict(self)
        d["redundant_equations"] = list(self.redundant_equations)
        return d


def dimensionless_jacobian(model, q, t=0.0) -> np.ndarray:
    return model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)


def assemble(model, t=0.0, max_iterations=None):
    """Gauss-Newton from the estimate; returns (q, max scaled residual, converged)."""
    from .analysis import gauss_newton

    q, r = gauss_newton(model, model.q0.copy(), t, max_iterations)
    return q, r, bool(r <= model.case.tolerance)


def info(model) -> Info:
    from .diagnose import rank_analysis

    nd = ~model.driving
    if model.n <= DENSE_RANK_LIMIT:
        q, residual, ok = assemble(model)
        rank, redundant = rank_analysis(model, q, 0.0, nd)
        method = "numerical"
    else:
        from scipy.sparse.csgraph import structural_rank

        from .analysis import Data, position

        data = Data(q=model.q0.copy())
        try:
            position(model, data, 0.0)
        except Exception:
            pass
        q, residual, ok = data.q, data.residual, data.residual <= model.case.tolerance
        rank = int(structural_rank(model.jacobian(q, 0.0, sparse=True)[nd].tocsr()))
        redundant, method = (), "structural"
    from .diagnose import explain_assembly

    return Info(
        diagnosis="" if ok else (explain_assembly(model, 0.0) or "no convergence"),
        case=model.case.name, coordinates=model.n, artificial_coordinates=len(model.artificial),
        equations=model.m, driving_equations=int(model.driving.sum()), jacobian_nonzeros=model.nnz,
        dof=model.n - rank, residual=float(residual), assembled=ok, rank_method=method,
        redundant_equations=redundant,
    )


def describe(i: Info) -> str:
    lines = [
        f"case {i.case}",
        f"  coordinates        {i.coordinates} ({i.artificial_coordinates} artificial)",
        f"  equations          {i.equations} ({i.driving_equations} driving)",
        f"  Jacobian non-zeros {i.jacobian_nonzeros} of {i.equations * i.coordinates}"
        f" ({100 * i.jacobian_nonzeros / max(1, i.equations * i.coordinates):.1f}%)",
        f"  degrees of freedom {i.dof} (coordinates minus the {i.rank_method} rank of the non-driving Jacobian)",
        f"  assembly residual  {i.residual:.2e} (scaled){'' if i.assembled else '  NOT ASSEMBLED'}",
    ]
    if i.redundant_equations:
        lines.append("  warning: redundant equations: " + ", ".join(i.redundant_equations))
    if i.diagnosis:
        lines.append(f"  not assembled: {i.diagnosis}")
    if i.equations != i.coordinates:
        lines.append(f"  warning: {i.equations} equations for {i.coordinates} coordinates")
    return "\n".join(lines)
