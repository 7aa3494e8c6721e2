"""Point on a line fixed in a body: translational joint (Eqs. 4.10-4.12,
Table 4.2) and revolute-translational joint (Eq. 4.16).

Both are the scalar cross product u x d = 0 of the line direction u (two
points of the line body a) and the vector d from the line's base point to a
point of the other body b: Eq. 4.12's first row with a = i, u = P_i - Q_i,
d = P_j - P_i, and Eq. 4.16 with a = j, u = Q_j - P_j, d = P_i - P_j.
"""
import numpy as np

from .base import (Family, Key, TypeDecl, col, cross, dot, entries, frames, interleave, local_points, pattern, rates,
                   row_info)


class _PointOnLine:
    """Arrays and kernels of the row u x d = 0 for several constraints."""

    def __init__(self, ca, pa, ua, cb, ob, length):
        self.ca, self.pa, self.ua, self.cb, self.ob = ca, pa, ua, cb, ob
        self.scale = np.abs(ua) * length
        self.cols = np.stack([ca, ca + 1, ca + 2, cb, cb + 1, cb + 2], axis=1)

    def parts(self, q):
        za, ea = frames(q, self.ca)
        zb, eb = frames(q, self.cb)
        sa, sb = self.pa * ea, self.ob * eb
        return self.ua * ea, zb + sb - za - sa, sa, sb

    def phi(self, q):
        u, d, _, _ = self.parts(q)
        return cross(u, d)

    def jac(self, q):
        """The columns [x_a, y_a, phi_a, x_b, y_b, phi_b], each (..., n_cons)."""
        u, d, sa, sb = self.parts(q)
        return u.imag, -u.real, -dot(u, d + sa), -u.imag, u.real, dot(u, sb)

    def gamma(self, q, qd):
        u, d, sa, sb = self.parts(q)
        va, wa = rates(qd, self.ca)
        vb, wb = rates(qd, self.cb)
        dd = vb + 1j * sb * wb - va - 1j * sa * wa
        return wa * wa * cross(u, d) + 2 * wa * dot(u, dd) + cross(u, sb * wb * wb - sa * wa * wa)


class Translational(Family):
    """Eq. 4.12: [(P_i - Q_i) x (P_j - P_i), phi_i - phi_j - (phi_i^0 - phi_j^0)]."""

    def __init__(self, cons, ctx):
        ci = ctx.cols(c["i"] for c in cons)
        cj = ctx.cols(c["j"] for c in cons)
        si = local_points([c["si"] for c in cons])
        qi = local_points([c["qi"] for c in cons])
        self.line = _PointOnLine(ci, si, si - qi, cj, local_points([c["sj"] for c in cons]), ctx.length)
        self.ai, self.aj = ci + 2, cj + 2
        self.phi0 = np.array([c["phi0"] for c in cons], dtype=float)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("perpendicular", "angle"))
        self.scale = np.stack([self.line.scale, np.ones(len(cons))], axis=1).ravel()
        cols = np.concatenate([self.line.cols, np.stack([self.ai, self.aj], axis=1)], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 6 + [1, 1], 2)
        self.plus, self.minus, self.zero = np.ones(len(cons)), -np.ones(len(cons)), np.zeros(len(cons))

    def phi(self, q, t):
        return interleave(self.line.phi(q), col(q, self.ai) - col(q, self.aj) - self.phi0)

    def jac(self, q, t):
        return entries(*self.line.jac(q), self.plus, self.minus)

    def gamma(self, q, qd, t):
        g = self.line.gamma(q, qd)
        return interleave(g, self.zero)


class RevoluteTranslational(Family):
    """Eq. 4.16: (Q_j - P_i) x (Q_j - P_j) = 0: pin P_i on the line P_j Q_j of body j."""

    def __init__(self, cons, ctx):
        ci = ctx.cols(c["i"] for c in cons)
        cj = ctx.cols(c["j"] for c in cons)
        sj = local_points([c["sj"] for c in cons])
        qj = local_points([c["qj"] for c in cons])
        self.line = _PointOnLine(cj, sj, qj - sj, ci, local_points([c["si"] for c in cons]), ctx.length)
        self.n_rows = len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("perpendicular",))
        self.scale = self.line.scale
        self.rows, self.cols = pattern(self.line.cols, [0] * 6, 1)

    def phi(self, q, t):
        return self.line.phi(q)

    def jac(self, q, t):
        return entries(*self.line.jac(q))

    def gamma(self, q, qd, t):
        return self.line.gamma(q, qd)


def _check_translational(f, bodies):
    if "phi0" not in f:
        f["phi0"] = bodies[f["i"]].q[2] - bodies[f["j"]].q[2]
    if f["si"] == f["qi"]:
        return [("qi", "coincides with si: the translation line has zero length", "two distinct points P_i, Q_i")]
    return []


def _check_rt(f, bodies):
    if f["sj"] == f["qj"]:
        return [("qj", "coincides with sj: the translation line has zero length", "two distinct points P_j, Q_j")]
    return []


TYPES = [
    TypeDecl("translational", "4.10-4.12", (
        Key("i", "body"),
        Key("si", "local", of="i", doc="P_i, on the line, on body i"),
        Key("qi", "local", of="i", doc="Q_i, a second point of the line on body i"),
        Key("j", "body"),
        Key("sj", "local", of="j", doc="P_j, on the line, on body j"),
        Key("phi0", "number", required=False, doc="phi_i^0 - phi_j^0; default from the estimates"),
    ), Translational, check=_check_translational, rows=2,
        doc="Translational joint: bodies i and j slide along a common line without relative rotation."),
    TypeDecl("revolute-translational", "4.16", (
        Key("i", "body"),
        Key("si", "local", of="i", doc="the pin P_i"),
        Key("j", "body"),
        Key("sj", "local", of="j", doc="P_j, on the line, on body j"),
        Key("qj", "local", of="j", doc="Q_j, a second point of the line on body j"),
    ), RevoluteTranslational, check=_check_rt,
        doc="Revolute-translational composite joint: pin P_i of body i moves along line P_j Q_j of body j."),
]
