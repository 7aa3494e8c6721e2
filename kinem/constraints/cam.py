"""Disk cam with a roller follower (Eq. 4.28) and with a flat-faced follower
(Eq. 4.29), Sec. 4.2.5. Each adds the artificial coordinate theta of the
contact point P_i on the cam's outline (kinem/constraints/curve.py):
a = A_i p(theta) and g = A_i g'(theta), the tangent there."""
import numpy as np

from .base import (BodyKey, Call, DirectionKey, Family, LocalKey, NumberKey, OutlineKey, PositiveKey, TypeDecl,
                   batch, call, ints, kernel, local_points, pattern, points, reals, row_info)
from .curve import Curve, check_theta


@kernel
def _dot(a, b):
    return a.real * b.real + a.imag * b.imag


@kernel
def _roller_d(qk, ek, ci, cj, sj, a):
    """d = r_j + A_j s'_j - r_i - a, and A_j s'_j."""
    b = sj * ek[cj + 2]
    return complex(qk[cj], qk[cj + 1]) + b - complex(qk[ci], qk[ci + 1]) - a, b


@kernel
def _roller_phi(q, E, ci, cj, sj, rho2, a, g, out):
    """Eq. 4.28: [g . d, d . d - rho^2]."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            d, _ = _roller_d(q[k], E[k], ci[c], cj[c], sj[c], a[k, c])
            out[k, 2 * c] = _dot(g[k, c], d)
            out[k, 2 * c + 1] = _dot(d, d) - rho2[c]


@kernel
def _roller_jac(q, E, ci, cj, sj, a, g, h, out):
    """Columns [r_i, phi_i, theta, r_j, phi_j] of both rows."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            ak, gk = a[k, c], g[k, c]
            d, b = _roller_d(q[k], E[k], ci[c], cj[c], sj[c], ak)
            o = out[k, 14 * c: 14 * c + 14]
            o[0], o[1] = -gk.real, -gk.imag
            o[2], o[3] = _dot(1j * gk, d) - _dot(gk, 1j * ak), _dot(h[k, c], d) - _dot(gk, gk)
            o[4], o[5], o[6] = gk.real, gk.imag, _dot(gk, 1j * b)
            o[7], o[8], o[9], o[10] = -2 * d.real, -2 * d.imag, -2 * _dot(d, 1j * ak), -2 * _dot(d, gk)
            o[11], o[12], o[13] = 2 * d.real, 2 * d.imag, 2 * _dot(d, 1j * b)


@kernel
def _roller_gamma(q, qd, E, ci, cj, sj, a, g, a1, a2, g1, g2, out):
    """-(d/dt)^2 Phi without the acceleration terms: (g.d)'' = g''.d + 2 g'.d' + g.d''."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            x, y = ci[c], cj[c]
            d, b = _roller_d(q[k], E[k], x, y, sj[c], a[k, c])
            wj = qd[k, y + 2]
            d1 = complex(qd[k, y], qd[k, y + 1]) + 1j * wj * b - complex(qd[k, x], qd[k, x + 1]) - a1[k, c]
            d2 = -wj * wj * b - a2[k, c]
            out[k, 2 * c] = -(_dot(g2[k, c], d) + 2 * _dot(g1[k, c], d1) + _dot(g[k, c], d2))
            out[k, 2 * c + 1] = -2 * (_dot(d1, d1) + _dot(d, d2))


@kernel
def _flat_parts(qk, ek, ci, cj, sj, nj, a):
    """d = r_i + a - r_j - A_j s'_j, A_j s'_j and n = A_j n'_j."""
    e = ek[cj + 2]
    b = sj * e
    return complex(qk[ci], qk[ci + 1]) + a - complex(qk[cj], qk[cj + 1]) - b, b, nj * e


@kernel
def _flat_phi(q, E, ci, cj, sj, nj, a, g, out):
    """Eq. 4.29: [g . n, d . n]."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            d, _, n = _flat_parts(q[k], E[k], ci[c], cj[c], sj[c], nj[c], a[k, c])
            out[k, 2 * c] = _dot(g[k, c], n)
            out[k, 2 * c + 1] = _dot(d, n)


@kernel
def _flat_jac(q, E, ci, cj, sj, nj, a, g, h, out):
    """Row 1 in [phi_i, theta, phi_j], row 2 in [r_i, phi_i, theta, r_j, phi_j]."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            ak, gk = a[k, c], g[k, c]
            d, b, n = _flat_parts(q[k], E[k], ci[c], cj[c], sj[c], nj[c], ak)
            o = out[k, 10 * c: 10 * c + 10]
            o[0], o[1], o[2] = _dot(1j * gk, n), _dot(h[k, c], n), _dot(gk, 1j * n)
            o[3], o[4], o[5], o[6] = n.real, n.imag, _dot(1j * ak, n), _dot(gk, n)
            o[7], o[8], o[9] = -n.real, -n.imag, _dot(d, 1j * n) - _dot(1j * b, n)


@kernel
def _flat_gamma(q, qd, E, ci, cj, sj, nj, a, g, a1, a2, g1, g2, out):
    """-(g . n)'' and -(d . n)'' without the acceleration terms."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            x, y = ci[c], cj[c]
            d, b, n = _flat_parts(q[k], E[k], x, y, sj[c], nj[c], a[k, c])
            wj = qd[k, y + 2]
            n1, n2 = 1j * wj * n, -wj * wj * n
            d1 = complex(qd[k, x], qd[k, x + 1]) + a1[k, c] - complex(qd[k, y], qd[k, y + 1]) - 1j * wj * b
            d2 = a2[k, c] + wj * wj * b
            out[k, 2 * c] = -(_dot(g2[k, c], n) + 2 * _dot(g1[k, c], n1) + _dot(g[k, c], n2))
            out[k, 2 * c + 1] = -(_dot(d2, n) + 2 * _dot(d1, n1) + _dot(d, n2))


class _CamFollower(Family):
    """The cam i with its outline (``curve``), the follower j and its point Q_j."""

    def setup(self, cons, ctx):
        self.curve = Curve(cons, [c["cam"] for c in cons], ctx)
        self.cb = ctx.cols(c["follower"] for c in cons)
        self.sb = local_points([c["sj"] for c in cons])
        self.bodies = (self.curve.cc, self.cb, self.sb)

    def columns(self, outlines) -> dict:
        """The cam's and the follower's columns of the core table."""
        return dict(self.curve.table(outlines), cj=ints(self.cb), sj=points(self.sb))

    def evaluate(self, fn, width, q, *extra, parts=2):
        """fn(Q, i, j, s'_j, *extra, first ``parts`` of (a, g, h), out)."""
        Q, lead = batch(q)
        return call(fn, width, Q, *self.bodies, *extra, *self.curve.at(Q)[:parts]).reshape(lead + (-1,))

    def compiled(self, kernels, extras):
        """Family.march for kernels (phi, jac, gamma) taking ``extras`` (one
        tuple each) after the bodies, then the parts of the outline."""
        (at, rates), (a, g, h, _, a1, a2, g1, g2) = self.curve.march()
        (phi, jac, gamma), (ephi, ejac, egamma) = kernels, extras
        return ((at, Call(phi, (*self.bodies, *ephi, a, g))), (at, Call(jac, (*self.bodies, *ejac, a, g, h))),
                (at, rates, Call(gamma, (*self.bodies, *egamma, a, g, a1, a2, g1, g2), rates=True)))

    def rates(self, fn, q, qd, *extra):
        """fn(Q, QD, i, j, s'_j, *extra, a, g, a', a'', g', g'', out)."""
        q, qd = np.broadcast_arrays(q, qd)
        (Q, lead), QD = batch(q), batch(qd)[0]
        a, g, h, k = self.curve.at(Q)
        return call(fn, self.n_rows, Q, *self.bodies, *extra, a, g, *self.curve.rates(QD, a, g, h, k),
                    qd=QD).reshape(lead + (-1,))


class CamRoller(_CamFollower):
    """Phi = [g . d, d . d - rho^2] with d = r_j + A_j s'_j^Q - r_i - a, from
    the contact point P_i to the roller centre Q_j (Eq. 4.28): d is normal to
    the outline and as long as the roller's radius."""

    def __init__(self, cons, ctx):
        self.setup(cons, ctx)
        rho = np.array([c["radius"] for c in cons], dtype=float)
        self.rho2 = rho**2
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("normal", "distance"))
        # residuals of a displacement L: |g| L (|g| ~ the outline's s) and 2 rho L
        self.scale = np.stack([self.curve.outlines.size * ctx.length, 2 * rho * ctx.length], axis=1).ravel()
        ci, ct, cj = self.curve.cc, self.curve.ct, self.cb
        cols = np.stack([ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(np.concatenate([cols, cols], axis=1), [0] * 7 + [1] * 7, 2)

    def table(self, functions, outlines):
        return "cam-roller", dict(self.columns(outlines), rho2=reals(self.rho2))

    def phi(self, q, t):
        return self.evaluate(_roller_phi, self.n_rows, q, self.rho2)

    def jac(self, q, t):
        return self.evaluate(_roller_jac, len(self.rows), q, parts=3)

    def gamma(self, q, qd, t):
        return self.rates(_roller_gamma, q, qd)

    def march(self, times):
        return self.compiled((_roller_phi, _roller_jac, _roller_gamma), ((self.rho2,), (), ()))


class CamFlat(_CamFollower):
    """Phi = [g . n, d . n] with n = A_j n'_j the unit normal of the follower's
    face and d = r_i + a - r_j - A_j s'_j^Q, from a point Q_j of the face to
    the contact point P_i (Eq. 4.29): the face is tangent to the outline at P_i."""

    def __init__(self, cons, ctx):
        self.setup(cons, ctx)
        n = local_points([c["normal"] for c in cons])
        self.n = n / np.abs(n)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("tangent", "contact"))
        # residuals of a rotation by 1 rad (|g| ~ the outline's s) and of a displacement L
        self.scale = np.stack([self.curve.outlines.size, np.full(len(cons), ctx.length)], axis=1).ravel()
        ci, ct, cj = self.curve.cc, self.curve.ct, self.cb
        cols = np.stack([ci + 2, ct, cj + 2, ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 3 + [1] * 7, 2)

    def table(self, functions, outlines):
        return "cam-flat", dict(self.columns(outlines), n=points(self.n))

    def phi(self, q, t):
        return self.evaluate(_flat_phi, self.n_rows, q, self.n)

    def jac(self, q, t):
        return self.evaluate(_flat_jac, len(self.rows), q, self.n, parts=3)

    def gamma(self, q, qd, t):
        return self.rates(_flat_gamma, q, qd, self.n)

    def march(self, times):
        return self.compiled((_flat_phi, _flat_jac, _flat_gamma), ((self.n,),) * 3)


TYPES = [
    TypeDecl("cam-roller", "4.28", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="Q_j: the roller's centre"),
        PositiveKey("radius", doc="rho: the roller's radius"),
        NumberKey("theta", doc="estimate of the contact angle theta on the outline (rad)"),
    ), CamRoller, check=check_theta, rows=2,
        doc="Disk cam and roller follower: the roller (a circle about Q_j) touches the outline."),
    TypeDecl("cam-flat", "4.29", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="Q_j: a point of the flat face"),
        DirectionKey("normal", doc="n'_j: the face's normal (local; normalised)"),
        NumberKey("theta", doc="estimate of the contact angle theta on the outline (rad)"),
    ), CamFlat, check=check_theta, rows=2,
        doc="Disk cam and flat-faced follower: the follower's face is tangent to the outline."),
]
