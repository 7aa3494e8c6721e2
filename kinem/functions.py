"""Driving functions d(t) (Sec. 4.2.8) and their exact first and second derivatives.

A case file gives a function as a bare number (constant), ``{poly = [c0, c1, ...]}``
(sum of c_k t^k), ``{harmonic = {amplitude, omega, phase, offset}}``
(offset + amplitude sin(omega t + phase)) or ``{table = {t = [...], value = [...]}}``
(not-a-knot cubic spline through the table). ``FunctionSet`` evaluates all the
functions of one constraint family at once.
"""
from dataclasses import dataclass

import numpy as np


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
    """All functions of a family, evaluated together: one matrix product for the
    polynomials, one vector expression for the harmonics, one spline call per table."""

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
        c0 = np.zeros((len(polys), deg))
        for r, (_, f) in enumerate(polys):
            c0[r, : len(f.coeffs)] = f.coeffs
        powers = np.arange(deg)
        c1 = np.zeros_like(c0)
        c1[:, :-1] = c0[:, 1:] * powers[1:]
        c2 = np.zeros_like(c0)
        c2[:, :-1] = c1[:, 1:] * powers[1:]
        self.poly_coeffs = (c0, c1, c2)
        self.powers = powers

        self.harm_idx = np.array([k for k, _ in harms], dtype=np.intp)
        self.harm = np.array([[f.amplitude, f.omega, f.phase, f.offset] for _, f in harms]).reshape(-1, 4)

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
        out = np.empty(t.shape + (self.n,))
        if self.poly_idx.size:
            out[..., self.poly_idx] = (t[..., None] ** self.powers) @ self.poly_coeffs[order].T
        if self.harm_idx.size:
            a, w, p, c = self.harm.T
            arg = w * t[..., None] + p
            if order == 0:
                out[..., self.harm_idx] = c + a * np.sin(arg)
            elif order == 1:
                out[..., self.harm_idx] = a * w * np.cos(arg)
            else:
                out[..., self.harm_idx] = -a * w * w * np.sin(arg)
        for k, splines in self.tables:
            out[..., k] = splines[order](t)
        return out
