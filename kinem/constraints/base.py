"""What every constraint family shares: the keys a case-file type declares
(kinds in kinem.casefile.keys), the Family interface, and the compiled-kernel conventions.

Each family evaluates Phi, its Jacobian values and gamma with kernels
compiled by numba (``kernel``), one loop over the instants of a batch and
the constraints of the family; one call evaluates all constraints of a type
at all instants. The Python methods only reshape: q and qd of shape (n,) or
(..., n) and t a scalar or an array of the leading shape (...) give rows
(..., n_rows) and Jacobian values (..., nnz). Time functions (drivers) are
evaluated by numpy before the call (kinem.functions) and passed per instant.

Planar vectors are complex numbers x + iy inside the kernels: A_i s' (Eq.
4.4) is s' e^{i phi} (e^{i phi} read from E, computed once per
configuration: ``rotations``), B_i s' (Eq. 4.44) is i A_i s', a dot b is
Re(conj(a) b) and the scalar cross product a x b is Im(conj(a) b). Every row
is still the chapter's equation.

Kernels call compiled helpers of their own module only (kinem.jit).
"""
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..casefile.keys import (BodyKey, BoolKey, CoordKey, DirectionKey, FunctionKey, Key, LocalKey,  # noqa: F401
                             NumberKey, OutlineKey, PositiveKey, Vector3Key)  # the key kinds types declare
from ..jit import kernel  # noqa: F401  (the families' decorator)


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
    """All constraints of one family, evaluated by one kernel call per quantity.

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

    def table(self, functions, outlines) -> tuple:
        """(kind, {column: 1-d array}): the family's struct-of-arrays table
        for the compiled core (kinem/core/src/families), indices of driving
        functions and outlines numbered by ``functions``
        (kinem.functions.FunctionTable) and ``outlines``
        (kinem.outline.OutlineTable), model-wide."""
        raise NotImplementedError

    def march(self, times):
        """What the compiled march (kinem.march) calls for this family at the
        output instants ``times`` (K,): three tuples of ``Call``, for phi,
        the Jacobian values and gamma; the last call of each writes the
        family's rows (or values)."""
        raise NotImplementedError


@dataclass(frozen=True)
class Call:
    """One kernel call of the compiled march at output instant k:
    kernel(q, [qd,] *args, [values[k:k+1],] [out]) with q (1, n)."""
    kernel: object
    args: tuple
    values: np.ndarray | None = None   # time-function values (K, rows) it takes after args
    rates: bool = False                # it takes qd after q
    out: bool = True                   # it writes the rows (the last call of a stage)


class Compiled(Family):
    """A family whose phi, jac and gamma are its ``kernels`` (phi, jac, gamma),
    each called as kernel(Q[, QD], *self.args, out)."""
    kernels: tuple = ()

    def phi(self, q, t):
        return call(self.kernels[0], self.n_rows, q, *self.args)

    def jac(self, q, t):
        return call(self.kernels[1], len(self.rows), q, *self.args)

    def gamma(self, q, qd, t):
        return call(self.kernels[2], self.n_rows, q, *self.args, qd=qd)

    def march(self, times):
        phi, jac, gamma = self.kernels
        return (Call(phi, self.args),), (Call(jac, self.args),), (Call(gamma, self.args, rates=True),)


def ints(a) -> np.ndarray:
    """Indices or flags as the compiled core's tables take them (int64)."""
    return np.ascontiguousarray(a, dtype=np.int64)


def reals(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def points(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.complex128)


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


def batch(q):
    """q (n,) or (..., n) as a writeable C-contiguous float (K, n) array (the
    one array type the kernels are compiled for), and the leading shape."""
    q = np.asarray(q, dtype=float)
    Q = np.ascontiguousarray(q.reshape(-1, q.shape[-1]))
    if not Q.flags.writeable:
        Q = Q.copy()
    return Q, q.shape[:-1]


def per_instant(values):
    """Values of time functions, (rows,) at one t or (..., rows) at a batch of
    t, as (1, rows) or (K, rows): kernels read row ``0 if len == 1 else k``."""
    v = np.asarray(values, dtype=float)
    return np.ascontiguousarray(v.reshape(-1, v.shape[-1]))


def call(fn, width, q, *args, qd=None):
    """fn(Q[, QD], E, *args, out) on the batch of q (and qd), out (K, width),
    E = exp(i Q) (``rotations``); returns out with q's leading shape."""
    if qd is None:
        Q, lead = batch(q)
        out = np.empty((Q.shape[0], width))
        fn(Q, rotations(Q), *args, out)
    else:
        if np.shape(q) != np.shape(qd):
            q, qd = np.broadcast_arrays(q, qd)
        Q, lead = batch(q)
        out = np.empty((Q.shape[0], width))
        fn(Q, batch(qd)[0], rotations(Q), *args, out)
    return out.reshape(lead + (width,))


def rotations(Q):
    """E = exp(i Q) (K, n), what the kernels read for A_i (E[k, phi column
    of body i]) and for an outline's angle (E[k, theta column]): shared by all
    the constraints of a body and all the families of a model. Only the angle
    columns are read; the compiled march computes only those."""
    return np.exp(1j * Q)

