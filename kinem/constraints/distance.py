"""Revolute-revolute composite joint (Eq. 4.13, Tables 4.2 and 4.3) and the
distance driver, its extension with a length l(t) that follows a function
(a linear actuator between two points)."""
import numpy as np

from .base import (BodyKey, Call, Family, FunctionKey, LocalKey, PositiveKey, TypeDecl, call, ints, kernel,
                   local_points, pattern, per_instant, points, row_info)
from ..functions import FunctionSet, constant


@kernel
def _parts(qk, ek, a, b, si, sj):
    """d = r_j + A_j s'_j - r_i - A_i s'_i, A_i s'_i, A_j s'_j."""
    sa, sb = si * ek[a + 2], sj * ek[b + 2]
    return complex(qk[b], qk[b + 1]) + sb - complex(qk[a], qk[a + 1]) - sa, sa, sb


@kernel
def _phi(q, E, ci, cj, si, sj, length, out):
    """Eq. 4.13: d . d - l(t)^2."""
    for k in range(q.shape[0]):
        lk = length[0] if length.shape[0] == 1 else length[k]
        for c in range(ci.shape[0]):
            d, _, _ = _parts(q[k], E[k], ci[c], cj[c], si[c], sj[c])
            out[k, c] = d.real * d.real + d.imag * d.imag - lk[c] ** 2


@kernel
def _jac(q, E, ci, cj, si, sj, out):
    """2 [-d^T, -d^T B_i s'_i, d^T, d^T B_j s'_j] (Table 4.2)."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            d, a, b = _parts(q[k], E[k], ci[c], cj[c], si[c], sj[c])
            o = out[k, 6 * c: 6 * c + 6]
            o[0], o[1], o[2] = -2 * d.real, -2 * d.imag, -2 * (d.imag * a.real - d.real * a.imag)
            o[3], o[4], o[5] = 2 * d.real, 2 * d.imag, 2 * (d.imag * b.real - d.real * b.imag)


@kernel
def _gamma(q, qd, E, ci, cj, si, sj, l2, out):
    """-2 d'.d' - 2 d.(A_i s'_i w_i^2 - A_j s'_j w_j^2) (Table 4.3), plus
    (l^2)'' = 2 (l'^2 + l l'') for a distance driver (``l2``)."""
    for k in range(q.shape[0]):
        lk = l2[0] if l2.shape[0] == 1 else l2[k]
        for c in range(ci.shape[0]):
            a_, b_ = ci[c], cj[c]
            d, a, b = _parts(q[k], E[k], a_, b_, si[c], sj[c])
            wi, wj = qd[k, a_ + 2], qd[k, b_ + 2]
            dd = complex(qd[k, b_], qd[k, b_ + 1]) + 1j * b * wj - complex(qd[k, a_], qd[k, a_ + 1]) - 1j * a * wi
            e = a * wi * wi - b * wj * wj
            out[k, c] = (-2 * (dd.real * dd.real + dd.imag * dd.imag) - 2 * (d.real * e.real + d.imag * e.imag)
                         + lk[c])


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
        self.args = (self.ci, self.cj, self.si, self.sj)

    def table(self, functions, outlines):
        return "distance", {"ci": ints(self.ci), "cj": ints(self.cj), "si": points(self.si), "sj": points(self.sj),
                            "f": functions.indices(self.length.funcs)}

    def phi(self, q, t):
        return call(_phi, self.n_rows, q, *self.args, per_instant(self.length(t)))

    def jac(self, q, t):
        return call(_jac, len(self.rows), q, *self.args)

    def nu(self, t):
        return 2 * self.length(t) * self.length(t, 1)

    def gamma(self, q, qd, t):
        return call(_gamma, self.n_rows, q, *self.args, per_instant(self.second(t)), qd=qd)

    def second(self, t):
        """(l^2)'' = 2 (l'^2 + l l''), the driver's term of gamma, at t (a scalar or (K,))."""
        if not self.time_dependent:
            return np.zeros(np.shape(t) + (self.n_rows,))
        l, l1, l2 = (self.length(t, k) for k in range(3))
        return 2 * (l1 * l1 + l * l2)

    def march(self, times):
        return ((Call(_phi, self.args, self.length(times)),), (Call(_jac, self.args),),
                (Call(_gamma, self.args, self.second(times), rates=True),))


TYPES = [
    TypeDecl("revolute-revolute", "4.13", (
        BodyKey("i"),
        LocalKey("si", of="i", doc="P_i: the link's joint on body i"),
        BodyKey("j"),
        LocalKey("sj", of="j", doc="P_j: the link's joint on body j"),
        PositiveKey("length", doc="l: the link length"),
    ), Distance, doc="Revolute-revolute composite joint: a massless link of length l between P_i and P_j."),
    TypeDecl("distance-driver", "4.13 (extended)", (
        BodyKey("i"),
        LocalKey("si", of="i"),
        BodyKey("j"),
        LocalKey("sj", of="j"),
        FunctionKey("d", doc="the distance |P_j - P_i| as a function of time"),
    ), Distance, driving=True, doc="Linear actuator: the distance between P_i and P_j follows d(t)."),
]
