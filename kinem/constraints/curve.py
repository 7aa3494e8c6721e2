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

The core evaluates them (kinem/core/src/families/curve.rs, outline.rs);
here are the outline body's and theta's columns and the outlines.
"""
from ..outline import OutlineSet
from .base import ints


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


def check_theta(f, bodies):
    """The estimate of theta must lie on an open outline's table."""
    o = f["outline"]
    lo, hi = o.span
    if not o.periodic and not lo <= f["theta"] <= hi:
        return [("theta", f"got {f['theta']:g} rad, outside the outline's table",
                 f"an angle from {lo:.9g} to {hi:.9g} rad")]
    return []
