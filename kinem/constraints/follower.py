"""A point of one body on an outline of another: the disk cam with a point
follower (Eqs. 4.26, 4.27) and the point-follower, a pin in a slot
(Eq. 4.30). Each adds the artificial coordinate theta of the contact point
on the outline (kinem/constraints/curve.py)."""
import numpy as np

from .base import (BodyKey, Call, Family, LocalKey, NumberKey, OutlineKey, TypeDecl, batch, call, ints, kernel,
                   local_points, pattern, points, reals, row_info)
from .curve import Curve, check_theta


@kernel
def _phi(q, E, cc, cb, sb, sign, a, out):
    """sigma (r_c + a - r_b - A_b s'_b), rows x and y."""
    for k in range(q.shape[0]):
        for c in range(cc.shape[0]):
            x, y = cc[c], cb[c]
            d = sign[c] * (complex(q[k, x], q[k, x + 1]) + a[k, c] - complex(q[k, y], q[k, y + 1])
                           - sb[c] * E[k, y + 2])
            out[k, 2 * c] = d.real
            out[k, 2 * c + 1] = d.imag


@kernel
def _jac(q, E, cb, sb, sign, a, g, out):
    """sigma [I, i a, g, -I, -B_b s'_b] in columns [r_c, phi_c, theta, r_b, phi_b]."""
    for k in range(q.shape[0]):
        for c in range(cb.shape[0]):
            b = sb[c] * E[k, cb[c] + 2]
            s, ak, gk = sign[c], a[k, c], g[k, c]
            o = out[k, 10 * c: 10 * c + 10]
            o[0], o[1], o[2], o[3], o[4] = s, -s * ak.imag, s * gk.real, -s, s * b.imag
            o[5], o[6], o[7], o[8], o[9] = s, s * ak.real, s * gk.imag, -s, -s * b.real


@kernel
def _gamma(q, qd, E, cb, sb, sign, a2, out):
    """-sigma (a'' + A_b s'_b w_b^2)."""
    for k in range(q.shape[0]):
        for c in range(cb.shape[0]):
            y = cb[c]
            g = -sign[c] * (a2[k, c] + sb[c] * E[k, y + 2] * qd[k, y + 2] ** 2)
            out[k, 2 * c] = g.real
            out[k, 2 * c + 1] = g.imag


class PointOnCurve(Family):
    """Phi = sigma (r_c + A_c p(theta) - r_b - A_b s'_b): two rows, x and y.
    cam-point: c = cam i, b = follower j, sigma = +1 (Eq. 4.26);
    point-follower: c = slotted body j, b = pin body i, sigma = -1 (Eq. 4.30)."""

    def __init__(self, cons, ctx):
        cam = [c.type == "cam-point" for c in cons]
        self.curve = Curve(cons, [c["cam"] if k else c["j"] for c, k in zip(cons, cam)], ctx)
        self.cb = ctx.cols(c["follower"] if k else c["i"] for c, k in zip(cons, cam))
        self.sb = local_points([c["sj"] if k else c["si"] for c, k in zip(cons, cam)])
        self.sign = np.where(cam, 1.0, -1.0)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("x", "y"))
        self.scale = np.full(self.n_rows, ctx.length)
        cc, ct, cb = self.curve.cc, self.curve.ct, self.cb
        cols = np.stack([cc, cc + 2, ct, cb, cb + 2, cc + 1, cc + 2, ct, cb + 1, cb + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 5 + [1] * 5, 2)

    def table(self, functions, outlines):
        return "point-on-curve", dict(self.curve.table(outlines), cb=ints(self.cb), sb=points(self.sb),
                                      sign=reals(self.sign))

    def phi(self, q, t):
        Q, lead = batch(q)
        a, _, _, _ = self.curve.at(Q)
        return call(_phi, self.n_rows, Q, self.curve.cc, self.cb, self.sb, self.sign, a).reshape(lead + (-1,))

    def jac(self, q, t):
        Q, lead = batch(q)
        a, g, _, _ = self.curve.at(Q)
        return call(_jac, len(self.rows), Q, self.cb, self.sb, self.sign, a, g).reshape(lead + (-1,))

    def gamma(self, q, qd, t):
        q, qd = np.broadcast_arrays(q, qd)
        (Q, lead), QD = batch(q), batch(qd)[0]
        _, a2, _, _ = self.curve.rates(QD, *self.curve.at(Q))
        return call(_gamma, self.n_rows, Q, self.cb, self.sb, self.sign, a2, qd=QD).reshape(lead + (-1,))

    def march(self, times):
        (at, rates), (a, g, _, _, _, a2, _, _) = self.curve.march()
        return ((at, Call(_phi, (self.curve.cc, self.cb, self.sb, self.sign, a))),
                (at, Call(_jac, (self.cb, self.sb, self.sign, a, g))),
                (at, rates, Call(_gamma, (self.cb, self.sb, self.sign, a2), rates=True)))


TYPES = [
    TypeDecl("cam-point", "4.26, 4.27", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="its contact point P_j"),
        NumberKey("theta", doc="estimate of the contact angle theta on the outline (rad)"),
    ), PointOnCurve, check=check_theta, rows=2,
        doc="Disk cam and point follower: point P_j of the follower lies on the cam's outline."),
    TypeDecl("point-follower", "4.30", (
        BodyKey("i", doc="body i, carrying the pin"),
        LocalKey("si", of="i", doc="the pin P"),
        BodyKey("j", doc="the slotted body j"),
        OutlineKey("outline", doc="the slot's centre line on body j"),
        NumberKey("theta", doc="estimate of the pin's angle theta on the outline (rad)"),
    ), PointOnCurve, check=check_theta, rows=2,
        doc="Point-follower: pin P of body i slides in a slot (an outline) of body j."),
]
