"""What a (near) singular configuration is: the rank-revealing look at the
dimensionless Jacobian J_s (docs/solver.md) at one configuration.

With J_s = U S V^T, the smallest singular value over the largest is the
conditioning; the left singular vector u of the smallest names the equations
that become dependent (the constraints involved), the right one the
coordinates that become free. The drivers' motion is consistent with the
singular configuration when u . nu_s = 0 (nu_s = nu / scale): then the
motion can continue through it (a bifurcation, e.g. the change point of a
four-bar); otherwise the drivers ask for a motion the mechanism cannot make
(a limit position: dead centre, toggle).
"""
from dataclasses import dataclass

import numpy as np

RANK_TOL = 1e-9       # singular values below this fraction of the largest count as zero
NEAR_SINGULAR = 1e-2   # conditioning below this counts as (near) singular
CONSISTENT = 1e-2      # |u . nu_s| / |nu_s| below this: the drivers' motion fits the singularity
INVOLVED = 0.2         # a row (column) takes part when |u_k| >= INVOLVED max |u|
DENSE_LIMIT = 3000


@dataclass(frozen=True)
class Block:
    """One block of the structural decomposition (kinem.model.Structure) in
    the case's words: its coordinates, the bodies (and artificial
    coordinates) they belong to, and the constraints whose rows close it."""
    number: int           # 1-based, in solve order
    count: int            # blocks in all
    coordinates: tuple    # "rod.x", ...
    owners: tuple         # "rod", "slider", ... (a body, or the constraint of an artificial coordinate)
    constraints: tuple    # constraint names of its rows

    @property
    def what(self) -> str:
        """'the loop of rod, slider' (several coordinates), else the coordinate."""
        if len(self.coordinates) == 1:
            return self.coordinates[0]
        return f"the loop of {', '.join(self.owners)}" if len(self.owners) > 1 else f"the body {self.owners[0]}"

    def words(self) -> str:
        """'block 8 of 8 (the loop of rod, slider, closed by B, A, T)'."""
        return f"block {self.number} of {self.count} ({self.what}, closed by {', '.join(self.constraints)})"


def blocks(model) -> tuple:
    """The model's blocks in solve order, in the case's words (``Block``)."""
    names, owner = model.coordinate_names, model.row_owner
    listed = model.structure.blocks
    return tuple(Block(k + 1, len(listed), tuple(names[c] for c in cols),
                       tuple(dict.fromkeys(names[c].rsplit(".", 1)[0] for c in cols)),
                       tuple(dict.fromkeys(owner[r] for r in sorted(rows))))
                 for k, (rows, cols) in enumerate(listed))


def failing_block(model, J) -> Block | None:
    """The block whose diagonal block of the dimensionless Jacobian J is
    the nearest singular (its smallest singular value the least): det J is
    the product of the blocks' dets, so a singular J has a singular block.
    None where the decomposition is not exact (one block: nothing to add)."""
    s = model.structure
    if not s.exact or len(s.blocks) < 2:
        return None
    smallest = [np.linalg.svd(J[np.ix_(rows, cols)], compute_uv=False)[-1] for rows, cols in s.blocks]
    return blocks(model)[int(np.argmin(smallest))]


def block_of_row(model, row) -> Block | None:
    """The block that holds a row (None where the decomposition is not
    exact or is one block)."""
    s = model.structure
    if not s.exact or len(s.blocks) < 2:
        return None
    return next(b for b, (rows, _) in zip(blocks(model), s.blocks) if row in rows)


@dataclass(frozen=True)
class Diagnosis:
    t: float
    conditioning: float
    consistent: bool
    constraints: tuple
    coordinates: tuple
    block: Block | None = None   # the block that is singular (structural decomposition), when it tells more

    @property
    def singular(self) -> bool:
        return self.conditioning < NEAR_SINGULAR

    def message(self) -> str:
        kind = ("the drivers' motion fits it (a bifurcation: the branch cannot be told)" if self.consistent
                else "the drivers ask for a motion the mechanism cannot make here (a limit position)")
        where = f"in {self.block.words()}, " if self.block is not None else ""
        return (f"singular configuration at t = {self.t:.6g}: {where}conditioning {self.conditioning:.1e} "
                f"(smallest/largest singular value of the dimensionless Jacobian); {kind}; "
                f"constraints involved: {', '.join(self.constraints)}; free coordinates: {', '.join(self.coordinates)}")


def diagnose(model, q, t) -> Diagnosis:
    if model.n > DENSE_LIMIT:
        return _diagnose_sparse(model, q, t)
    J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)
    if not np.isfinite(J).all():
        return Diagnosis(float(t), 0.0, False, ("(non-finite Jacobian)",), ())
    U, s, Vt = np.linalg.svd(J)
    cond = float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0
    k = len(s) - 1
    u, v = U[:, k] if U.shape[1] > k else U[:, -1], Vt[-1]
    nu = model.nu(t) / model.scale
    norm = np.linalg.norm(nu)
    consistent = bool(norm == 0 or abs(u @ nu) / norm < CONSISTENT)
    rows = np.flatnonzero(np.abs(u) >= INVOLVED * np.abs(u).max())
    cols = np.flatnonzero(np.abs(v) >= INVOLVED * np.abs(v).max())
    owners = tuple(dict.fromkeys(model.row_owner[r] for r in rows))
    return Diagnosis(float(t), cond, consistent, owners, tuple(model.coordinate_names[c] for c in cols),
                     failing_block(model, J))


def _diagnose_sparse(model, q, t) -> Diagnosis:
    """Large models: the sparse LU's smallest pivot only (no SVD)."""
    from .errors import SingularError
    from .linalg import Factor

    try:
        f = Factor(model, model.jac_values(q, t))
        cond = f.pivot_ratio
    except SingularError:
        cond = 0.0
    return Diagnosis(float(t), cond, False, ("(not resolved above 3000 coordinates)",), ())


def rank_analysis(model, q, t=0.0, rows=None):
    """(rank, dependent equation labels) of the dimensionless Jacobian's rows
    (all, or a boolean mask): SVD for the rank, QR with column pivoting of
    the transpose to name the rows that depend on the others."""
    from scipy.linalg import qr

    J = model.assemble(model.jac_values(q, t) * model.entry_scale, sparse=False)
    if not np.isfinite(J).all():
        from .errors import AnalysisError

        raise AnalysisError(f"non-finite Jacobian at t = {t:g}: the configuration overflowed")
    labels = np.array(model.row_labels, dtype=object)
    if rows is not None:
        J, labels = J[rows], labels[rows]
    if not J.size:
        return 0, ()
    s = np.linalg.svd(J, compute_uv=False)
    rank = int((s > RANK_TOL * s[0]).sum()) if s.size and s[0] > 0 else 0
    _, _, perm = qr(J.T, pivoting=True, mode="economic")
    order = list(model.row_labels)
    return rank, tuple(sorted(labels[perm[rank:]], key=order.index))


LOOP_SHARE = 1e-3   # a row is on the failing loop when its least-squares residual is this share of the largest
EXPLAIN_ITERATIONS = 50
EXPLAIN_LIMIT = 400  # coordinates: above, dense least squares would cost more than the failed run


HOLD = 1e4  # weight of the constraints kept closed while the open one's miss is made least


def _open(model, q, t, weights):
    """The configuration nearest q that makes the weighted sum of squared
    dimensionless residuals least (scipy's trust-region least squares: plain
    Gauss-Newton diverges on a residual that cannot vanish)."""
    from scipy.optimize import least_squares

    def fun(x):
        return weights * model.phi(model.col_scale * x, t) / model.scale

    def jac(x):
        return weights[:, None] * model.assemble(model.jac_values(model.col_scale * x, t) * model.entry_scale,
                                                 sparse=False)

    fit = least_squares(fun, q / model.col_scale, jac=jac, method="trf", xtol=1e-14, ftol=1e-14, gtol=1e-14,
                        max_nfev=200)
    return model.col_scale * fit.x


def cycle(model, name) -> list:
    """The other constraints of the shortest loop through constraint ``name``
    in the graph of bodies joined by the kinematic (non-driving) constraints;
    a constraint on one body joins it to the fixed frame. [] if none."""
    from collections import deque

    from .casefile.keys import BodyKey
    from .constraints import REGISTRY

    driving = set(np.asarray(model.row_owner, dtype=object)[model.driving])
    edges, ends = {}, None
    for c in model.case.constraints:
        bodies = [c[k.name] for k in REGISTRY[c.type].keys if isinstance(k, BodyKey) and k.name in c.fields]
        a, b = (bodies + ["(fixed frame)"])[:2]
        if c.name == name:
            ends = (a, b)
        elif c.name not in driving:
            edges.setdefault(a, []).append((b, c.name))
            edges.setdefault(b, []).append((a, c.name))
    if ends is None:
        return []
    previous, todo = {ends[0]: None}, deque([ends[0]])
    while todo:
        node = todo.popleft()
        for nxt, via in edges.get(node, ()):
            if nxt not in previous:
                previous[nxt] = (node, via)
                todo.append(nxt)
    if ends[1] not in previous:
        return []
    path, node = [], ends[1]
    while previous[node] is not None:
        node, via = previous[node]
        path.append(via)
    return path


# A residual below ROUNDING x eps x (the largest |x|, |y|) / L is rounding: each
# equation sums a few coordinates and rotated local vectors, each rounded to eps of itself.
ROUNDING = 64


def _beyond_precision(model, q, residual, tolerance) -> str:
    """The explanation when the residual left is what double precision can
    resolve where the mechanism is (far from the origin), '' otherwise."""
    names = np.asarray(model.coordinate_names, dtype=object)
    xy = np.array([n.endswith((".x", ".y")) for n in names], bool)
    if not xy.any():
        return ""
    far = float(np.abs(q[xy]).max())
    floor = ROUNDING * np.finfo(float).eps * far / model.length   # the scale of the length equations
    if residual > floor:
        return ""
    unit = model.case.length_unit
    u = f" {unit}" if unit else ""
    return (f"the mechanism is {far:.3g}{u} from the origin, where double precision resolves only about "
            f"{np.finfo(float).eps * far:.2g}{u}: the tolerance {tolerance:g} (scaled residual) cannot be "
            "reached there; move the mechanism nearer the origin, or loosen [solver] tolerance")


def driver_count(model, t=0.0, q=None, settle=True):
    """(least-squares configuration, '' or why the driving equations do not
    match the degrees of freedom: their count and names, the mobility both
    ways (the Gruebler count, coordinates minus kinematic equations, and
    coordinates minus the rank of their Jacobian) and how many to add or
    remove); None where it cannot be told (too large, no equations, not finite).
    ``settle``: the ranks at the least-squares configuration from q (default
    the estimates); else at q itself."""
    from .analysis import gauss_newton

    if model.n > EXPLAIN_LIMIT or model.m == 0:
        return None
    q_ls = (model.q0 if q is None else q).copy()
    if settle:
        q_ls, _ = gauss_newton(model, q_ls, t, EXPLAIN_ITERATIONS)
    J = model.assemble(model.jac_values(q_ls, t) * model.entry_scale, sparse=False)
    if not (np.isfinite(q_ls).all() and np.isfinite(J).all()):
        return None
    nd = ~model.driving
    s = np.linalg.svd(J[nd], compute_uv=False) if nd.any() else np.zeros(0)
    rank = int((s > RANK_TOL * s[0]).sum()) if s.size and s[0] > 0 else 0
    dof, drivers = model.n - rank, list(dict.fromkeys(np.asarray(model.row_owner, dtype=object)[model.driving]))
    n_driving = int(model.driving.sum())
    if n_driving == dof:
        return q_ls, ""
    named = f" ({', '.join(drivers)})" if drivers else ""
    gap = abs(n_driving - dof)
    kinematic = int(nd.sum())
    return q_ls, (f"too {'many' if n_driving > dof else 'few'} driving equations: {n_driving}{named} for "
                  f"{dof} degree{'s' * (dof != 1)} of freedom ({model.n} coordinates, {rank} independent "
                  f"kinematic equations; Gruebler count {model.n} - {kinematic} = {model.n - kinematic}"
                  + (f", {kinematic - rank} redundant" if kinematic > rank else "") + "): "
                  + (f"remove {gap} driving equation{'s' * (gap != 1)}" if n_driving > dof else
                     f"add {gap} driver{'s' * (gap != 1)} (one per degree of freedom)"))


def explain_assembly(model, t=0.0, q=None, tolerance=1e-12) -> str:
    """Why an assembly at t fails, in the user's terms ('' when no cause is
    found): a number of driving equations other than the degrees of freedom
    (named, with the count), or the loop of constraints that cannot close
    and its gap.

    The least-squares configuration (Gauss-Newton, minimum norm) gives the
    rank of the kinematic equations (degrees of freedom = coordinates minus
    that rank) and, when the counts agree, its residual spreads over the
    constraints of the loop that cannot close. The constraint with the
    largest residual is then left open and the rest solved: how far its
    equations miss is the gap."""
    counted = driver_count(model, t, q)
    if counted is None:
        return ""
    q_ls, message = counted
    if message:
        return message
    nd = ~model.driving
    r = np.abs(model.phi(q_ls, t)) / model.scale
    if not r.size or r.max() <= tolerance:
        return ""
    far = _beyond_precision(model, q_ls, r.max(), tolerance)
    if far:
        return far
    owners = np.asarray(model.row_owner, dtype=object)
    kinematic = np.where(nd, r, 0.0)
    worst_row = int(np.argmax(kinematic if kinematic.max() > 0 else r))
    worst = owners[worst_row]
    loop = [worst] + cycle(model, worst)
    if len(loop) == 1:  # no kinematic loop through it: the constraints left with a residual
        loop = list(dict.fromkeys(owners[r >= LOOP_SHARE * r.max()]))
    mine = owners == worst
    q_open = _open(model, q_ls, t, np.where(mine, 1.0, HOLD))
    text = f"the loop of constraints {', '.join(loop)} cannot close"
    block = block_of_row(model, worst_row)
    if block is not None:
        text += f" in {block.words()}"
    rest = np.abs(model.phi(q_open, t)[~mine]) / model.scale[~mine]
    if rest.max(initial=0.0) > 1e-6:  # the rest does not close (to 1e-6 of its scale): no single gap to give
        return text
    miss = float(np.linalg.norm(model.phi(q_open, t)[mine]))
    if np.all(model.scale[mine] == model.length):
        unit = model.case.length_unit
        return text + f": with '{worst}' left open, its ends are {miss:.4g}{' ' + unit if unit else ''} apart"
    return text + f": with '{worst}' left open, its equations miss by {miss:.4g}"


# higher pairs with a contact angle: type -> (outline's body key, other body key, the other's point key)
CONTACTS = {"cam-roller": ("cam", "follower", "sj"), "cam-point": ("cam", "follower", "sj"),
            "cam-flat": ("cam", "follower", "sj"), "point-follower": ("j", "i", "si")}
FAR_THETA = 0.5   # rad between a contact angle's estimate and where the bodies' estimates put the contact


def contact_hint(model) -> str:
    """'' or, for each higher pair whose contact-angle estimate ``theta`` is
    far (more than FAR_THETA) from where its bodies' estimates put the
    contact, the value it would need: the polar angle, about the outline's
    centre in the outline body's frame, of the follower's point (a roller's
    centre, a pin), or for a flat face the direction of the face's normal
    that points from the outline towards the face."""
    bodies = {b.name: b.q for b in model.case.bodies}
    hints = []
    for c in model.case.constraints:
        if c.type not in CONTACTS or "theta" not in c.fields:
            continue
        on, other, key = CONTACTS[c.type]
        (xi, yi, pi), (xj, yj, pj) = bodies[c[on]], bodies[c[other]]
        centre = complex(*c["outline"].center)
        point = complex(xj, yj) + complex(*c[key]) * np.exp(1j * pj)       # the follower's point, global
        local = (point - complex(xi, yi)) * np.exp(-1j * pi) - centre       # about the outline's centre
        if c.type == "cam-flat":
            n = complex(*c["normal"]) * np.exp(1j * (pj - pi))            # the face's normal in the cam's frame
            local = n if (local.conjugate() * n).real > 0 else -n
        if abs(local) == 0:
            continue
        need = float(np.angle(local))
        off = (c["theta"] - need + np.pi) % (2 * np.pi) - np.pi           # wrapped: a turn more is no mistake
        if abs(off) > FAR_THETA:
            a, b = c["outline"].span
            turns = [need + 2 * np.pi * k for k in range(-4, 5)]
            inside = [x for x in turns if a <= x <= b]                   # on the outline's table if it can be
            need = min(inside or turns, key=lambda x: abs(x - c["theta"]))
            hints.append(f"the estimate theta = {c['theta']:.6g} of '{c.name}' is {abs(off):.3g} rad from where "
                         f"the bodies' estimates put the contact: try theta = {need:.6g}")
    return "; ".join(hints)
