"""Solving many variants of a mechanism together.

``merge`` turns B cases on one time grid into one case whose bodies, points
and constraints are those of every variant, renamed ``v<k>-<name>``: its
Jacobian is block-diagonal (kinem.model.Blocks, a block per variant), and
the compiled march splits it into one model per variant and marches those
in parallel, each converging on its own (docs/solver.md, "The march").
``split`` recovers variant k's trajectory with its own column names.

An instant that one variant does not accept in the march (a sub-step, a
limit position) is taken by the tracker for the whole merged case; residuals
are measured against the largest variant's size: give variants of comparable
size (the usual case for a parameter sweep).

``solve_merged`` is the one merged-batch solver of sweeps, tolerance bands
and variant batches (where kinem.variants' march cannot take them): a batch
of variant cases solved as one merged case, a batch that fails halved until
each failing variant is solved alone; where the variants start is the
caller's explicit choice (``start``).
"""
import re
from dataclasses import dataclass, replace

import numpy as np

from .casefile.keys import BodyKey
from .constraints import REGISTRY
from .errors import InputError
from .result import Trajectory
from .spec import Case, frozen_map

OWN = "own"   # solve_merged's start: each variant from its own case's estimates


def prefix(k: int) -> str:
    return f"v{k}-"


def unprefix(name: str) -> tuple[int, str]:
    """A merged name's variant and own name: "v3-crank.x" -> (3, "crank.x")."""
    head, own = name.split("-", 1)
    return int(head[1:]), own


def merge(cases, name="batch") -> Case:
    cases = list(cases)
    if not cases:
        raise InputError("merge: no cases")
    if not all(isinstance(c, Case) for c in cases):
        bad = next(c for c in cases if not isinstance(c, Case))
        raise InputError(f"merge: cases: a {type(bad).__name__}; expected kinem.Case objects (kinem.load(path))")
    end, steps = cases[0].end, cases[0].steps
    if any(c.end != end or c.steps != steps for c in cases):
        raise InputError("merge: the variants must share their output instants (end and steps)")
    bodies, points, constraints = [], [], []
    for k, c in enumerate(cases):
        p = prefix(k)
        bodies += [replace(b, name=p + b.name) for b in c.bodies]
        points += [replace(pt, name=p + pt.name, body=p + pt.body) for pt in c.points]
        for con in c.constraints:
            keys = {key.name for key in REGISTRY[con.type].keys if isinstance(key, BodyKey)}
            fields = {f: (p + v if f in keys else v) for f, v in con.fields.items()}
            constraints.append(replace(con, name=p + con.name, index=len(constraints) + 1, fields=frozen_map(fields),
                                       refs=frozen_map({k: p + v for k, v in con.refs.items()})))
    return Case(name=name, bodies=tuple(bodies), points=tuple(points), constraints=tuple(constraints), end=end,
                steps=steps, tolerance=min(c.tolerance for c in cases),
                max_iterations=max(c.max_iterations for c in cases), linear_solver="auto",
                description=f"{len(cases)} variants merged", units=cases[0].units, source="<batch>")


def variants(traj: Trajectory) -> int:
    """The number of variants of a merged trajectory (0: not one)."""
    found = [re.match(r"v(\d+)-", c) for c in traj.columns]
    return 1 + max((int(m.group(1)) for m in found if m), default=-1)


def split(traj: Trajectory, k: int) -> Trajectory:
    """Variant k's columns of a merged trajectory, with their own names
    (InputError for a k that is not one of its variants)."""
    if not isinstance(traj, Trajectory):
        raise InputError(f"split: traj {type(traj).__name__}: expected the Trajectory of a merged case")
    whole = not isinstance(k, bool) and isinstance(k, (int, np.integer)) and k >= 0
    p = prefix(k) if whole else ""
    idx = [i for i, c in enumerate(traj.columns) if c.startswith(p)] if whole else []
    if not idx:   # the variants counted only to say what was expected (a pass over every column)
        count = variants(traj)
        raise InputError(f"split: k {k!r:.40}: expected a variant index, a whole number from 0 to {count - 1}"
                         if count else f"split: k {k!r:.40}: the trajectory has no variants (not of a merged case)")
    return Trajectory(np.array(traj.t), tuple(traj.columns[i][len(p):] for i in idx),
                      np.ascontiguousarray(traj.data[:, idx]))


@dataclass(frozen=True, eq=False)
class Solved:
    """One variant's outcome in ``solve_merged``: ``data`` its columns (K, C)
    and ``q`` its state at the first instant (its own coordinates, in its own
    model's order), or both None and ``why`` says why ("" when solved)."""
    data: np.ndarray | None
    q: np.ndarray | None
    why: str = ""


def solve_merged(cases, columns, *, start, times=None, options=None) -> list:
    """Solves ``cases`` (variant Cases of one mechanism; an InputError in
    place of a case that could not be made is reported as bad input) as one
    merged case (``merge``) and returns a Solved per case. A batch that fails
    (or whose merged equations are refused as input) is halved, until each
    failing variant is solved alone by its own case.

    ``start`` is where every variant starts, an explicit choice:
    ``OWN``: from its own case's estimates (its bodies' q, each variant
    assembled on its own: a sweep); or a mapping {coordinate name: value},
    the nominal's state at the first instant (kinem.Model.coordinate_names),
    each variant from it, so that it assembles near the nominal's branch
    (the caller checks the branch on ``Solved.q``: tolerance bands, variant
    batches). ``times`` and ``options`` as ``solve``'s (None: the case's)."""
    from .result import stages_for

    if not (start is OWN or hasattr(start, "items")):
        raise InputError(f"solve_merged: start {start!r:.40}: expected kinem.batch.OWN or a mapping "
                         "{coordinate name: value}")
    out = [Solved(None, None, f"bad input: {c.summary()}") if isinstance(c, InputError) else None for c in cases]
    _halving([k for k, c in enumerate(cases) if out[k] is None], list(cases), tuple(columns),
             stages_for(columns), start, times, options, out)
    return out


def _halving(ks, cases, columns, stages, start, times, options, out):
    from .model import compile
    from .solver import solve

    if not ks:
        return
    p = [prefix(j) if len(ks) > 1 else "" for j in range(len(ks))]
    try:
        model = compile(merge([cases[k] for k in ks]) if len(ks) > 1 else cases[ks[0]])
    except InputError as e:   # e.g. a variant whose equations cannot be counted square
        if len(ks) == 1:
            out[ks[0]] = Solved(None, None, f"bad input: {e.summary()}")
            return
        model = None
    if model is not None:
        names = model.coordinate_names
        split_names = [(0, n) for n in names] if len(ks) == 1 else [unprefix(n) for n in names]
        q0 = None if start is OWN else np.array([start[own] for _, own in split_names])
        r = solve(model, outputs=stages, times=times, options=options, q0=q0)
        if r.success:
            at = {}   # variant j's coordinates by their merged names
            for i, (j, _) in enumerate(split_names):
                at.setdefault(j, []).append(i)
            for j, k in enumerate(ks):
                out[k] = Solved(np.column_stack([r.trajectory[p[j] + c] for c in columns]), r.q[0, at[j]])
            return
        if len(ks) == 1:
            out[ks[0]] = Solved(None, None, f"{r.status.name}: {r.message}")
            return
    half = len(ks) // 2
    _halving(ks[:half], cases, columns, stages, start, times, options, out)
    _halving(ks[half:], cases, columns, stages, start, times, options, out)
