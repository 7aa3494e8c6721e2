"""What every constraint family shares: the key schema a case-file type
declares, the Family interface, and the planar point kinematics of Sec. 4.1.

Planar vectors are held as complex numbers x + iy inside the families:
A_i s' (Eq. 4.4) is s' e^{i phi}, B_i s' (Eq. 4.44) is i A_i s', a dot b is
Re(conj(a) b) and the scalar cross product a x b is Im(conj(a) b). This halves
the number of array operations per evaluation; every row is still the
chapter's equation.

Every evaluation also takes a batch: q, qd of shape (..., n) and t a scalar
or an array of the leading shape (...) give rows (..., n_rows) and Jacobian
values (..., nnz), one numpy pass for all the instants. Columns are taken
with ``col(q, c)`` (q[..., c], as cheap as q[c] for a single q) and
constraint-major outputs built with ``entries``.
"""
from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Key:
    """One key of a case-file constraint type.

    kind: body | local | number | positive | direction | vector3 | coord |
    function | bool | outline. ``of`` names the body key a ``local`` point lies on.
    """
    name: str
    kind: str
    required: bool = True
    of: str | None = None
    doc: str = ""


@dataclass(frozen=True)
class TypeDecl:
    """A case-file constraint type: its keys, its equations in the chapter, the
    family that evaluates it (None: not implemented yet), and hooks."""
    name: str
    equations: str
    keys: tuple
    family: type | None
    doc: str = ""
    # check(fields, bodies) -> list of (key, problem); may fill defaults into fields
    check: Callable | None = None
    rows: int = 1
    driving: bool = False
    extra: dict = field(default_factory=dict)


class Family:
    """All constraints of one family, evaluated with one numpy pass per quantity.

    q and qd are (n,) or a batch (..., n), t a scalar or an array of the
    batch's leading shape; every method returns its rows (or Jacobian values)
    on the last axis, after the batch's leading axes.

    A subclass sets, in ``__init__(constraints, ctx)``:
      n_rows, labels (one per row), owner (constraint name per row),
      driving (bool per row), scale (per row: the residual that counts as one
      unit of relative error, see docs/solver.md), rows and cols (the
      structural Jacobian pattern, rows local to the family, in the order
      ``jac`` returns values), time_dependent.
    and implements phi, jac, nu (if time-dependent) and gamma.
    """
    time_dependent = False

    def phi(self, q, t):
        raise NotImplementedError

    def jac(self, q, t):
        raise NotImplementedError

    def nu(self, t):
        """Right side of the velocity equation, -Phi_t (zero unless time-dependent)."""
        return np.zeros(getattr(t, "shape", ()) + (self.n_rows,))

    def gamma(self, q, qd, t):
        raise NotImplementedError


def pattern(cols: np.ndarray, entry_rows, rows_per_constraint: int) -> tuple:
    """Global-in-family rows and columns of a Jacobian pattern.

    cols is a (n_constraints, nnz) table of coordinate columns, entry_rows
    gives for each of the nnz entries the row within its constraint; ``jac``
    must return values in the same (constraint-major) order."""
    n = cols.shape[0]
    entry_rows = np.asarray(entry_rows, dtype=np.intp)
    rows = np.arange(n)[:, None] * rows_per_constraint + entry_rows[None, :]
    return rows.ravel().astype(np.intp), np.asarray(cols).ravel().astype(np.intp)


def row_info(constraints, suffixes, driving=False):
    """Labels ("<name>.<suffix>") and owners (constraint names) of the rows
    of constraints with one row per suffix."""
    labels = [f"{c.name}.{s}" if len(suffixes) > 1 else c.name for c in constraints for s in suffixes]
    owners = [c.name for c in constraints for _ in suffixes]
    return labels, owners, np.full(len(labels), driving)


def local_points(values) -> np.ndarray:
    """Local points [(xi, eta), ...] as complex xi + i eta."""
    a = np.asarray(values, dtype=float).reshape(-1, 2)
    return a[:, 0] + 1j * a[:, 1]


def col(q, c):
    """q[..., c]: columns c of one configuration (n,) or of a batch (..., n).
    (q[..., c] costs several times q[c] for a single q; take is the fastest
    gather for a batch.)"""
    return q[c] if q.ndim == 1 else q.take(c, -1)


def frames(q, c):
    """Origins r_i (complex) and rotations e^{i phi_i} of the bodies whose x
    coordinate sits at column ``c``."""
    return col(q, c) + 1j * col(q, c + 1), np.exp(1j * col(q, c + 2))


def rates(qd, c):
    """Origin velocities (complex) and angular velocities of the bodies."""
    return col(qd, c) + 1j * col(qd, c + 1), col(qd, c + 2)


def dot(a, b):
    return (a.conjugate() * b).real


def cross(a, b):
    return (a.conjugate() * b).imag


def entries(*columns):
    """Per-constraint values, each (n_cons,) (a constant) or (..., n_cons),
    side by side: (..., n_cons * k) in constraint-major order
    [c0[0], c1[0], ..., c0[1], c1[1], ...], as ``pattern`` lays out a
    Jacobian's entries. The leading shape is that of the batched columns."""
    shape = columns[0].shape
    for c in columns:
        if c.ndim > len(shape):
            shape = c.shape
    out = np.empty(shape + (len(columns),))
    for k, c in enumerate(columns):
        out[..., k] = c
    return out.reshape(shape[:-1] + (-1,))


def interleave(a, b):
    """Rows [a0, b0, a1, b1, ...]: two rows per constraint."""
    return entries(a, b)
