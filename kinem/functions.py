"""Driving functions d(t) (Sec. 4.2.8) and their exact first and second derivatives.

A case file gives a function as a bare number (constant), ``{poly = [c0, c1, ...]}``
(sum of c_k t^k), ``{harmonic = {amplitude, omega, phase, offset}}``
(offset + amplitude sin(omega t + phase)) or ``{table = {t = [...], value = [...]}}``
(not-a-knot cubic spline through the table). ``FunctionSet`` evaluates all the
functions of one constraint family at once: polynomials and harmonics in one
compiled loop (kinem.jit), tables by scipy.
"""
from dataclasses import dataclass

import numpy as np

from .jit import kernel


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


@kernel
def _evaluate(t, order, poly_idx, coeffs, harm_idx, harm, out):
    """out[k, poly_idx[r]] = sum_j coeffs[r, j] t_k^j (Horner), and
    out[k, harm_idx[r]] = the harmonic's d, d' or d'' at t_k."""
    for k in range(t.shape[0]):
        tk = t[k]
        for r in range(poly_idx.shape[0]):
            v = 0.0
            for j in range(coeffs.shape[1] - 1, -1, -1):
                v = v * tk + coeffs[r, j]
            out[k, poly_idx[r]] = v
        for r in range(harm_idx.shape[0]):
            a, w, p, c = harm[r, 0], harm[r, 1], harm[r, 2], harm[r, 3]
            if order == 0:
                v = c + a * np.sin(w * tk + p)
            elif order == 1:
                v = a * w * np.cos(w * tk + p)
            else:
                v = -a * w * w * np.sin(w * tk + p)
            out[k, harm_idx[r]] = v


class FunctionSet:
    """All functions of a family, evaluated together: one compiled loop for the
    polynomials and harmonics, one spline call per table."""

    def __init__(self, funcs):
        funcs = list(funcs)
        self.n = len(funcs)
        polys = [(k, f) for k, f in enumerate(funcs) if isinstance(f, Poly)]
        harms = [(k, f) for k, f in enumerate(funcs) if isinstance(f, Harmonic)]
        tables = [(k, f) for k, f in enumerate(funcs) if isinstance(f, Table)]
        if len(polys) + len(harms) + len(tables) != self.n:
            raise TypeError("unknown function kind")
        self.constant = len(harms) == len(tables) == 0 and all(len(f.coeffs) == 1 for _, f in polys)

        self.poly_idx = np.array([k for k, _ in polys], dtype=np.intp)
        deg = max((len(f.coeffs) for _, f in polys), default=1)
        c0 = np.zeros((len(polys), deg))  # c0[r, j]: coefficient of t^j
        for r, (_, f) in enumerate(polys):
            c0[r, : len(f.coeffs)] = f.coeffs
        powers = np.arange(deg)
        c1 = np.zeros_like(c0)
        c1[:, :-1] = c0[:, 1:] * powers[1:]
        c2 = np.zeros_like(c0)
        c2[:, :-1] = c1[:, 1:] * powers[1:]
        self.poly_coeffs = (c0, c1, c2)

        self.harm_idx = np.array([k for k, _ in harms], dtype=np.intp)
        self.harm = np.array([[f.amplitude, f.omega, f.phase, f.offset] for _, f in harms], dtype=float).reshape(-1, 4)

        self.tables = []
        if tables:
            from scipy.interpolate import CubicSpline

            for k, f in tables:
                s = CubicSpline(np.asarray(f.t, float), np.asarray(f.value, float))
                self.tables.append((k, (s, s.derivative(1), s.derivative(2))))

    def __call__(self, t, order: int = 0) -> np.ndarray:
        """d^(order)(t) for every function, order 0, 1 or 2: (n,) at a scalar
        t, S + (n,) at an array of instants of shape S."""
        t = np.asarray(t, dtype=float)
        flat = np.ascontiguousarray(t.reshape(-1))
        out = np.empty((flat.shape[0], self.n))
        _evaluate(flat, order, self.poly_idx, self.poly_coeffs[order], self.harm_idx, self.harm, out)
        for k, splines in self.tables:
            out[:, k] = splines[order](flat)
        return out.reshape(t.shape + (self.n,))
