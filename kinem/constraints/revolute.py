"""Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47."""
import numpy as np

from .base import Family, Key, TypeDecl, col, entries, frames, interleave, local_points, pattern, row_info


class Revolute(Family):
    """Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y."""

    def __init__(self, cons, ctx):
        n = len(cons)
        self.ci = ctx.cols(c["i"] for c in cons)
        self.cj = ctx.cols(c["j"] for c in cons)
        self.si = local_points([c["si"] for c in cons])
        self.sj = local_points([c["sj"] for c in cons])
        self.n_rows = 2 * n
        self.labels, self.owner, self.driving = row_info(cons, ("x", "y"))
        self.scale = np.full(self.n_rows, ctx.length)
        ci, cj = self.ci, self.cj
        cols = np.stack([ci, ci + 2, cj, cj + 2, ci + 1, ci + 2, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0, 0, 0, 0, 1, 1, 1, 1], 2)
        self.ones = np.ones(n)

    def phi(self, q, t):
        zi, ei = frames(q, self.ci)
        zj, ej = frames(q, self.cj)
        d = zi + self.si * ei - zj - self.sj * ej
        return interleave(d.real, d.imag)

    def jac(self, q, t):
        a = self.si * np.exp(1j * col(q, self.ci + 2))
        b = self.sj * np.exp(1j * col(q, self.cj + 2))
        one = self.ones
        return entries(one, -a.imag, -one, b.imag, one, a.real, -one, -b.real)

    def gamma(self, q, qd, t):
        a = self.si * np.exp(1j * col(q, self.ci + 2))
        b = self.sj * np.exp(1j * col(q, self.cj + 2))
        g = a * col(qd, self.ci + 2) ** 2 - b * col(qd, self.cj + 2) ** 2
        return interleave(g.real, g.imag)


TYPES = [
    TypeDecl("revolute", "4.7", (
        Key("i", "body", doc="body i"),
        Key("si", "local", of="i", doc="s'_i^P: the joint centre on body i"),
        Key("j", "body", doc="body j"),
        Key("sj", "local", of="j", doc="s'_j^P: the joint centre on body j"),
    ), Revolute, rows=2, doc="Revolute joint: point P of body i coincides with point P of body j."),
]
