"""Revolute-revolute composite joint (Eq. 4.13, Tables 4.2 and 4.3) and the
distance driver, its extension with a length l(t) that follows a function
(a linear actuator between two points)."""
import numpy as np

from .base import (BodyKey, Family, FunctionKey, LocalKey, PositiveKey, TypeDecl, ints, local_points, pattern,
                   points, row_info)
from ..functions import FunctionSet, constant


class Distance(Family):
    """Phi = d^T d - l(t)^2 with d = r_j^P - r_i^P (Eq. 4.13)."""
    lands = {"si": "si", "sj": "sj"}

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
