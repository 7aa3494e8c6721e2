"""Disk cam with a roller follower (Eq. 4.28) and with a flat-faced follower
(Eq. 4.29), Sec. 4.2.5. Each adds the artificial coordinate theta of the
contact point P_i on the cam's outline (kinem/constraints/curve.py):
a = A_i p(theta) and g = A_i g'(theta), the tangent there."""
import numpy as np

from .base import Family, Key, TypeDecl, col, dot, entries, frames, interleave, local_points, pattern, rates, row_info
from .curve import Curve, check_theta


class _Follower:
    """The follower j and its point Q_j (sj)."""

    def __init__(self, cons, ctx):
        self.cb = ctx.cols(c["follower"] for c in cons)
        self.sb = local_points([c["sj"] for c in cons])

    def at(self, q):
        z, e = frames(q, self.cb)
        return z, self.sb * e


class CamRoller(Family):
    """Phi = [g . d, d . d - rho^2] with d = r_j + A_j s'_j^Q - r_i - a, from
    the contact point P_i to the roller centre Q_j (Eq. 4.28): d is normal to
    the outline and as long as the roller's radius."""

    def __init__(self, cons, ctx):
        self.curve = Curve(cons, [c["cam"] for c in cons], ctx)
        self.foll = _Follower(cons, ctx)
        rho = np.array([c["radius"] for c in cons])
        self.rho2 = rho**2
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("normal", "distance"))
        # residuals of a displacement L: |g| L (|g| ~ the outline's s) and 2 rho L
        self.scale = interleave(self.curve.outlines.size * ctx.length, 2 * rho * ctx.length)
        ci, ct, cj = self.curve.cc, self.curve.ct, self.foll.cb
        cols = np.stack([ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(np.concatenate([cols, cols], axis=1), [0] * 7 + [1] * 7, 2)

    def parts(self, q):
        zi, (a, g, h, k) = self.curve.at(q)
        zj, b = self.foll.at(q)
        return zj + b - zi - a, a, g, h, k, b

    def phi(self, q, t):
        d, _, g, _, _, _ = self.parts(q)
        return interleave(dot(g, d), (d * d.conjugate()).real - self.rho2)

    def jac(self, q, t):
        d, a, g, h, _, b = self.parts(q)
        return entries(
            -g.real, -g.imag, dot(1j * g, d) - dot(g, 1j * a), dot(h, d) - dot(g, g), g.real, g.imag, dot(g, 1j * b),
            -2 * d.real, -2 * d.imag, -2 * dot(d, 1j * a), -2 * dot(d, g), 2 * d.real, 2 * d.imag, 2 * dot(d, 1j * b),
        )

    def gamma(self, q, qd, t):
        """-(d/dt)^2 Phi without the acceleration terms: (g.d)'' = g''.d + 2 g'.d' + g.d''."""
        d, a, g, h, k, b = self.parts(q)
        vi, a1, a2, g1, g2 = self.curve.rates(qd, a, g, h, k)
        vj, wj = rates(qd, self.foll.cb)
        d1 = vj + 1j * wj * b - vi - a1
        d2 = -wj * wj * b - a2
        return interleave(-(dot(g2, d) + 2 * dot(g1, d1) + dot(g, d2)), -2 * (dot(d1, d1) + dot(d, d2)))


class CamFlat(Family):
    """Phi = [g . n, d . n] with n = A_j n'_j the unit normal of the follower's
    face and d = r_i + a - r_j - A_j s'_j^Q, from a point Q_j of the face to
    the contact point P_i (Eq. 4.29): the face is tangent to the outline at P_i."""

    def __init__(self, cons, ctx):
        self.curve = Curve(cons, [c["cam"] for c in cons], ctx)
        self.foll = _Follower(cons, ctx)
        n = local_points([c["normal"] for c in cons])
        self.n = n / np.abs(n)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("tangent", "contact"))
        # residuals of a rotation by 1 rad (|g| ~ the outline's s) and of a displacement L
        self.scale = interleave(self.curve.outlines.size, np.full(len(cons), ctx.length))
        ci, ct, cj = self.curve.cc, self.curve.ct, self.foll.cb
        cols = np.stack([ci + 2, ct, cj + 2, ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 3 + [1] * 7, 2)

    def parts(self, q):
        zi, (a, g, h, k) = self.curve.at(q)
        zj, b = self.foll.at(q)
        n = self.n * np.exp(1j * col(q, self.foll.cb + 2))
        return zi + a - zj - b, a, g, h, k, b, n

    def phi(self, q, t):
        d, _, g, _, _, _, n = self.parts(q)
        return interleave(dot(g, n), dot(d, n))

    def jac(self, q, t):
        d, a, g, h, _, b, n = self.parts(q)
        return entries(
            dot(1j * g, n), dot(h, n), dot(g, 1j * n),
            n.real, n.imag, dot(1j * a, n), dot(g, n), -n.real, -n.imag, dot(d, 1j * n) - dot(1j * b, n),
        )

    def gamma(self, q, qd, t):
        d, a, g, h, k, b, n = self.parts(q)
        vi, a1, a2, g1, g2 = self.curve.rates(qd, a, g, h, k)
        vj, wj = rates(qd, self.foll.cb)
        n1, n2 = 1j * wj * n, -wj * wj * n
        d1 = vi + a1 - vj - 1j * wj * b
        d2 = a2 + wj * wj * b
        return interleave(-(dot(g2, n) + 2 * dot(g1, n1) + dot(g, n2)), -(dot(d2, n) + 2 * dot(d1, n1) + dot(d, n2)))


TYPES = [
    TypeDecl("cam-roller", "4.28", (
        Key("cam", "body", doc="the cam i"),
        Key("outline", "outline", doc="the cam's outline"),
        Key("follower", "body", doc="the follower j"),
        Key("sj", "local", of="follower", doc="Q_j: the roller's centre"),
        Key("radius", "positive", doc="rho: the roller's radius"),
        Key("theta", "number", doc="estimate of the contact angle theta on the outline (rad)"),
    ), CamRoller, check=check_theta, rows=2,
        doc="Disk cam and roller follower: the roller (a circle about Q_j) touches the outline."),
    TypeDecl("cam-flat", "4.29", (
        Key("cam", "body", doc="the cam i"),
        Key("outline", "outline", doc="the cam's outline"),
        Key("follower", "body", doc="the follower j"),
        Key("sj", "local", of="follower", doc="Q_j: a point of the flat face"),
        Key("normal", "direction", doc="n'_j: the face's normal (local; normalised)"),
        Key("theta", "number", doc="estimate of the contact angle theta on the outline (rad)"),
    ), CamFlat, check=check_theta, rows=2,
        doc="Disk cam and flat-faced follower: the follower's face is tangent to the outline."),
]
