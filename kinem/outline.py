"""Outlines of bodies (Sec. 4.2.4): a curve fixed in a body, in polar
coordinates s(theta) about a centre point Q of the body (Eq. 4.25),

    p(theta) = [xi, eta] = Q + s(theta) [cos theta, sin theta].

s is a cubic spline through a table (scipy ``CubicSpline``: periodic, or an
open table with not-a-knot or natural ends) or a constant (a circle of
radius R about Q, exact). Both are piecewise cubics, laid out once for
the compiled core (``OutlineTable``), which evaluates them for the analysis
and, through ``OutlineSet``, for everything else: a periodic outline wraps
an accumulated theta into its period first; an open outline is extended
beyond its table by its end cubics (there is no stop at the ends).

Planar vectors are complex xi + i eta, as in the constraint families.
"""
import cmath
from dataclasses import dataclass

import numpy as np

from . import native

from .functions import identity

TWO_PI = 2.0 * np.pi
OPEN_BC = ("not-a-knot", "natural")


@dataclass(frozen=True)
class Outline:
    """kind "spline" (table theta [rad], s) or "circle" (radius); centre Q local."""
    kind: str
    theta: tuple = ()
    s: tuple = ()
    periodic: bool = False
    bc: str = "not-a-knot"
    radius: float = 0.0
    center: tuple = (0.0, 0.0)

    @classmethod
    def circle(cls, radius, center=(0.0, 0.0)):
        return cls("circle", radius=float(radius), periodic=True, center=tuple(center))

    @classmethod
    def spline(cls, theta, s, periodic=False, bc="not-a-knot", center=(0.0, 0.0)):
        return cls("spline", tuple(map(float, theta)), tuple(map(float, s)), bool(periodic),
                   "periodic" if periodic else bc, center=tuple(center))

    @property
    def span(self) -> tuple:
        """(first, last) theta of the table; a full turn for a circle."""
        return (0.0, TWO_PI) if self.kind == "circle" else (self.theta[0], self.theta[-1])

    def pieces(self):
        """Breakpoints x (n+1,) and coefficients c (4, n) of s: on piece k,
        s = sum_m c[m, k] (theta - x[k])^(3-m) (scipy's PPoly layout)."""
        if self.kind == "circle":
            return np.array([0.0, TWO_PI]), np.array([[0.0], [0.0], [0.0], [self.radius]])
        from scipy.interpolate import CubicSpline

        sp = CubicSpline(np.array(self.theta), np.array(self.s), bc_type=self.bc)
        return sp.x, sp.c

    def radius_at(self, theta):
        """s, ds/dtheta, d2s/dtheta2 at the given angles (Example 4.3)."""
        return OutlineSet([self]).radius(np.asarray(theta, float))[:3]

    def point_at(self, theta):
        """xi + i eta (Eq. 4.25), g' = mu + i nu (Eqs. 4.22, 4.24) and dg'/dtheta (Eq. 4.23)."""
        return OutlineSet([self]).curve(np.asarray(theta, float))[:3]


class OutlineSet:
    """Several outlines, evaluated together: outline k at theta[k]. With a
    single outline, theta may be any array of angles."""

    def __init__(self, outlines):
        outlines = list(outlines)
        table = OutlineTable()
        self._which = table.indices(outlines)   # equal outlines share one number
        self._table = table.arrays()
        self.center = np.array([complex(*o.center) for o in outlines])
        self.size = np.array([np.max(np.abs(o.pieces()[1][3])) for o in outlines])  # the largest tabulated s

    def radius(self, theta):
        """s and its first three derivatives with respect to theta: outline
        k at theta[..., k] (a single outline: at any array of angles), by the
        compiled core (kinem/core/src/outline.rs, the analysis's own)."""
        theta = np.asarray(theta, float)
        shape = np.broadcast_shapes(theta.shape, self._which.shape)
        flat = np.ascontiguousarray(np.broadcast_to(theta, shape)).reshape(-1)
        which = np.ascontiguousarray(np.broadcast_to(self._which, shape), np.int64).reshape(-1)
        return tuple(native.outline_radius(self._table, which, flat).reshape((4,) + shape))

    def curve(self, theta):
        """p and dp/dtheta, d2p/dtheta2, d3p/dtheta3 in local components
        (Eqs. 4.21-4.25 with p = Q + s e^{i theta}; g' = dp/dtheta)."""
        return _curve(self.center, np.exp(1j * np.asarray(theta, float)), *self.radius(theta))

    def curve_at(self, theta: float) -> tuple:
        """``curve`` of the first outline at one angle, as Python complex
        numbers, without numpy's broadcasting: the hot path of a user
        constraint called at every Newton iteration (adapters/exudyn_sim.py)."""
        s = native.outline_radius(self._table, self._which[:1], np.array([float(theta)])).reshape(4).tolist()
        return _curve(complex(self.center[0]), cmath.exp(1j * theta), *s)


def _curve(center, e, s, s1, s2, s3):
    """p and its first three derivatives in theta from s and its own, e = e^{i theta}."""
    return (center + s * e, (s1 + 1j * s) * e, (s2 - s + 2j * s1) * e, (s3 - 3 * s1 + 1j * (3 * s2 - s)) * e)


class OutlineTable:
    """Every outline of a model, numbered as the compiled core (kinem._core)
    reads them: ``index`` gives an outline's number (equal outlines share
    one), ``arrays`` the table of kinem/core/src/outline.rs: outline o's
    pieces are first[o] .. last[o], each starting at starts (theta from
    t0[o]) with 4 coefficients, highest power first; span the table's
    length in theta (a periodic outline's period), center Q. A circle is
    one constant piece over [0, 2 pi), periodic (Outline.pieces)."""

    def __init__(self, share: bool = True):
        self.outlines = []
        self._number = {}
        self.share = share   # False: every outline its own number (kinem.sensitivity's tables line up)

    def index(self, o: Outline) -> int:
        key = identity(o) if self.share else len(self.outlines)
        k = self._number.get(key)
        if k is None:
            k = self._number[key] = len(self.outlines)
            self.outlines.append(o)
        return k

    def indices(self, outlines) -> np.ndarray:
        return np.array([self.index(o) for o in outlines], dtype=np.int64)

    def arrays(self) -> dict:
        first, last, t0, span, starts, coef = [], [], [], [], [], []
        count = 0
        for o in self.outlines:
            x, c = o.pieces()
            local = x - x[0]
            first.append(count)
            count += len(x) - 1
            last.append(count - 1)
            t0.append(x[0])
            span.append(local[-1])
            starts.append(local[:-1])
            coef.append(np.asarray(c, float).T.ravel())
        return {"first": np.array(first, np.int64), "last": np.array(last, np.int64),
                "t0": np.array(t0, float), "span": np.array(span, float),
                "periodic": np.array([o.periodic for o in self.outlines], np.int64),
                "center": np.array([complex(*o.center) for o in self.outlines], complex),
                "starts": np.concatenate(starts) if starts else np.zeros(0),
                "coef": np.concatenate(coef) if coef else np.zeros(0)}
