"""How close a motion is to trouble (``solve(..., outputs=(..., "margins"))``;
docs/design.md, "Margins"):

- ``margin``: per instant, the smallest singular value of the dimensionless
  constraint Jacobian J_s = diag(1/scale) Phi_q diag(col_scale) (the
  driving rows included: the system the analysis solves; docs/solver.md).
  It is zero at a singular position (a dead point of the driven mechanism,
  a change point) and, unlike the pivot ratio, a distance: the smallest
  relative change of J_s that makes it singular (Eckart-Young). Its right
  singular vector says which coordinates move in the motion that
  singularity allows: ``moves`` names those with at least half the largest
  component.
- ``<joint>.transmission``: at every revolute joint that joins two binary
  links (moving bodies with exactly two revolute joints), the angle in
  [0, pi] between the two links, each taken from the joint to its other
  joint: the transmission angle (90 degrees is ideal, 0 or 180 a toggle).
"""
import numpy as np

MARGINS = "margins"


def joints(model) -> tuple:
    """(joint, body i, s'_i, other joint's s' on i, body j, s'_j, other s' on j)
    for every revolute joint between two binary links."""
    fixed = {c["body"] for c in model.case.constraints if c.type == "ground"}
    on = {}
    for c in model.case.constraints:
        if c.type == "revolute":
            on.setdefault(c["i"], []).append((c, c["si"]))
            on.setdefault(c["j"], []).append((c, c["sj"]))
    binary = {b for b, js in on.items() if len(js) == 2 and b not in fixed}
    out = []
    for c in model.case.constraints:
        if c.type == "revolute" and c["i"] in binary and c["j"] in binary:
            other = {b: next(s for k, s in on[b] if k is not c) for b in (c["i"], c["j"])}
            out.append((c.name, c["i"], c["si"], other[c["i"]], c["j"], c["sj"], other[c["j"]]))
    return tuple(out)


def margins(model, Q, times):
    """(column names, values (K, columns), moves: per instant the names of
    the coordinates the smallest singular vector moves)."""
    Q = np.asarray(Q, float)
    if not len(Q):
        return ("margin",) + tuple(f"{j[0]}.transmission" for j in joints(model)), np.zeros((0, 1)), ()
    J = model.assemble(model.jac_values(Q, np.asarray(times, float)) * model.entry_scale, sparse=False)
    _, s, vt = np.linalg.svd(J)
    if model.m < model.n:   # a deficient system: singular
        s = np.zeros((len(Q), 1))
    v = np.abs(vt[:, -1, :])
    moves = tuple(tuple(model.coordinate_names[j] for j in np.flatnonzero(row >= 0.5 * row.max())) for row in v)
    names, cols = ["margin"], [s[:, -1]]
    col = {b: 3 * k for k, b in enumerate(model.body_names)}
    for name, bi, si, oi, bj, sj, oj in joints(model):
        ui, uj = _link(Q, col[bi], si, oi), _link(Q, col[bj], sj, oj)
        names.append(f"{name}.transmission")
        cols.append(np.abs(np.angle(uj / ui)))
    return tuple(names), np.column_stack(cols), moves


def _link(Q, c, here, there):
    """The link's direction from the joint (here, local) to its other joint, global."""
    return (complex(*there) - complex(*here)) * np.exp(1j * Q[:, c + 2])
