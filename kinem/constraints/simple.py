"""Simplified constraints (Eqs. 4.31-4.34) and driving constraints (Eqs. 4.36-4.40).

Every row has the form
    Phi = q_c(i) [+ (A_i s'_i^P)_c] [- phi_k] - f(t)
where q_c(i) is x_i, y_i or phi_i, the bracketed point term is present for
the point forms (Eqs. 4.34, 4.39, 4.40) and the relative term for a motor
between two moving bodies (``relative_to``). ``ground`` gives three rows with
constant f; ``absolute`` one constant row; ``driver`` one row with f = d(t).
The point term of row r is mx_r Re(s) + my_r Im(s), s = A_i s'_i^P.
"""
import numpy as np

from .base import (BodyKey, CoordKey, Family, FunctionKey, LocalKey, NumberKey, TypeDecl, Vector3Key, ints,
                   local_points, points, reals)
from ..functions import FunctionSet, constant

COORD = {"x": 0, "y": 1, "phi": 2}


class Simple(Family):

    def __init__(self, cons, ctx):
        rows = []  # (label, owner, driving, body, coord, point or None, relative body or None, f)
        for c in cons:
            if c.type == "ground":
                for k, name in enumerate(("x", "y", "phi")):
                    rows.append((f"{c.name}.{name}", c.name, False, c["body"], k, None, None, constant(c["value"][k])))
            else:
                f = c["d"] if c.type == "driver" else constant(c["value"])
                rows.append((c.name, c.name, c.type == "driver", c["body"], COORD[c["coord"]],
                             c.get("point"), c.get("relative_to"), f))
        n = self.n_rows = len(rows)
        self.labels = [r[0] for r in rows]
        self.owner = [r[1] for r in rows]
        self.driving = np.array([r[2] for r in rows], dtype=bool)
        body = ctx.cols(r[3] for r in rows)
        coord = np.array([r[4] for r in rows], dtype=np.intp)
        has_point = np.array([r[5] is not None for r in rows])
        relative = np.array([r[6] is not None for r in rows])
        self.a = body + coord
        self.angle = body + 2
        self.k = np.where(relative, ctx.cols(r[6] or r[3] for r in rows) + 2, 0)
        self.w = relative.astype(float)
        self.local = local_points([r[5] or (0.0, 0.0) for r in rows])
        self.mx = (has_point & (coord == 0)).astype(float)
        self.my = (has_point & (coord == 1)).astype(float)
        self.f = FunctionSet(r[7] for r in rows)
        self.time_dependent = not self.f.constant
        self.scale = np.where(coord == 2, 1.0, ctx.length)
        keep = np.flatnonzero(np.stack([np.ones(n, bool), has_point, relative], axis=1).ravel())
        self.rows = np.repeat(np.arange(n), 3)[keep]
        self.cols = np.stack([self.a, self.angle, self.k], axis=1).ravel()[keep]
        self.point, self.relative = has_point, relative
        self.zero = np.zeros((1, n))

    def table(self, functions, outlines):
        return "simple", {"a": ints(self.a), "angle": ints(self.angle), "k": ints(self.k), "local": points(self.local),
                          "mx": reals(self.mx), "my": reals(self.my), "point": ints(self.point),
                          "relative": ints(self.relative), "f": functions.indices(self.f.funcs)}


def _estimate_point(body, point):
    x, y, phi = body.q
    c, s = np.cos(phi), np.sin(phi)
    return x + c * point[0] - s * point[1], y + s * point[0] + c * point[1]


def _check_ground(f, bodies):
    f.setdefault("value", bodies[f["body"]].q)
    return []


def _check_coord(f, bodies, driver=False):
    out = []
    if "point" in f and f["coord"] == "phi":
        out.append(("point", "a point goes with coord x or y only", "coord = \"x\" or \"y\" with a point"))
    if driver and "relative_to" in f and (f["coord"] != "phi" or "point" in f):
        out.append(("relative_to", "a relative driver acts on angles only", "coord = \"phi\" and no point"))
    if not driver and "value" not in f and not out:
        body = bodies[f["body"]]
        k = COORD[f["coord"]]
        f["value"] = _estimate_point(body, f["point"])[k] if "point" in f else body.q[k]
    return out


TYPES = [
    TypeDecl("ground", "4.31-4.33", (
        BodyKey("body"),
        Vector3Key("value", required=False, doc="[x, y, phi] held; default: the body's estimate q"),
    ), Simple, check=_check_ground, rows=3, doc="Holds x, y and phi of a body (Eqs. 4.31-4.33 at once)."),
    TypeDecl("absolute", "4.31-4.34", (
        BodyKey("body"),
        CoordKey("coord", doc="x, y or phi"),
        LocalKey("point", required=False, of="body", doc="for x/y: a point of the body (Eq. 4.34)"),
        NumberKey("value", required=False, phi_angle=True, quantity="coordinate", doc="the constant; default from the estimates"),
    ), Simple, check=_check_coord, doc="Holds one coordinate of a body, or of a point of it, constant."),
    TypeDecl("driver", "4.36-4.40", (
        BodyKey("body"),
        CoordKey("coord", doc="x, y or phi"),
        LocalKey("point", required=False, of="body", doc="for x/y: a point of the body (Eqs. 4.39-4.40)"),
        BodyKey("relative_to", required=False, doc="body k: drives phi_i - phi_k (a motor between moving bodies)"),
        FunctionKey("d", phi_angle=True, doc="d(t)"),
    ), Simple, check=lambda f, b: _check_coord(f, b, driver=True), driving=True,
        doc="Driving constraint: a coordinate, a point coordinate or a relative angle follows d(t)."),
]
