"""What every constraint family shares: the keys a case-file type declares
(kinds in kinem.casefile.keys) and the Family interface.

A family's equations (Phi, its Jacobian values, nu and gamma) live in the
compiled core, one Rust module each (kinem/core/src/families/), evaluated
over all the constraints of the family at once. Its Python class holds what
``compile()`` needs: the rows (labels, owners, driving flags, residual
scales), the Jacobian's structural pattern, in the order the core gives the
values, and ``table()``, the struct-of-arrays table handed to the core.
"""
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..casefile.keys import (BodyKey, BoolKey, CoordKey, DirectionKey, FunctionKey, Key, LocalKey,  # noqa: F401
                             NumberKey, OutlineKey, PositiveKey, Vector3Key, WordKey)  # the key kinds types declare


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
    """All constraints of one family.

    A subclass sets, in ``__init__(constraints, ctx)``:
      n_rows, labels (one per row), owner (constraint name per row),
      driving (bool per row), scale (per row: the residual that counts as one
      unit of relative error, see docs/solver.md), rows and cols (the
      structural Jacobian pattern, rows local to the family, in the order
      the core's family module gives the values),
    and implements ``table``.
    ``lands``: the keys whose point (xi + i eta) or number lands as it is
    in a column of the table, one entry per constraint in the family's
    order (key -> column; kinem.sensitivity takes their tangents there
    directly), and
    ``spans``: the columns that hold the difference of two such keys'
    points, column -> (key a, key b) for a - b.
    """
    lands: dict = {}
    spans: dict = {}

    def table(self, functions, outlines) -> tuple:
        """(kind, {column: 1-d array}): the family's struct-of-arrays table
        for the compiled core (kinem/core/src/families), indices of driving
        functions and outlines numbered by ``functions``
        (kinem.functions.FunctionTable) and ``outlines``
        (kinem.outline.OutlineTable), model-wide."""
        raise NotImplementedError


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
