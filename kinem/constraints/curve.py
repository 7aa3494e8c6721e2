"""A point that moves on an outline of a body (Secs. 4.2.4-4.2.6): the
outline body c, its outlines and the artificial coordinates theta that
locate the point on them (one per constraint, labelled "<name>.theta").

With a = A_c p(theta), g = A_c p'(theta) (the tangent g_c of Eq. 4.24 in
global components), h = A_c p'' and k = A_c p''':
    da/dphi_c = i a,   da/dtheta = g,   dg/dphi_c = i g,   dg/dtheta = h,
and along a motion, without the terms in the accelerations (those go into
Phi_q qdd),
    a'  = i w a + g th',   a''  = -w^2 a + 2 i w th' g + th'^2 h,
    g'  = i w g + h th',   g''  = -w^2 g + 2 i w th' h + th'^2 k.

These are numpy expressions on a batch (K, n) (kinem.outline evaluates the
splines); the families' kernels take their results as (K, constraints) arrays.
"""
import numpy as np

from ..jit import kernel
from ..outline import OutlineSet, curve_at
from .base import Call, ints, rotations

NO_ROTATIONS = np.ones((1, 1), complex)  # curve_rates reads none


class Curve:
    def __init__(self, cons, bodies, ctx):
        """bodies: the name of the outline body of each constraint."""
        self.cc = ctx.cols(bodies)
        self.ct = ctx.add_coordinates([f"{c.name}.theta" for c in cons], [c["theta"] for c in cons])
        self.outline_list = [c["outline"] for c in cons]
        self.outlines = OutlineSet(self.outline_list)

    def table(self, outlines) -> dict:
        """The columns every curve family's core table has: cc, ct and the
        outlines' numbers (kinem.outline.OutlineTable)."""
        return {"cc": ints(self.cc), "ct": ints(self.ct), "outline": outlines.indices(self.outline_list)}

    def at(self, Q):
        """(a, g, h, k) at the configurations Q (K, n), each (K, constraints)."""
        a, g, h, k = (np.empty((Q.shape[0], len(self.cc)), complex) for _ in range(4))
        curve_at(Q, rotations(Q), self.cc, self.ct, *self.outlines.args, a, g, h, k)
        return a, g, h, k

    def rates(self, QD, a, g, h, k):
        """a', a'', g', g'' (without acceleration terms)."""
        out = tuple(np.empty_like(a) for _ in range(4))
        curve_rates(QD, QD, NO_ROTATIONS, self.cc, self.ct, a, g, h, k, *out)
        return out

    def march(self):
        """For the compiled march (one instant): the calls that fill (a, g, h,
        k) and then the rates (a', a'', g', g''), and those eight arrays."""
        parts = tuple(np.zeros((1, len(self.cc)), complex) for _ in range(8))
        return (Call(curve_at, (self.cc, self.ct, *self.outlines.args, *parts[:4]), out=False),
                Call(curve_rates, (self.cc, self.ct, *parts), rates=True, out=False)), parts


@kernel
def curve_rates(q, qd, E, cc, ct, a, g, h, k3, a1, a2, g1, g2):
    """a', a'', g', g'' from a, g, h, k3 and the rates w_c, theta' of qd
    (the module docstring's formulas; q and E are not used)."""
    for k in range(a.shape[0]):
        for c in range(cc.shape[0]):
            w, th = qd[k, cc[c] + 2], qd[k, ct[c]]
            ak, gk, hk = a[k, c], g[k, c], h[k, c]
            a1[k, c] = 1j * w * ak + gk * th
            a2[k, c] = -w * w * ak + 2j * w * th * gk + th * th * hk
            g1[k, c] = 1j * w * gk + hk * th
            g2[k, c] = -w * w * gk + 2j * w * th * hk + th * th * k3[k, c]


def check_theta(f, bodies):
    """The estimate of theta must lie on an open outline's table."""
    o = f["outline"]
    lo, hi = o.span
    if not o.periodic and not lo <= f["theta"] <= hi:
        return [("theta", f"got {f['theta']:g} rad, outside the outline's table",
                 f"an angle from {lo:.9g} to {hi:.9g} rad")]
    return []
