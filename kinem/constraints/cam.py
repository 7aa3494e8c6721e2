"""Disk cam with a roller follower (Eq. 4.28) and with a flat-faced follower
(Eq. 4.29), Sec. 4.2.5. Each adds the artificial coordinate theta of the
contact point P_i on the cam's outline (kinem/constraints/curve.py):
a = A_i p(theta) and g = A_i g'(theta), the tangent there."""
import numpy as np

from .base import (BodyKey, DirectionKey, Family, LocalKey, NumberKey, OutlineKey, PositiveKey, TypeDecl, WordKey,
                   ints, local_points, pattern, points, reals, row_info)
from .curve import Curve, check_theta


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


class CamRoller(_CamFollower):
    """Phi = [g . d, d . d - rho^2] with d = r_j + A_j s'_j^Q - r_i - a, from
    the contact point P_i to the roller centre Q_j (Eq. 4.28): d is normal to
    the outline and as long as the roller's radius."""

    def __init__(self, cons, ctx):
        self.setup(cons, ctx)
        rho = np.array([c["radius"] for c in cons], dtype=float)
        self.rho = rho
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("normal", "distance"))
        # residuals of a displacement L: |g| L (|g| ~ the outline's s) and 2 rho L
        self.scale = np.stack([self.curve.outlines.size * ctx.length, 2 * rho * ctx.length], axis=1).ravel()
        ci, ct, cj = self.curve.cc, self.curve.ct, self.cb
        cols = np.stack([ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(np.concatenate([cols, cols], axis=1), [0] * 7 + [1] * 7, 2)

    def table(self, functions, outlines):
        return "cam-roller", dict(self.columns(outlines), rho=reals(self.rho))   # the core squares it


class CamFlat(_CamFollower):
    """Phi = [g . n, d . n] with n = A_j n'_j the unit normal of the follower's
    face and d = r_i + a - r_j - A_j s'_j^Q, from a point Q_j of the face to
    the contact point P_i (Eq. 4.29): the face is tangent to the outline at P_i."""

    def __init__(self, cons, ctx):
        self.setup(cons, ctx)
        n = local_points([c["normal"] for c in cons])
        self.normal, self.n = n, n / np.abs(n)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("tangent", "contact"))
        # residuals of a rotation by 1 rad (|g| ~ the outline's s) and of a displacement L
        self.scale = np.stack([self.curve.outlines.size, np.full(len(cons), ctx.length)], axis=1).ravel()
        ci, ct, cj = self.curve.cc, self.curve.ct, self.cb
        cols = np.stack([ci + 2, ct, cj + 2, ci, ci + 1, ci + 2, ct, cj, cj + 1, cj + 2], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 3 + [1] * 7, 2)

    def table(self, functions, outlines):
        return "cam-flat", dict(self.columns(outlines), n=points(self.normal))   # the core normalises it


TYPES = [
    TypeDecl("cam-roller", "4.28", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="Q_j: the roller's centre"),
        PositiveKey("radius", doc="rho: the roller's radius"),
        NumberKey("theta", angle=True, quantity=None, doc="estimate of the contact angle theta on the outline (rad)"),
        WordKey("side", required=False, words=("outside", "inside"),
                doc="the branch the assembly must reach: the roller's centre outside or inside the outline "
                    "at the first instant; else the analysis fails (kinem/branches.py)"),
    ), CamRoller, check=check_theta, rows=2,
        doc="Disk cam and roller follower: the roller (a circle about Q_j) touches the outline."),
    TypeDecl("cam-flat", "4.29", (
        BodyKey("cam", doc="the cam i"),
        OutlineKey("outline", doc="the cam's outline"),
        BodyKey("follower", doc="the follower j"),
        LocalKey("sj", of="follower", doc="Q_j: a point of the flat face"),
        DirectionKey("normal", doc="n'_j: the face's normal (local; normalised)"),
        NumberKey("theta", angle=True, quantity=None, doc="estimate of the contact angle theta on the outline (rad)"),
    ), CamFlat, check=check_theta, rows=2,
        doc="Disk cam and flat-faced follower: the follower's face is tangent to the outline."),
]
