"""Driving functions d(t) (Sec. 4.2.8) and their exact first and second derivatives.

A case file gives a function as a bare number (constant), ``{poly = [c0, c1, ...]}``
(sum of c_k t^k), ``{harmonic = {amplitude, omega, phase, offset}}``
(offset + amplitude sin(omega t + phase)) or ``{table = {t = [...], value = [...]}}``
(not-a-knot cubic spline through the table). The compiled core evaluates
them in the analysis (kinem/core/src/functions.rs, from ``FunctionTable``);
``FunctionSet`` evaluates them with numpy for everything else (the engines'
drives, the report's references).
"""
from dataclasses import dataclass

import numpy as np

from . import native



@dataclass(frozen=True)
class Poly:
    coeffs: tuple


@dataclass(frozen=True)
class Harmonic:
    amplitude: float
    omega: float
    phase: float = 0.0
    offset: float = 0.0


@dataclass(frozen=True)
class Table:
    t: tuple
    value: tuple


def constant(c) -> Poly:
    return Poly((float(c),))


def value_at(f, t: float, order: int = 0) -> float:
    """d(t), d'(t) or d''(t) of a single function."""
    return float(FunctionSet([f])(t, order)[0])


class FunctionSet:
    """Several functions, evaluated together by the compiled core (the
    analysis's own evaluation, kinem/core/src/functions.rs, from their
    ``FunctionTable``)."""

    def __init__(self, funcs):
        funcs = list(funcs)
        if not all(isinstance(f, (Poly, Harmonic, Table)) for f in funcs):
            raise TypeError("unknown function kind")
        self.funcs = tuple(funcs)
        self.n = len(funcs)
        self.constant = all(isinstance(f, Poly) and len(f.coeffs) == 1 for f in funcs)
        table = FunctionTable()
        self._index = table.indices(funcs)
        self._table = table.arrays()

    def __call__(self, t, order: int = 0) -> np.ndarray:
        """d^(order)(t) for every function, order 0, 1 or 2: (n,) at a scalar
        t, S + (n,) at an array of instants of shape S."""
        t = np.asarray(t, dtype=float)
        flat = np.ascontiguousarray(t.reshape(-1))
        out = native.functions(self._table, flat, order)[:, self._index]
        return out.reshape(t.shape + (self.n,))


# kinds of kinem/core/src/functions.rs
POLY, HARMONIC, PIECES = 0, 1, 2


def spline_pieces(f: Table):
    """Breakpoints x (k+1,) and coefficients c (4, k) of a table function:
    its not-a-knot CubicSpline (scipy's PPoly layout)."""
    from scipy.interpolate import CubicSpline

    s = CubicSpline(np.asarray(f.t, float), np.asarray(f.value, float))
    return s.x, s.c


def identity(obj) -> tuple:
    """A hashable key of a frozen dataclass by value (its fields may be lists)."""
    return (type(obj),) + tuple(tuple(np.ravel(v).tolist()) if isinstance(v, (list, tuple, np.ndarray)) else v
                                for v in vars(obj).values())


class FunctionTable:
    """Every driving function of a model, numbered as the compiled core
    (kinem._core) reads them: ``index`` gives a function's number (equal
    functions share one), ``arrays`` the table {kind, start, data} of
    kinem/core/src/functions.rs: function f's parameters are
    data[start[f]:start[f + 1]], POLY c_0 .. c_d, HARMONIC amplitude, omega,
    phase, offset, PIECES k, the k + 1 breakpoints and the 4 k coefficients
    piece by piece, highest power first."""

    def __init__(self, share: bool = True):
        self.functions = []
        self._number = {}
        self.share = share   # False: every function its own number (kinem.sensitivity's tables line up)

    def index(self, f) -> int:
        key = identity(f) if self.share else len(self.functions)
        k = self._number.get(key)
        if k is None:
            k = self._number[key] = len(self.functions)
            self.functions.append(f)
        return k

    def indices(self, funcs) -> np.ndarray:
        return np.array([self.index(f) for f in funcs], dtype=np.int64)

    def arrays(self) -> dict:
        kinds, parts = [], []
        for f in self.functions:
            if isinstance(f, Poly):
                kinds.append(POLY)
                parts.append(np.asarray(f.coeffs, float))
            elif isinstance(f, Harmonic):
                kinds.append(HARMONIC)
                parts.append(np.array([f.amplitude, f.omega, f.phase, f.offset], float))
            elif isinstance(f, Table):
                kinds.append(PIECES)
                parts.append(pieces(f))
            else:
                raise TypeError("unknown function kind")
        return table_arrays(kinds, parts)


def pieces(f: Table) -> np.ndarray:
    """A table's parameters as the core reads them: k, the k + 1 breakpoints, the 4 k coefficients piece by piece
    (its not-a-knot spline, spline_pieces)."""
    x, c = spline_pieces(f)
    return np.concatenate([[len(x) - 1.0], x, c.T.ravel()])


def table_arrays(kinds, parts) -> dict:
    """The core's function table {kind, start, data} of functions of ``kinds`` with parameters ``parts``."""
    start = np.concatenate([[0], np.cumsum([len(p) for p in parts], dtype=np.int64)]).astype(np.int64)
    return {"kind": np.array(kinds, dtype=np.int64), "start": start,
            "data": np.concatenate(parts) if len(parts) else np.zeros(0)}
