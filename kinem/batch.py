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
"""
import re
from dataclasses import replace

import numpy as np

from .casefile.keys import BodyKey
from .constraints import REGISTRY
from .errors import InputError
from .result import Trajectory
from .spec import Case, frozen_map


def prefix(k: int) -> str:
    return f"v{k}-"


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
