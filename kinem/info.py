"""``kinem info``: counts, degrees of freedom and redundant equations of a model.

The assembly info reports is the one ``kinem solve`` performs: the solver
itself at the first output instant (one assembly, one answer). Where the
solver cannot assemble, the ranks are taken at a Gauss-Newton (minimum-norm
least-squares) point instead, which also settles redundant or non-square
systems, and the report says so. Ranks are taken on the dimensionless
Jacobian (rows divided by their residual scale, length columns multiplied by
the characteristic length L), where a singular value below
kinem.diagnose.RANK_TOL of the largest counts as zero. The configuration the
estimates chose is shown as the relative angle at every revolute joint
between two moving bodies (its sign is each loop's closure orientation:
elbow up or down) and the side of the outline every cam roller is on
(kinem.branches); a case's ``sign`` and ``side`` keys pin them (the solver
fails on the other branch, and so does info).
"""
from dataclasses import asdict, dataclass

import numpy as np

from .options import Options
from .result import Status

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
    diagnosis: str = ""  # why it does not assemble (the solver's message), when it does not
    configuration: tuple = ()   # (joint, relative angle phi_j - phi_i in (-pi, pi]) of the assembly
    sides: tuple = ()           # kinem.branches.Side of every cam roller at the assembly
    status: Status = Status.SUCCESS   # the solver's (WRONG_BRANCH: assembled on a branch the case's pins exclude)
    drawn: tuple = ()           # (body, frame (x, y, phi) at the drawing, ((point, (xi, eta)), ...)) of drawn points
    parameters: tuple = ()      # (name, value) of the case's [parameters], as used (--set applied)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["redundant_equations"] = list(self.redundant_equations)
        d["configuration"] = {name: angle for name, angle in self.configuration}
        d["status"] = self.status.name
        d["parameters"] = dict(self.parameters)
        d["drawn"] = {b: {"frame": list(q), "points": {n: list(at) for n, at in pts}} for b, q, pts in self.drawn}
        d["sides"] = {s.constraint: {"side": s.side, "distance": s.distance, "radius": s.radius} for s in self.sides}
        return d


def dimensionless_jacobian(model, q, t=0.0) -> np.ndarray:
    return model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)


def least_squares_point(model, t=0.0, max_iterations=None):
    """Gauss-Newton from the estimate; returns (q, max scaled residual, converged).
    Only for the ranks where the solver cannot assemble."""
    from .analysis import gauss_newton

    q, r = gauss_newton(model, model.q0.copy(), t, max_iterations)
    return q, r, bool(r <= Options.of(model.case).tolerance)


def assemble(model):
    """The solver's own assembly at the first output instant: (q or None,
    scaled residual, status, message)."""
    from .solver import solve

    t0 = model.times[:1]
    r = solve(model, times=t0, outputs=("positions",))
    if r.success:
        return r.q[0], float(r.residual[0]), r.status, ""
    return None, float("nan"), r.status, r.message


def configuration(model, q) -> tuple:
    """(revolute joint, phi_j - phi_i wrapped to (-pi, pi]) for every revolute
    joint between two bodies that are not grounded: the branch the estimates
    chose."""
    from .branches import relative_angle

    fixed = {c["body"] for c in model.case.constraints if c.type == "ground"}
    return tuple((c.name, relative_angle(model, q, c)) for c in model.case.constraints
                 if c.type == "revolute" and c["i"] not in fixed and c["j"] not in fixed)


def info(model) -> Info:
    from .branches import sides
    from .diagnose import rank_analysis

    nd = ~model.driving
    q, residual, status, message = assemble(model)
    ok = status is Status.SUCCESS
    at = q
    if at is None:   # the ranks at a least-squares point; the verdict stays the solver's
        at, residual, _ = least_squares_point(model)
    if model.n <= DENSE_RANK_LIMIT:
        rank, redundant = rank_analysis(model, at, 0.0, nd)
        method = "numerical"
    else:
        from scipy.sparse.csgraph import structural_rank

        rank = int(structural_rank(model.jacobian(at, 0.0, sparse=True)[nd].tocsr()))
        redundant, method = (), "structural"
    return Info(
        diagnosis=message, case=model.case.name, coordinates=model.n, artificial_coordinates=len(model.artificial),
        equations=model.m, driving_equations=int(model.driving.sum()), jacobian_nonzeros=model.nnz,
        dof=model.n - rank, residual=float(residual), assembled=ok, rank_method=method,
        redundant_equations=redundant, configuration=configuration(model, q) if ok else (),
        sides=sides(model, q) if ok else (), status=status,
        drawn=tuple((b.name, b.q, b.carries) for b in model.case.bodies if b.carries),
        parameters=tuple(model.case.parameters.items()),
    )


def describe(i: Info) -> str:
    lines = [
        f"case {i.case}",
        f"  coordinates        {i.coordinates} ({i.artificial_coordinates} artificial)",
        f"  equations          {i.equations} ({i.driving_equations} driving)",
        f"  Jacobian non-zeros {i.jacobian_nonzeros} of {i.equations * i.coordinates}"
        f" ({100 * i.jacobian_nonzeros / max(1, i.equations * i.coordinates):.1f}%)",
        f"  degrees of freedom {i.dof} (coordinates minus the {i.rank_method} rank of the non-driving Jacobian)",
        f"  assembly residual  {i.residual:.2e} (scaled)" + (
            " (the assembly kinem solve performs)" if i.assembled
            else "  (least-squares point: the solver's assembly is on a branch the case excludes)"
            if i.status is Status.WRONG_BRANCH else "  NOT ASSEMBLED (least-squares point)"),
    ]
    if i.configuration:
        lines.append("  configuration      " + ", ".join(f"{n} {a:+.3f} rad" for n, a in i.configuration)
                     + " (relative angle at each joint between moving bodies: the branch the estimates chose)")
    for s in i.sides:
        lines.append(f"  cam roller         {s.constraint}: {s.side} the outline (its centre {s.distance:.6g} from the outline's "
                     f"centre, outline radius {s.radius:.6g} at the contact: the branch the estimates chose)")
    if i.parameters:
        lines.append("  parameters         " + ", ".join(f"{n} = {v:.10g}" for n, v in i.parameters))
    for body, q, pts in i.drawn:
        lines.append(f"  drawn body         {body}: frame x {q[0]:.10g}, y {q[1]:.10g}, phi {q[2]:.10g}; local "
                     + ", ".join(f"{n} [{xi:.10g}, {eta:.10g}]" for n, (xi, eta) in pts))
    if i.redundant_equations:
        lines.append("  warning: redundant equations: " + ", ".join(i.redundant_equations))
    if i.diagnosis:
        what = "on a branch the case excludes" if i.status is Status.WRONG_BRANCH else "not assembled"
        lines.append(f"  {what}: {i.diagnosis}")
    if i.equations != i.coordinates:
        lines.append(f"  warning: {i.equations} equations for {i.coordinates} coordinates")
    return "\n".join(lines)


def describe_parameters(listed) -> str:
    """kinem info CASE --parameters: one line per design parameter (kinem.parameters)."""
    width = max([len(p.path) for p in listed] + [4])
    lines = [f"{'path':<{width}}  {'value':>14}  {'unit':<8}  what"]
    lines += [f"{p.path:<{width}}  {p.value:>14.10g}  {p.unit:<8}  {p.what}" for p in listed]
    return "\n".join(lines)


def describe_blocks(model) -> str:
    """kinem info CASE --blocks: the structural decomposition (issue 31,
    docs/solver.md "Structural decomposition") as a table, one line per
    block in solve order: its coordinates and the constraints that close it."""
    from .diagnose import blocks

    s = model.structure
    listed = blocks(model)
    rows = [(str(b.number), str(len(b.coordinates)), ", ".join(b.coordinates), ", ".join(b.constraints))
            for b in listed]
    head = ("block", "size", "coordinates", "closed by")
    width = [max(len(r[k]) for r in rows + [head]) for k in range(3)]
    lines = [f"case {model.case.name}: {len(listed)} block{'s' * (len(listed) != 1)} in solve order "
             f"({s.kind}; structural rank {s.rank} of {model.n} coordinates)"]
    lines += ["  ".join(r[k].ljust(width[k]) for k in range(3)) + "  " + r[3] for r in [head] + rows]
    return "\n".join(line.rstrip() for line in lines)


def blocks_as_dict(model) -> dict:
    """--blocks --json: the same as describe_blocks."""
    from .diagnose import blocks

    s = model.structure
    return {"case": model.case.name, "exact": s.exact, "kind": s.kind, "rank": s.rank,
            "blocks": [{"block": b.number, "coordinates": list(b.coordinates), "constraints": list(b.constraints)}
                       for b in blocks(model)]}
