"""Revolute-revolute composite joint (Eq. 4.13, Tables 4.2 and 4.3) and the
distance driver, its extension with a length l(t) that follows a function
(a linear actuator between two points)."""
import numpy as np

from .base import Family, Key, TypeDecl, dot, entries, frames, local_points, pattern, rates, row_info
from ..functions import FunctionSet, constant


class Distance(Family):
    """Phi = d^T d - l(t)^2 with d = r_j^P - r_i^P (Eq. 4.13)."""

    def __init__(self, cons, ctx):
        self.ci = ctx.cols(c["i"] for c in cons)
        self.cj = ctx.cols(c["j"] for c in cons)
        self.si = local_points([c["si"] for c in cons])
        self.sj = local_points([c["sj"] for c in cons])
        self.length = FunctionSet([constant(c["length"]) if c.type == "revolute-revolute" else c["d"] for c in cons])
        self.time_dependent = not self.length.constant
        self.n_rows = len(cons)
        self.labels, self.owner, _ = row_info(cons, ("length",))
        self.driving = np.array([c.type == "distance-driver" for c in cons])
        self.scale = np.full(self.n_rows, ctx.length**2)
        ci, cj = self.ci, self.cj
        self.rows, self.cols = pattern(np.stack([ci, ci + 1, ci + 2, cj, cj + 1, cj + 2], axis=1), [0] * 6, 1)

    def parts(self, q):
        zi, ei = frames(q, self.ci)
        zj, ej = frames(q, self.cj)
        a, b = self.si * ei, self.sj * ej
        return zj + b - zi - a, a, b

    def phi(self, q, t):
        d, _, _ = self.parts(q)
        return (d * d.conjugate()).real - self.length(t) ** 2

    def jac(self, q, t):
        d, a, b = self.parts(q)
        return 2 * entries(-d.real, -d.imag, -dot(d, 1j * a), d.real, d.imag, dot(d, 1j * b))

    def nu(self, t):
        return 2 * self.length(t) * self.length(t, 1)

    def gamma(self, q, qd, t):
        d, a, b = self.parts(q)
        vi, wi = rates(qd, self.ci)
        vj, wj = rates(qd, self.cj)
        dd = vj + 1j * b * wj - vi - 1j * a * wi
        g = -2 * (dd * dd.conjugate()).real - 2 * dot(d, a * wi * wi - b * wj * wj)
        if self.time_dependent:
            l, l1, l2 = (self.length(t, k) for k in range(3))
            g = g + 2 * (l1 * l1 + l * l2)
        return g


TYPES = [
    TypeDecl("revolute-revolute", "4.13", (
        Key("i", "body"),
        Key("si", "local", of="i", doc="P_i: the link's joint on body i"),
        Key("j", "body"),
        Key("sj", "local", of="j", doc="P_j: the link's joint on body j"),
        Key("length", "positive", doc="l: the link length"),
    ), Distance, doc="Revolute-revolute composite joint: a massless link of length l between P_i and P_j."),
    TypeDecl("distance-driver", "4.13 (extended)", (
        Key("i", "body"),
        Key("si", "local", of="i"),
        Key("j", "body"),
        Key("sj", "local", of="j"),
        Key("d", "function", doc="the distance |P_j - P_i| as a function of time"),
    ), Distance, driving=True, doc="Linear actuator: the distance between P_i and P_j follows d(t)."),
]
