"""Independent references for native (the report's native row, kinem compare's): the closed forms of
kinem.reference for the repository's cases, evaluated at the case's
instants, with their exact velocities and accelerations (chain rule).

Each closed form takes its dimensions (link lengths, pivots, slider line,
pitch radii, outlines) from the case's assembled configuration at t = 0 and
the case's own tables, and its input from the case's driving function
(evaluated by kinem.reference.drive, not the core), never from the solver's
later instants. A case of that name whose geometry the closed form does not
fit (someone else's case called slider_crank, a gear pair whose centres are
not ri + rj apart, a follower off the camshaft's line) gets none.

What is compared: the named points a closed form gives, else the origin and
angle of every moving body. An angle counts as the arc it moves a point at
distance L (error L |wrap(dphi)|), so one position figure covers both.
"""
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from kinem import reference
from kinem.reference import drive, turned, wrap

from .base import grounded, in_time

CHUNK = 65536   # instants of a closed form evaluated at a time (the time limit looked at between them)
FIT = 1e-6   # relative to L: the closed form must reproduce the t = 0 assembly this well to apply
PARALLEL = 1e-9   # sine of the angle under which two directions count as parallel
# Native against its closed form (docs/report.md "Independent references for native"). The closed
# forms are exact to rounding; native converges to a scaled residual of 1e-12 (the main run) with
# Newton's quadratic convergence, and its rates are linear solves on those positions. Measured on
# the 14 cases: at most 8.3e-15 of L (positions), 6.9e-15 and 1.2e-14 of the peak (velocities,
# accelerations), all on quick_return_3. A change of formulation (a gear ratio 1e-7 off, rates
# 1e-6 off) moves them by that much: the limits sit four orders above rounding, below any such change.
LIMITS = {"position_error_rel": 1e-10, "reference_velocity_error_rel": 1e-9,
          "reference_acceleration_error_rel": 1e-9}


@dataclass(frozen=True)
class ClosedForm:
    """label: what it is, for results.json's ``reference``; points: {name:
    (p, v, a)}, complex arrays over the reference's instants; bodies:
    {name: ((p, v, a) of its origin, (phi, omega, alpha))}."""
    label: str
    points: Mapping
    bodies: Mapping


@dataclass(frozen=True)
class Figures:
    """Native against a closed form, max over the run: positions (case
    length units; angles as L |dphi|) and / L; velocities and accelerations
    (angular ones times L) and each / the closed form's peak of the same."""
    position: float
    position_rel: float
    velocity: float
    velocity_rel: float
    acceleration: float
    acceleration_rel: float


def closed_form(model, ref):
    """The case's ClosedForm, or None. ref: a SolveResult of model's case
    (its first state gives the dimensions, its instants the times)."""
    make = CLOSED_FORMS.get(model.case.name)
    if make is None or not ref.success:
        return None
    traj = ref.trajectory
    try:
        cf = make(model, traj) if _loops(model, make) or len(traj) <= CHUNK else _chunked(make, model, traj)
    except (KeyError, ValueError, StopIteration, ZeroDivisionError):   # another geometry than the closed form's
        return None
    moving = set(model.body_names) - grounded(model)
    if cf.bodies and set(cf.bodies) != moving:     # a body the closed form does not know
        return None
    start = _figures(model, traj, cf, 1)
    fits = start.position <= FIT * model.length
    finite = all(np.isfinite(x).all() for m in _motions(cf) for x in m)
    return cf if fits and finite else None


def _loops(model, make) -> bool:
    """Whether the closed form loops over the instants (a pin in a spline slot: each root from the previous
    instant's; it looks at the limit itself), not evaluated in chunks."""
    return make is pin_in_slot and _one(model, "point-follower")["outline"].kind != "circle"


class _Window:
    """The instants ``rows`` of a trajectory (its first among them), as a closed form reads one: t and columns."""

    def __init__(self, traj, rows):
        self.traj, self.rows, self.t = traj, rows, traj.t[rows]

    def __getitem__(self, name):
        return self.traj[name][self.rows]

    def __len__(self):
        return len(self.rows)


def _chunked(make, model, traj) -> ClosedForm:
    """make(model, traj) evaluated CHUNK instants at a time, the time limit
    (in_time) looked at between chunks: each chunk is the first instant (the
    closed form's dimensions, its assembly and d(0) come from it) and the
    chunk's, the first dropped but in the first chunk. Every closed form but
    that of a pin in a spline slot (``_loops``: its roots each start from the
    previous instant's, and it looks at the limit itself) is elementwise in
    the instants: the same arrays to the bit as one pass."""
    parts = []
    for lo in range(0, len(traj), CHUNK):
        hi = min(len(traj), lo + CHUNK)
        rows = np.arange(lo, hi) if lo == 0 else np.concatenate([[0], np.arange(lo, hi)])
        part = make(model, _Window(traj, rows))
        parts.append(part if lo == 0 else _tail(part))
        if hi < len(traj):
            in_time(traj.t[hi - 1])
    first = parts[0]
    join = [np.concatenate(xs) for xs in zip(*(_flat(p, n) for p, n in zip(parts, _lengths(len(traj)))))]
    return _unflat(first, iter(join))


def _lengths(n):
    """The instants of each chunk's part (the first instant dropped but in the first)."""
    return [min(n, lo + CHUNK) - lo for lo in range(0, n, CHUNK)]


def _flat(cf, n=None) -> list:
    """Every array of a ClosedForm, in one order (``_unflat``'s); a constant as ``n`` instants of it."""
    out = [x for m in cf.points.values() for x in m]
    for origin, angle in cf.bodies.values():
        out += list(origin) + list(angle)
    return [np.full(n, x) if n is not None and np.ndim(x) == 0 else x for x in out]


def _unflat(cf, arrays) -> ClosedForm:
    points = {name: tuple(next(arrays) for _ in m) for name, m in cf.points.items()}
    bodies = {name: (tuple(next(arrays) for _ in origin), tuple(next(arrays) for _ in angle))
              for name, (origin, angle) in cf.bodies.items()}
    return ClosedForm(cf.label, points, bodies)


def _tail(cf) -> ClosedForm:
    """cf without its first instant (a later chunk's copy of instant 0)."""
    return _unflat(cf, iter([x[1:] if np.ndim(x) else x for x in _flat(cf)]))


def error(model, traj, cf) -> Figures:
    """Figures of traj against cf over the instants both have."""
    return _figures(model, traj, cf, min(len(traj), len(next(_motions(cf))[0])))


def _motions(cf):
    """Every motion (p, v, a) of cf: the points', then each body's origin and angle."""
    for m in cf.points.values():
        yield m
    for origin, angle in cf.bodies.values():
        yield origin
        yield angle


def _figures(model, traj, cf, n) -> Figures:
    L = model.length
    items = []      # (native's, the closed form's, is an angle): three arrays each, an angle's times L
    for name, m in cf.points.items():
        items.append(([_xy(traj, name, k)[:n] for k in ("", "v", "a")], [x[:n] for x in m], False))
    for body, (origin, angle) in cf.bodies.items():
        items.append(([_xy(traj, body, k)[:n] for k in ("", "v", "a")], [x[:n] for x in origin], False))
        items.append(([L * traj[f"{body}.{c}"][:n] for c in ("phi", "omega", "alpha")], [L * x[:n] for x in angle],
                      True))
    out = []
    for k in range(3):
        err = max(float(np.max(np.abs(L * wrap((g[k] - w[k]) / L) if angle and k == 0 else g[k] - w[k])))
                  for g, w, angle in items)
        peak = max(float(np.max(np.abs(w[k]))) for _, w, _ in items)
        out += [err, err / (L if k == 0 else max(peak, 1e-300))]
    return Figures(*out)


def _xy(traj, name, kind=""):
    return traj[f"{name}.{kind}x"] + 1j * traj[f"{name}.{kind}y"]


# -- the case's t = 0 configuration and tables ------------------------------------------------

def _at(traj, body):
    """A body's origin (complex) and angle at t = 0."""
    return complex(traj[f"{body}.x"][0], traj[f"{body}.y"][0]), float(traj[f"{body}.phi"][0])


def _global(traj, body, local):
    origin, phi = _at(traj, body)
    return origin + complex(*local) * np.exp(1j * phi)


def _driven(model, traj, body, coord):
    """The motion of a body coordinate's driver, as a change from t = 0."""
    c = next(c for c in model.case.constraints
             if c.type == "driver" and c.get("body") == body and c.get("coord") == coord and not c.get("point"))
    return drive(c["d"], traj.t)


def _pivot(model, traj, body):
    """Global position at t = 0 of the revolute joining ``body`` to a grounded body."""
    fixed = grounded(model)
    c = next(c for c in model.case.constraints if c.type == "revolute"
             and body in (c["i"], c["j"]) and c["i"] != c["j"] and ({c["i"], c["j"]} - {body}) <= fixed)
    side = "j" if c["i"] == body else "i"
    return _global(traj, c[side], c["s" + side])


def _line(model, traj, body, types=("translational",)):
    """Unit direction at t = 0 of the line that guides ``body`` on a grounded
    body: a translational joint's si -> qi on body i, a revolute-translational
    joint's sj -> qj on body j."""
    fixed = grounded(model)
    c = next(c for c in model.case.constraints if c.type in types
             and body in (c["i"], c["j"]) and ({c["i"], c["j"]} - {body}) <= fixed)
    side = "i" if c.type == "translational" else "j"
    d = (complex(*c["q" + side]) - complex(*c["s" + side])) * np.exp(1j * _at(traj, c[side])[1])
    return d / abs(d)


def _still(z, t):
    return np.full(len(t), z), np.zeros(len(t), complex), np.zeros(len(t), complex)


def _turning(traj, body, pivot, turn):
    """A body turning by ``turn`` about a fixed pivot: (origin, angle) motions."""
    origin, phi = _at(traj, body)
    return turned(origin, pivot, turn), (phi + turn[0], turn[1], turn[2])


def _sliding(traj, body, travel, u):
    """A body translating by ``travel`` (a motion) along the unit direction u."""
    origin, phi = _at(traj, body)
    zero = np.zeros_like(travel[0])
    return (origin + travel[0] * u, travel[1] * u, travel[2] * u), (phi + zero, zero, zero)


def _one(model, kind):
    (c,) = [c for c in model.case.constraints if c.type == kind]
    return c


def _check(ok, why):
    if not ok:
        raise ValueError(why)


def _parallel(a, b):
    return abs((a / b).imag) <= PARALLEL


def _outline_s(o):
    """s(theta) and its first two derivatives of an outline (a circle: constant R)."""
    if o.kind == "circle":
        return lambda x: (np.full_like(x, o.radius), np.zeros_like(x), np.zeros_like(x))
    return reference.polar_spline(o.theta, o.s, o.bc)


# -- the closed forms -------------------------------------------------------------------------

def slider_crank(model, traj):
    O = _ground(model, traj, "O")
    B0, A0 = _xy(traj, "B")[0], _xy(traj, "A")[0]
    r, l, e = abs(B0 - O), abs(A0 - B0), (A0 - O).imag
    d, w, a = _driven(model, traj, "crank", "phi")
    theta = np.angle(B0 - O) + d
    side = -1.0 if A0.real < B0.real else 1.0
    s = reference.slider_crank(theta, w, a, r, l, e, side)
    return ClosedForm("closed form kinem.reference.slider_crank (points A, B)",
                      {"B": turned(B0, O, (d, w, a)), "A": (O + s["x"] + 1j * e, s["vx"] + 0j, s["ax"] + 0j)}, {})


def four_bar(model, traj):
    O2, O4 = (_xy(traj, n)[0] for n in ("O2", "O4"))
    A0, B0 = _xy(traj, "A")[0], _xy(traj, "B")[0]
    u = (O4 - O2) / abs(O4 - O2)          # the ground line's direction
    a, b, c, d = abs(A0 - O2), abs(B0 - A0), abs(B0 - O4), abs(O4 - O2)
    turn = _driven(model, traj, "crank", "phi")
    th2 = np.angle((A0 - O2) / u) + turn[0]
    best = None
    for sign in (1.0, -1.0):                # the assembly the case starts in
        f = reference.four_bar(th2, turn[1], turn[2], a, b, c, d, sign)
        B = O2 + u * f["B"]
        if best is None or abs(B[0] - B0) < abs(best[0][0] - B0):
            best = (B, 1j * f["w4"] * (B - O4), (1j * f["a4"] - f["w4"] ** 2) * (B - O4))
    return ClosedForm("closed form kinem.reference.four_bar (points A, B)", {"A": turned(A0, O2, turn), "B": best}, {})


def quick_return(model, traj):
    O, C = _ground(model, traj, "O"), _ground(model, traj, "C")
    u = (O - C) / abs(O - C)               # the closed form's +y: from the rocker pivot C to the crank pivot O
    to_local = 1j / u
    A0, B0, D0 = (_xy(traj, n)[0] for n in "ABD")
    d, w, a = _driven(model, traj, "crank", "phi")
    theta = np.angle((A0 - O) * to_local) + d
    p = reference.quick_return(theta, abs(O - C), abs(A0 - O), abs(B0 - C), abs(D0 - B0),
                               ((D0 - O) * to_local).imag, w, a)
    return ClosedForm("closed form kinem.reference.quick_return (points A, B, D)",
                      {n: (O + p[n] / to_local, p["v" + n] / to_local, p["a" + n] / to_local) for n in "ABD"}, {})


def gear_pair(model, traj):
    """Eq. 4.17: the driven gear's turn, the other's -rho_i / rho_j of it."""
    g = _one(model, "gear")
    _check(not g.get("carrier") and not g.get("internal"), "not a pair on fixed centres")
    pi, pj = _pivot(model, traj, g["i"]), _pivot(model, traj, g["j"])
    _check(abs(abs(pi - pj) - (g["ri"] + g["rj"])) <= FIT * model.length, "centres not rho_i + rho_j apart")
    try:
        ti = _driven(model, traj, g["i"], "phi")
        tj = reference.gear_pair(ti, g["ri"], g["rj"])
    except StopIteration:
        tj = _driven(model, traj, g["j"], "phi")
        ti = reference.gear_pair(tj, g["rj"], g["ri"])
    return ClosedForm("closed form kinem.reference.gear_pair (Eq. 4.17; the gears' angles)",
                      {}, {g["i"]: _turning(traj, g["i"], pi, ti), g["j"]: _turning(traj, g["j"], pj, tj)})


def planetary(model, traj):
    """Eq. 4.18 on both meshes: sun driven, ring fixed, planet on the carrier."""
    fixed = grounded(model)
    ring_mesh = next(c for c in model.case.constraints if c.type == "gear" and c.get("internal"))
    sun_mesh = next(c for c in model.case.constraints if c.type == "gear" and not c.get("internal"))
    ring, r_ring = (ring_mesh["i"], ring_mesh["ri"]) if ring_mesh["i"] in fixed else (ring_mesh["j"], ring_mesh["rj"])
    planet, r_p = (ring_mesh["j"], ring_mesh["rj"]) if ring == ring_mesh["i"] else (ring_mesh["i"], ring_mesh["ri"])
    sun, r_s, r_p2 = ((sun_mesh["i"], sun_mesh["ri"], sun_mesh["rj"]) if sun_mesh["j"] == planet
                      else (sun_mesh["j"], sun_mesh["rj"], sun_mesh["ri"]))
    carrier = sun_mesh["carrier"]
    _check(ring in fixed and ring_mesh.get("carrier") == carrier and r_p2 == r_p and planet in
           (sun_mesh["i"], sun_mesh["j"]), "not a sun, planet, carrier and fixed ring")
    axis, axis_c = _pivot(model, traj, sun), _pivot(model, traj, carrier)
    axle = next(c for c in model.case.constraints if c.type == "revolute" and {c["i"], c["j"]} == {planet, carrier})
    p0 = _global(traj, carrier, axle["si" if axle["i"] == carrier else "sj"])
    L = model.length
    _check(abs(axis - axis_c) <= FIT * L and abs(abs(p0 - axis) - (r_s + r_p)) <= FIT * L
           and abs(r_ring - r_p - r_s - r_p) <= FIT * L, "not a coaxial sun, carrier and ring meshing the planet")
    turn = _driven(model, traj, sun, "phi")
    tc, tp = reference.planetary(turn, r_s, r_p, r_ring)
    centre = turned(p0, axis, tc)                     # the planet's axle on the carrier
    origin, phi = _at(traj, planet)
    rel = (origin - p0) * np.exp(1j * tp[0])          # the planet's origin about its axle
    planet_origin = (centre[0] + rel, centre[1] + 1j * tp[1] * rel, centre[2] + (1j * tp[2] - tp[1] ** 2) * rel)
    return ClosedForm("closed form kinem.reference.planetary (Eq. 4.18; sun, carrier, planet)", {},
                      {sun: _turning(traj, sun, axis, turn), carrier: _turning(traj, carrier, axis, tc),
                       planet: (planet_origin, (phi + tp[0], tp[1], tp[2]))})


def _pitch(model, traj, m):
    """(pinion centre, unit direction u of the pitch line, signed radius h:
    the centre's side of the line) at t = 0 of a rack-pinion constraint."""
    centre = _global(traj, m["pinion"], m.get("center", (0.0, 0.0)))
    u = complex(*m.get("u", (1.0, 0.0))) * np.exp(1j * _at(traj, m["rack"])[1])
    u /= abs(u)
    h = ((centre - _global(traj, m["rack"], m["sj"])) / u).imag
    _check(abs(abs(h) - m["radius"]) <= FIT * model.length, "the pinion's centre is not its radius off the pitch line")
    return centre, u, float(np.copysign(m["radius"], h))


def rack_pinion(model, traj):
    """Eq. 4.19 on an inclined line: the pinion turns about its fixed centre,
    the rack slides h phi along its pitch line."""
    m = _one(model, "rack-pinion")
    pinion, rack = m["pinion"], m["rack"]
    centre, u, h = _pitch(model, traj, m)
    pivot = _pivot(model, traj, pinion)
    _check(abs(centre - pivot) <= FIT * model.length and _parallel(_line(model, traj, rack), u),
           "the pinion's centre moves or the rack's guide is not along its pitch line")
    turn = _driven(model, traj, pinion, "phi")
    return ClosedForm("closed form kinem.reference.rack_travel (Eq. 4.19; pinion angle, rack along its line)", {},
                      {pinion: _turning(traj, pinion, pivot, turn),
                       rack: _sliding(traj, rack, reference.rack_travel(turn, h), u)})


def rolling_pinion(model, traj):
    """Eq. 4.20 with the rack fixed: the centre, driven along the line, turns
    the pinion by -x / h."""
    m = _one(model, "rack-pinion")
    pinion = m["pinion"]
    from adapters.base import grounded

    _check(m["rack"] in grounded(model) and complex(*m.get("center", (0.0, 0.0))) == 0,
           "not a pinion rolling on a fixed rack about its own origin")
    centre, u, h = _pitch(model, traj, m)
    _check(_parallel(_line(model, traj, pinion, ("revolute-translational", "translational")), u)
           and abs(u.real) > 0.1, "the centre's line is not along the pitch line, or x does not move it")
    x = _driven(model, traj, pinion, "x")
    along = reference.scaled(1 / u.real, x)                         # the centre's travel along u
    turn = reference.scaled(-1 / h, along)                          # rack_travel's h phi, the rack fixed
    angle = (_at(traj, pinion)[1] + turn[0], turn[1], turn[2])
    return ClosedForm("closed form kinem.reference.rack_travel (Eq. 4.20; pinion rolling on the fixed rack)", {},
                      {pinion: (_sliding(traj, pinion, along, u)[0], angle)})


def pin_in_slot(model, traj):
    """Eq. 4.30 with the pin driven in y: on a circle x = sqrt(R^2 - y^2);
    on a spline slot the root of s(theta) sin(theta) = y (scipy)."""
    from adapters.base import grounded

    c = _one(model, "point-follower")
    pin, slot = c["i"], c["j"]
    o = c["outline"]
    q, phi_j = _at(traj, slot)
    _check(slot in grounded(model) and abs(wrap(phi_j)) <= PARALLEL, "the slot is not on an unturned ground")
    next(a for a in model.case.constraints if a.type == "absolute" and a["body"] == pin and a["coord"] == "phi")
    Q = q + complex(*o.center)
    P0 = _global(traj, pin, c["si"])
    offset = P0 - _at(traj, pin)[0]
    dy = _driven(model, traj, pin, "y")
    Y = ((P0 - Q).imag + dy[0], dy[1], dy[2])
    if o.kind == "circle":
        X = reference.circle_x(Y, o.radius, np.sign((P0 - Q).real))
        label = "closed form kinem.reference.circle_x (Eq. 4.30 on a circle: x = sqrt(R^2 - y^2))"
    else:
        X, _ = reference.pin_in_outline(Y, _outline_s(o), np.angle(P0 - Q), lambda k: in_time(traj.t[k]))
        label = "kinem.reference.pin_in_outline (Eq. 4.30: scipy's periodic CubicSpline of the slot, Brent's root)"
    P = (Q + X[0] + 1j * Y[0], X[1] + 1j * Y[1], X[2] + 1j * Y[2])
    zero = np.zeros_like(Y[0])
    return ClosedForm(label, {}, {pin: ((P[0] - offset, P[1], P[2]), (_at(traj, pin)[1] + zero, zero, zero))})


def _cam(model, traj, c):
    """(pivot, the cam's turn, the follower's guide) of a cam pair."""
    return _pivot(model, traj, c["cam"]), _driven(model, traj, c["cam"], "phi"), _line(model, traj, c["follower"])


def cam_flat(model, traj):
    """Eq. 4.29, a circular cam and a flat face normal to the guide: the face
    height is the cam centre's plus R (lift = e sin(phi) + R)."""
    c = _one(model, "cam-flat")
    cam, fol, o = c["cam"], c["follower"], c["outline"]
    _check(o.kind == "circle", "not a circular cam")
    pivot, turn, g = _cam(model, traj, c)
    n = complex(*c["normal"]) * np.exp(1j * _at(traj, fol)[1])
    n /= abs(n)
    _check(_parallel(g, n), "the face is not normal to the follower's guide")
    C0 = _global(traj, cam, o.center)
    F0 = _global(traj, fol, c["sj"])
    d0 = (np.conj(n) * (F0 - C0)).real
    _check(abs(abs(d0) - o.radius) <= FIT * model.length, "the face does not touch the circle")
    lift = reference.cam_flat_lift(turned(C0, pivot, turn), n, o.radius, np.sign(d0))
    travel = (lift[0] - (np.conj(n) * F0).real, lift[1], lift[2])
    return ClosedForm("closed form kinem.reference.cam_flat_lift (Eq. 4.29: lift = e sin(phi) + R)", {},
                      {cam: _turning(traj, cam, pivot, turn), fol: _sliding(traj, fol, travel, n)})


def cam_roller(model, traj):
    """Example 4.4: a roller on a circular cam, its centre on a line through
    the camshaft: d = e sin(psi) + rho cos(gamma)."""
    c = _one(model, "cam-roller")
    cam, fol, o = c["cam"], c["follower"], c["outline"]
    _check(o.kind == "circle" and c.get("side", "outside") == "outside", "not a roller outside a circular cam")
    pivot, turn, g = _cam(model, traj, c)
    frame = 1j / g                                    # the guide along +y, the camshaft at 0
    c0 = (_global(traj, cam, o.center) - pivot) * frame
    q0 = (_global(traj, fol, c["sj"]) - pivot) * frame
    _check(abs(q0.real) <= FIT * model.length, "the roller's line misses the camshaft")
    e = abs(c0)
    psi = (np.angle(c0) + turn[0], turn[1], turn[2])
    d = reference.roller_on_circle(psi, e, o.radius + c["radius"], np.sign(q0.imag - e * np.sin(psi[0][0])))
    travel = (d[0] - q0.imag, d[1], d[2])
    return ClosedForm("closed form kinem.reference.roller_on_circle (Example 4.4)", {},
                      {cam: _turning(traj, cam, pivot, turn), fol: _sliding(traj, fol, travel, g)})


def cam_point(model, traj):
    """Eq. 4.26 with a radial point follower: the tip at s(theta) from the
    outline's centre, theta = its angle on the cam (scipy's spline of the table)."""
    c = _one(model, "cam-point")
    cam, fol, o = c["cam"], c["follower"], c["outline"]
    pivot, turn, g = _cam(model, traj, c)
    C0, F0 = _global(traj, cam, o.center), _global(traj, fol, c["sj"])
    L = model.length
    _check(abs(C0 - pivot) <= FIT * L and abs(((F0 - C0) / g).imag) <= FIT * L, "not a radial follower")
    u = (F0 - C0) / abs(F0 - C0)
    theta0 = np.angle(F0 - C0) - _at(traj, cam)[1]
    r = reference.radial_follower((theta0 - turn[0], -turn[1], -turn[2]), _outline_s(o))
    travel = (r[0] - abs(F0 - C0), r[1], r[2])
    return ClosedForm("kinem.reference.radial_follower (Eq. 4.26: scipy's periodic CubicSpline of the table)", {},
                      {cam: _turning(traj, cam, pivot, turn), fol: _sliding(traj, fol, travel, u)})


def _ground(model, traj, joint):
    """Global position of the ground-side point of a revolute joint named ``joint``."""
    from adapters.base import grounded

    c = next(c for c in model.case.constraints if c.name == joint and c.type == "revolute")
    side = "i" if c["i"] in grounded(model) else "j"
    return _global(traj, c[side], c["s" + side])


CLOSED_FORMS = {"slider_crank": slider_crank, "four_bar": four_bar,
                "quick_return_1": quick_return, "quick_return_2": quick_return, "quick_return_3": quick_return,
                "gear_pair": gear_pair, "planetary": planetary, "rack_pinion": rack_pinion,
                "rolling_pinion": rolling_pinion, "pin_in_slot": pin_in_slot, "pin_in_spline_slot": pin_in_slot,
                "cam_flat_eccentric": cam_flat, "cam_roller_circle": cam_roller, "cam_table41": cam_point}
