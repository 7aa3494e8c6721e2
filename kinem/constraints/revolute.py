"""Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47."""
import numpy as np

from .base import BodyKey, Family, LocalKey, TypeDecl, WordKey, ints, local_points, pattern, points, row_info


class Revolute(Family):
    """Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y."""
    lands = {"si": "si", "sj": "sj"}

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
        WordKey("sign", required=False, words=("positive", "negative"),
                doc="the branch the assembly must reach: the sign of phi_j - phi_i (wrapped to (-pi, pi]) "
                    "at the first instant; else the analysis fails (kinem/branches.py)"),
    ), Revolute, rows=2, doc="Revolute joint: point P of body i coincides with point P of body j."),
]
