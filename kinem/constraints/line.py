"""Point on a line fixed in a body: translational joint (Eqs. 4.10-4.12,
Table 4.2) and revolute-translational joint (Eq. 4.16).

Both are the scalar cross product u x d = 0 of the line direction u (two
points of the line body a) and the vector d from the line's base point to a
point of the other body b: Eq. 4.12's first row with a = i, u = P_i - Q_i,
d = P_j - P_i, and Eq. 4.16 with a = j, u = Q_j - P_j, d = P_i - P_j.
"""
import numpy as np

from .base import BodyKey, Family, LocalKey, NumberKey, TypeDecl, ints, local_points, pattern, points, reals, row_info


class _PointOnLine(Family):
    """The row u x d = 0 for several constraints (a = the line's body, b the
    other), with the angle rows of translational joints when ``ai`` is given."""

    def setup(self, ca, pa, ua, cb, ob, length, ai=(), aj=(), phi0=()):
        self.scale_line = np.abs(ua) * length
        self.line_cols = np.stack([ca, ca + 1, ca + 2, cb, cb + 1, cb + 2], axis=1)
        ai, aj = np.asarray(ai, np.intp), np.asarray(aj, np.intp)
        self.args = (ca, pa, ua, cb, ob, ai, aj, np.asarray(phi0, float))

    def table(self, functions, outlines):
        """One core family "line" for both joints: the angle row's columns
        (ai, aj, phi0) are empty for the revolute-translational joint."""
        ca, pa, ua, cb, ob, ai, aj, phi0 = self.args
        return "line", {"ca": ints(ca), "pa": points(pa), "ua": points(ua), "cb": ints(cb), "ob": points(ob),
                        "ai": ints(ai), "aj": ints(aj), "phi0": reals(phi0)}


class Translational(_PointOnLine):
    """Eq. 4.12: [(P_i - Q_i) x (P_j - P_i), phi_i - phi_j - (phi_i^0 - phi_j^0)]."""
    lands, spans = {"si": "pa", "sj": "ob", "phi0": "phi0"}, {"ua": ("si", "qi")}

    def __init__(self, cons, ctx):
        ci = ctx.cols(c["i"] for c in cons)
        cj = ctx.cols(c["j"] for c in cons)
        si = local_points([c["si"] for c in cons])
        qi = local_points([c["qi"] for c in cons])
        phi0 = np.array([c["phi0"] for c in cons], dtype=float)
        self.setup(ci, si, si - qi, cj, local_points([c["sj"] for c in cons]), ctx.length, ci + 2, cj + 2, phi0)
        self.n_rows = 2 * len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("perpendicular", "angle"))
        self.scale = np.stack([self.scale_line, np.ones(len(cons))], axis=1).ravel()
        cols = np.concatenate([self.line_cols, np.stack([ci + 2, cj + 2], axis=1)], axis=1)
        self.rows, self.cols = pattern(cols, [0] * 6 + [1, 1], 2)


class RevoluteTranslational(_PointOnLine):
    """Eq. 4.16: (Q_j - P_i) x (Q_j - P_j) = 0: pin P_i on the line P_j Q_j of body j."""
    lands, spans = {"sj": "pa", "si": "ob"}, {"ua": ("qj", "sj")}

    def __init__(self, cons, ctx):
        ci = ctx.cols(c["i"] for c in cons)
        cj = ctx.cols(c["j"] for c in cons)
        sj = local_points([c["sj"] for c in cons])
        qj = local_points([c["qj"] for c in cons])
        self.setup(cj, sj, qj - sj, ci, local_points([c["si"] for c in cons]), ctx.length)
        self.n_rows = len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("perpendicular",))
        self.scale = self.scale_line
        self.rows, self.cols = pattern(self.line_cols, [0] * 6, 1)


def _check_translational(f, bodies):
    if "phi0" not in f:
        f["phi0"] = bodies[f["i"]].q[2] - bodies[f["j"]].q[2]
    return _line_length(f["si"], f["qi"], "qi", "si", "P_i, Q_i")


def _check_rt(f, bodies):
    return _line_length(f["sj"], f["qj"], "qj", "sj", "P_j, Q_j")


MIN_LINE = 1e-12  # the length of a translation line, absolute and relative to its points' distance from the origin


def _line_length(p, q, key, other, names):
    """A problem if the line through p and q is too short to give a direction (5e-324 apart
    would make its normal overflow)."""
    d = float(np.hypot(q[0] - p[0], q[1] - p[1]))
    if d == 0:
        return [(key, f"coincides with {other}: the translation line has zero length", f"two distinct points {names}")]
    if d < MIN_LINE * max(1.0, *map(abs, p + q)):
        return [(key, f"only {d:.3g} from {other}: the translation line is too short to give a direction",
                 f"two points {names} at least {MIN_LINE:g} (relative to their coordinates) apart")]
    return []


TYPES = [
    TypeDecl("translational", "4.10-4.12", (
        BodyKey("i"),
        LocalKey("si", of="i", doc="P_i, on the line, on body i"),
        LocalKey("qi", of="i", doc="Q_i, a second point of the line on body i"),
        BodyKey("j"),
        LocalKey("sj", of="j", doc="P_j, on the line, on body j"),
        NumberKey("phi0", required=False, angle=True, quantity="angle", doc="phi_i^0 - phi_j^0; default from the estimates"),
    ), Translational, check=_check_translational, rows=2,
        doc="Translational joint: bodies i and j slide along a common line without relative rotation."),
    TypeDecl("revolute-translational", "4.16", (
        BodyKey("i"),
        LocalKey("si", of="i", doc="the pin P_i"),
        BodyKey("j"),
        LocalKey("sj", of="j", doc="P_j, on the line, on body j"),
        LocalKey("qj", of="j", doc="Q_j, a second point of the line on body j"),
    ), RevoluteTranslational, check=_check_rt,
        doc="Revolute-translational composite joint: pin P_i of body i moves along line P_j Q_j of body j."),
]
