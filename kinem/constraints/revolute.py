"""Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47."""
import numpy as np

from .base import BodyKey, Compiled, LocalKey, TypeDecl, ints, kernel, local_points, pattern, points, row_info


@kernel
def _phi(q, E, ci, cj, si, sj, out):
    """Eq. 4.7: r_i + A_i s'_i - r_j - A_j s'_j, rows x and y."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            a, b = ci[c], cj[c]
            d = (complex(q[k, a], q[k, a + 1]) + si[c] * E[k, a + 2]
                 - complex(q[k, b], q[k, b + 1]) - sj[c] * E[k, b + 2])
            out[k, 2 * c] = d.real
            out[k, 2 * c + 1] = d.imag


@kernel
def _jac(q, E, ci, cj, si, sj, out):
    """Eq. 4.46: [I, B_i s'_i, -I, -B_j s'_j]; B s' = i A s'."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            a = si[c] * E[k, ci[c] + 2]
            b = sj[c] * E[k, cj[c] + 2]
            o = out[k, 8 * c: 8 * c + 8]
            o[0], o[1], o[2], o[3] = 1.0, -a.imag, -1.0, b.imag
            o[4], o[5], o[6], o[7] = 1.0, a.real, -1.0, -b.real


@kernel
def _gamma(q, qd, E, ci, cj, si, sj, out):
    """Eq. 4.47: A_i s'_i w_i^2 - A_j s'_j w_j^2."""
    for k in range(q.shape[0]):
        for c in range(ci.shape[0]):
            wi, wj = qd[k, ci[c] + 2], qd[k, cj[c] + 2]
            g = (si[c] * E[k, ci[c] + 2] * wi ** 2
                 - sj[c] * E[k, cj[c] + 2] * wj ** 2)
            out[k, 2 * c] = g.real
            out[k, 2 * c + 1] = g.imag


class Revolute(Compiled):
    """Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y."""
    kernels = (_phi, _jac, _gamma)

    def __init__(self, cons, ctx):
        self.ci = ctx.cols(c["i"] for c in cons)
        self.cj = ctx.cols(c["j"] for c in cons)
        self.si = local_points([c["si"] for c in cons])
        self.sj = local_points([c["sj"] for c in cons])
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("x", "y"))
        self.scale = np.full(self.n_rows, ctx.length)
        ci, cj = self.ci, self.cj
        cols = np.stack([ci, ci + 2, cj, cj + 2, ci + 1, ci + 2, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0, 0, 0, 0, 1, 1, 1, 1], 2)
        self.args = (self.ci, self.cj, self.si, self.sj)

    def table(self, functions, outlines):
        return "revolute", {"ci": ints(self.ci), "cj": ints(self.cj), "si": points(self.si), "sj": points(self.sj)}


TYPES = [
    TypeDecl("revolute", "4.7", (
        BodyKey("i", doc="body i"),
        LocalKey("si", of="i", doc="s'_i^P: the joint centre on body i"),
        BodyKey("j", doc="body j"),
        LocalKey("sj", of="j", doc="s'_j^P: the joint centre on body j"),
    ), Revolute, rows=2, doc="Revolute joint: point P of body i coincides with point P of body j."),
]
