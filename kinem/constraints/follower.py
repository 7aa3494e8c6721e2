"""A point of one body on an outline of another: the disk cam with a point
follower (Eqs. 4.26, 4.27) and the point-follower, a pin in a slot
(Eq. 4.30). Each adds the artificial coordinate theta of the contact point
on the outline (kinem/constraints/curve.py)."""
import numpy as np

from .base import (BodyKey, Family, LocalKey, NumberKey, OutlineKey, TypeDecl, ints, local_points, pattern, points,
                   reals, row_info)
from .curve import Curve, check_theta


class PointOnCurve(Family):
    """Phi = sigma (r_c + A_c p(theta) - r_b - A_b s'_b): two rows, x and y.
    cam-point: c = cam i, b = follower j, sigma = +1 (Eq. 4.26);
    point-follower: c = slotted body j, b = pin body i, sigma = -1 (Eq. 4.30)."""
    lands = {"sj": "sb", "si": "sb"}   # cam-point: sj, point-follower: si

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


TYPES = [
    TypeDecl("cam-point", "4.26, 4.27", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="its contact point P_j"),
        NumberKey("theta", angle=True, quantity=None, doc="estimate of the contact angle theta on the outline (rad)"),
    ), PointOnCurve, check=check_theta, rows=2,
        doc="Disk cam and point follower: point P_j of the follower lies on the cam's outline."),
    TypeDecl("point-follower", "4.30", (
        BodyKey("i", doc="body i, carrying the pin"),
        LocalKey("si", of="i", doc="the pin P"),
        BodyKey("j", doc="the slotted body j"),
        OutlineKey("outline", doc="the slot's centre line on body j"),
        NumberKey("theta", angle=True, quantity=None, doc="estimate of the pin's angle theta on the outline (rad)"),
    ), PointOnCurve, check=check_theta, rows=2,
        doc="Point-follower: pin P of body i slides in a slot (an outline) of body j."),
]
