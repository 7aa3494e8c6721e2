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

from ..outline import OutlineSet


class Curve:
    def __init__(self, cons, bodies, ctx):
        """bodies: the name of the outline body of each constraint."""
        self.cc = ctx.cols(bodies)
        self.ct = ctx.add_coordinates([f"{c.name}.theta" for c in cons], [c["theta"] for c in cons])
        self.outlines = OutlineSet(c["outline"] for c in cons)

    def at(self, Q):
        """(a, g, h, k) at the configurations Q (K, n), each (K, constraints)."""
        e = np.exp(1j * Q[:, self.cc + 2])
        return tuple(np.ascontiguousarray(e * p) for p in self.outlines.curve(Q[:, self.ct]))

    def rates(self, QD, a, g, h, k):
        """a', a'', g', g'' (without acceleration terms)."""
        w, th = QD[:, self.cc + 2], QD[:, self.ct]
        return tuple(np.ascontiguousarray(x) for x in (
            1j * w * a + g * th, -w * w * a + 2j * w * th * g + th * th * h,
            1j * w * g + h * th, -w * w * g + 2j * w * th * h + th * th * k))


def check_theta(f, bodies):
    """The estimate of theta must lie on an open outline's table."""
    o = f["outline"]
    lo, hi = o.span
    if not o.periodic and not lo <= f["theta"] <= hi:
        return [("theta", f"got {f['theta']:g} rad, outside the outline's table",
                 f"an angle from {lo:.9g} to {hi:.9g} rad")]
    return []
