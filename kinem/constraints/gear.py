"""Spur gears (Eqs. 4.17, 4.18) and rack and pinion (Eqs. 4.19, 4.20 and
their general form, Problem 4.15), Sec. 4.2.3.

Both are the integrated no-slip condition of the pitch circles (lines) at
the contact point. They do not keep the gears in mesh: revolute and
translational joints to a third body must do that (as in the chapter).
Angles are accumulated. The integration constant is one number, ``phi0``,
defaulting to the value that makes the initial estimates satisfy the
equation: the estimates are the reference configuration (phi_i^0, ...).
"""
import numpy as np

from .base import (BodyKey, BoolKey, DirectionKey, Family, LocalKey, NumberKey, PositiveKey, TypeDecl, ints,
                   local_points, pattern, points, reals, row_info)


class Gear(Family):
    """Phi = rho_i (phi_i - phi_k) + sigma rho_j (phi_j - phi_k - phi0) (Eq. 4.18;
    Eq. 4.17 without a carrier k, phi_k = 0). sigma = +1 for external gears
    (they turn in opposite senses relative to k), -1 when one of them is an
    internal (ring) gear (same sense). phi0 is phi_j - phi_k when
    phi_i - phi_k = 0."""

    def __init__(self, cons, ctx):
        n = len(cons)
        self.ai = ctx.cols(c["i"] for c in cons) + 2
        self.aj = ctx.cols(c["j"] for c in cons) + 2
        carrier = np.array(["carrier" in c.fields for c in cons])
        self.ak = np.where(carrier, ctx.cols(c.get("carrier", c["i"]) for c in cons) + 2, 0)
        self.w = carrier.astype(float)
        self.ri = np.array([c["ri"] for c in cons], dtype=float)
        self.rj = np.array([c["rj"] for c in cons], dtype=float) * np.array(
            [-1.0 if c.get("internal") else 1.0 for c in cons])
        self.phi0 = np.array([c["phi0"] for c in cons], dtype=float)
        self.n_rows = n
        self.labels, self.owner, self.driving = row_info(cons, ("roll",))
        self.scale = self.ri + np.abs(self.rj)  # the residual of a 1 rad slip of either gear, roughly
        keep = np.flatnonzero(np.stack([np.ones(n, bool), np.ones(n, bool), carrier], axis=1).ravel())
        self.rows = np.repeat(np.arange(n), 3)[keep]
        self.cols = np.stack([self.ai, self.aj, self.ak], axis=1).ravel()[keep]
        self.values = np.stack([self.ri, self.rj, -(self.ri + self.rj)], axis=1).ravel()[keep]
        self.args = (self.ai, self.aj, self.ak, self.w, self.ri, self.rj, self.phi0)

    def table(self, functions, outlines):
        return "gear", {"ai": ints(self.ai), "aj": ints(self.aj), "ak": ints(self.ak), "carrier": ints(self.w != 0),
                        "ri": reals(self.ri), "rj": reals(self.rj), "phi0": reals(self.phi0)}


class RackPinion(Family):
    """Phi = u . (C - P) + rho (phi_i - phi_j - phi0): pinion i with pitch
    radius rho and centre C = r_i + A_i c'; rack j with pitch line through
    P = r_j + A_j s'_j along the unit vector u = A_j u'. The pinion lies on
    the side of u turned by +90 degrees. In the rack's frame the centre's
    coordinate along the line, u . (C - P), changes by -rho per radian of
    relative rotation (rolling without slip). phi0 is phi_i - phi_j when C is
    on the normal through P. Rack fixed along x: Eq. 4.20; pinion centre
    fixed too: Eq. 4.19."""

    def __init__(self, cons, ctx):
        self.ci = ctx.cols(c["pinion"] for c in cons)
        self.cj = ctx.cols(c["rack"] for c in cons)
        self.c = local_points([c["center"] for c in cons])
        self.s = local_points([c["sj"] for c in cons])
        u = local_points([c["u"] for c in cons])
        self.direction, self.u = u, u / np.abs(u)
        self.rho = np.array([c["radius"] for c in cons], dtype=float)
        self.phi0 = np.array([c["phi0"] for c in cons], dtype=float)
        self.n_rows = len(cons)
        self.labels, self.owner, self.driving = row_info(cons, ("roll",))
        self.scale = np.full(self.n_rows, ctx.length)
        ci, cj = self.ci, self.cj
        self.rows, self.cols = pattern(np.stack([ci, ci + 1, ci + 2, cj, cj + 1, cj + 2], axis=1), [0] * 6, 1)
        self.args = (self.ci, self.cj, self.c, self.s, self.u, self.rho, self.phi0)

    def table(self, functions, outlines):
        return "rack-pinion", {"ci": ints(self.ci), "cj": ints(self.cj), "c": points(self.c), "s": points(self.s),
                               "u": points(self.direction), "rho": reals(self.rho), "phi0": reals(self.phi0)}


def _angle(bodies, name):
    return bodies[name].q[2] if name is not None else 0.0


def _check_gear(f, bodies):
    if "phi0" not in f:
        k = _angle(bodies, f.get("carrier"))
        sigma = -1.0 if f.get("internal") else 1.0
        f["phi0"] = (_angle(bodies, f["j"]) - k) + sigma * f["ri"] / f["rj"] * (_angle(bodies, f["i"]) - k)
    return []


def _check_rack(f, bodies):
    """phi0 from the estimates; a pinion whose estimated centre lies on the
    side of u turned -90 degrees (by more than half its radius) is refused:
    Phi rolls it the other way there (Eq. 4.19's sign), so u must point the
    other way along the line."""
    f.setdefault("center", (0.0, 0.0))
    f.setdefault("u", (1.0, 0.0))
    (xi, yi, pi), (xj, yj, pj) = bodies[f["pinion"]].q, bodies[f["rack"]].q
    ei, ej = np.exp(1j * pi), np.exp(1j * pj)
    u = complex(*f["u"]) / np.hypot(*f["u"]) * ej
    d = complex(xi, yi) + complex(*f["center"]) * ei - complex(xj, yj) - complex(*f["sj"]) * ej
    side = (u.conjugate() * d).imag   # the centre's distance from the line, positive on u's +90 degree side
    if side < -0.5 * f["radius"]:
        return [("u", f"the pinion's centre lies {-side:.6g} from the pitch line on the side of u turned -90 "
                      "degrees (by the estimates)", "u along the line with the pinion on its side turned +90 "
                      "degrees (reverse u)")]
    if "phi0" not in f:
        f["phi0"] = float(pi - pj + (u.conjugate() * d).real / f["radius"])
    return []


TYPES = [
    TypeDecl("gear", "4.17, 4.18", (
        BodyKey("i", doc="gear i"),
        PositiveKey("ri", doc="rho_i: pitch radius of gear i"),
        BodyKey("j", doc="gear j"),
        PositiveKey("rj", doc="rho_j: pitch radius of gear j"),
        BodyKey("carrier", required=False, doc="body k that carries both gear centres (Eq. 4.18)"),
        BoolKey("internal", required=False, doc="one gear is an internal (ring) gear: both turn the same way"),
        NumberKey("phi0", required=False, angle=True, quantity="angle", doc="phi_j - phi_k when phi_i - phi_k = 0; default from the estimates"),
    ), Gear, check=_check_gear,
        doc="Spur gears: the pitch circles of gears i and j roll on each other without slip."),
    TypeDecl("rack-pinion", "4.19, 4.20, Problem 4.15", (
        BodyKey("pinion", doc="the pinion i"),
        PositiveKey("radius", doc="rho_i: its pitch radius"),
        LocalKey("center", required=False, of="pinion", doc="its centre, default [0, 0]"),
        BodyKey("rack", doc="the rack j"),
        LocalKey("sj", of="rack", doc="a point of the rack's pitch line"),
        DirectionKey("u", required=False, doc="the pitch line's local direction, default [1, 0]"),
        NumberKey("phi0", required=False, angle=True, quantity="angle",
            doc="phi_i - phi_j when the centre is on the normal to the line through sj; default from the estimates"),
    ), RackPinion, check=_check_rack,
        doc="Rack and pinion: the pitch circle rolls on the pitch line without slip, on the side of u turned +90 deg."),
]
