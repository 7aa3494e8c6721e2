"""Exudyn adapter: planar rigid bodies with exact algebraic constraints,
integrated by Exudyn's implicit generalized-alpha solver (index 3).

Every moving body is a NodeRigidBody2D + ObjectRigidBody2D whose reference
coordinates are zero, so that node coordinates (which Exudyn counts from the
reference) are the absolute x, y, phi of the case's body frame; bodies fixed
by 'ground' are ObjectGround frames at their pose. Each chapter constraint
becomes one Exudyn constraint (see ``supports``). Positions come out of the
index-3 Newton solve, so they satisfy the constraints at every step whatever
the step size; velocities follow from the Newmark-type update and carry an
O(dt^2) error.

Why generalized-alpha and not a SolveStatic kinematic sweep (engines.md): the
sweep gives positions only (no velocities to compare), and index-3
generalized-alpha already gives positions at round-off (1e-15 of the
mechanism size). 'trapezoidal-index2' (velocity-level constraints) is offered
for comparison: its velocities satisfy the constraints, its positions drift
(~1e-9 of L on the cases at dt = 1e-4).
"""
import bisect
import math
import time

import numpy as np

import exudyn as exu
from exudyn import itemInterface as ei
from exudyn.advancedUtilities import CreateSymbolicUserFunction
from scipy.interpolate import CubicSpline

from kinem.functions import Harmonic, Poly, Table
from kinem.outline import Outline, OutlineSet  # noqa: F401 - Outline: the repr of the exported calls

from .base import (Adapter, Failure, Reason, Status, boolean, choice, count, count_or_none, deadline, drives, fraction,
                   grounded, in_time, mass_properties, nonnegative, positive, step_or_auto)

# Limits on the figures of adapters/compare.py at the default settings.
# Positions: the index-3 Newton solve holds every constraint at each step, so
# the engine is at round-off (<= 1.3e-14 of L against a native converged to
# 1e-14); against native at a tolerance of 1e-10 (the default when these were
# measured; it is now 1e-12) the figures are native's own error, measured up to
# 4.1e-11 of L and 1.3e-10 rad (quick_return_1): the limits are 10x that
# tolerance (at 1e-12: 3e-12 of L, kinem compare on the quick-returns).
# Velocities: the O(dt^2) generalized-alpha error at dt = 1e-4, measured up to
# 1.2e-8 of the speed scale and 6.2e-8 rad/s (quick_return_1, 3 rad/s) over
# the tests' cases: the limits are about 8x that.
TOLERANCE = {
    "position_error_rel": 1e-9,      # |r_engine - r_native| / L
    "angle_error": 1e-9,             # rad
    "constraint_residual": 1e-9,     # native scaled residual of the engine's positions (t = 0 is native's q0)
    "velocity_error_rel": 1e-7,      # |v_engine - v_native| / speed scale
    "angular_velocity_error_rel": 1e-7,  # |omega_engine - omega_native| / peak angular speed
}

INTEGRATORS = {"generalized-alpha": "GeneralizedAlpha", "trapezoidal-index2": "TrapezoidalIndex2"}
NEWTON_TESTS = {"residual": 0, "increment": 1}  # Exudyn's newton.residualMode
SOLVERS = ("auto", "EXUdense", "EigenDense")

# Sketch of the representation of each case-file type.
SUPPORTS = {
    "ground": "ObjectGround at the body's pose (the body has no node)",
    "absolute": "CoordinateConstraint to a ground coordinate; for a point: "
                "ObjectJointPrismatic2D(constrainRotation=False) on a fixed line x = c or y = c",
    "revolute": "ObjectJointRevolute2D between two MarkerBodyPosition",
    "translational": "ObjectJointPrismatic2D(constrainRotation=True), the line's body as marker 1",
    "revolute-revolute": "ObjectConnectorDistance",
    "revolute-translational": "ObjectJointPrismatic2D(constrainRotation=False), the slotted body as marker 1",
    "driver": "CoordinateConstraint with (symbolic) offsetUserFunction d(t) and offsetUserFunction_t d'(t) "
              "on x, y or phi (relative_to: between the two phi coordinates); point form: a helper body whose "
              "x (y) follows d(t), with the point held on its line x = d(t) (y = d(t)) by ObjectJointPrismatic2D",
    "distance-driver": "ObjectConnectorCoordinateVector with constraint and Jacobian user functions "
                       "|P_j - P_i|^2 - d(t)^2",
    "gear": "CoordinateConstraint between the two phi coordinates with factor1 (fixed axes); with a moving "
            "carrier, a linear ObjectConnectorCoordinateVector (scaling matrix, no user function) on the "
            "three angles",
    "rack-pinion": "ObjectConnectorCoordinateVector with constraint and Jacobian user functions "
                   "u.(C - P) + rho (phi_i - phi_j) - const",
}
REASONS = {}
CURVE = ("ObjectConnectorCoordinateVector with constraint and Jacobian user functions over the bodies' node "
         "coordinates and a NodeGenericODE2 for the outline angle theta; the outline by kinem.outline (the core's "
         "evaluation): ")
SUPPORTS.update({
    "cam-point": CURVE + "r_c + A_c p(theta) - r_f - A_f s_f (Eq. 4.26)",
    "point-follower": CURVE + "r_j + A_j p(theta) - r_i - A_i s_i (Eq. 4.30)",
    "cam-roller": CURVE + "[g . d, d . d - rho^2], d from the contact point to the roller centre (Eq. 4.28)",
    "cam-flat": CURVE + "[g . n, d . n], n the face's normal, d from the face point to the contact (Eq. 4.29)",
})


def function_spec(f):
    """A kinem function as the plain data ``evaluate`` takes (the same values as
    kinem.functions: the table is the same not-a-knot CubicSpline)."""
    if isinstance(f, Poly):
        c = [float(v) for v in f.coeffs]
        cs = [c]
        for _ in range(2):
            c = [k * v for k, v in enumerate(c)][1:] or [0.0]
            cs.append(c)
        return ("poly", cs)
    if isinstance(f, Harmonic):
        return ("harmonic", float(f.offset), float(f.amplitude), float(f.omega), float(f.phase))
    if isinstance(f, Table):
        s = CubicSpline(np.asarray(f.t, float), np.asarray(f.value, float))
        return ("table", s.x.tolist(), s.c.T.tolist())  # per interval: c3 .. c0 of (t - x_k)^3 .. ^0
    raise TypeError(f"unknown function kind {f!r}")


class _Function:
    """d(t), d'(t), d''(t) of a kinem function: Python numbers (``value``) or
    Exudyn symbolic user functions that run in C++ (``symbolic``), both from
    ``evaluate``."""

    def __init__(self, f):
        self.f, self.spec = f, function_spec(f)

    def value(self, t, order=0):
        return evaluate(self.spec, t, order)

    def symbolic(self, mbs, offset=0.0):
        """(offset + d(t), d'(t)) as symbolic offset user functions of a CoordinateConstraint."""
        return offset_functions(mbs, self.spec, offset, True)


# -- Portable: the functions from here to _rot use only math, bisect and exudyn;
# kinem export (adapters/export.py) copies their source into the exported
# script, so that it runs the very code of the harness.

def evaluate(spec, t, order=0, symbolic=False):
    """d(t), d'(t) or d''(t) (order 0, 1, 2) of a driving function given as
    plain data: ("poly", [coefficients of d, d', d'' by rising power]),
    ("harmonic", offset, amplitude, omega, phase): offset + amplitude
    sin(omega t + phase), or ("table", breakpoints x, per interval the
    coefficients of (t - x_k)^3 .. ^0: kinem's not-a-knot cubic spline). t is
    a float or (symbolic) an Exudyn symbolic real; a table is then a chain of
    IfThenElse over the same pieces."""
    if spec[0] == "poly":
        v = 0.0
        for a in reversed(spec[1][order]):
            v = v * t + a
        return v
    if spec[0] == "harmonic":
        _, offset, amplitude, omega, phase = spec
        sin, cos = (exu.symbolic.sin, exu.symbolic.cos) if symbolic else (math.sin, math.cos)
        arg = omega * t + phase
        if order == 0:
            return offset + amplitude * sin(arg)
        if order == 1:
            return amplitude * omega * cos(arg)
        return -amplitude * omega ** 2 * sin(arg)
    _, x, c = spec
    n = len(x)
    if not symbolic:
        return _piece(x, c, min(max(bisect.bisect_right(x, t) - 1, 0), n - 2), t, order)
    v = _piece(x, c, n - 2, t, order)
    for k in range(n - 3, -1, -1):
        v = exu.symbolic.IfThenElse(t < x[k + 1], _piece(x, c, k, t, order), v)
    return v


def _piece(x, c, k, t, order):
    a, b, cc, d = c[k]
    h = t - x[k]
    if order == 0:
        return ((a * h + b) * h + cc) * h + d
    if order == 1:
        return (3 * a * h + 2 * b) * h + cc
    return 6 * a * h + 2 * b


def offset_functions(mbs, spec, offset, symbolic):
    """(offset + d(t), d'(t)): the offsetUserFunction and offsetUserFunction_t
    of a CoordinateConstraint (their argument names are Exudyn's); symbolic:
    Exudyn symbolic user functions (keep them alive while the system lives)."""
    def d(mbs, t, itemNumber, lOffset):
        return offset + evaluate(spec, t, 0, symbolic)

    def d_t(mbs, t, itemNumber, lOffset):
        return evaluate(spec, t, 1, symbolic)
    if not symbolic:
        return d, d_t
    return tuple(CreateSymbolicUserFunction(mbs, g, name, itemTypeName="ObjectConnectorCoordinate")
                 for g, name in ((d, "offsetUserFunction"), (d_t, "offsetUserFunction_t")))


def user_functions(phi, grad, phi_t, slots, z0):
    """constraintUserFunction and jacobianUserFunction of an
    ObjectConnectorCoordinateVector for constraint rows phi(z, t) = 0 (a
    list) with gradients grad(z, t) (one list per row) over z (x, y, phi of
    each of its bodies, then any outline angle theta): the connector's
    coordinates fill the places ``slots`` of z, the rest (fixed bodies)
    keep their values in z0. Plain Python floats."""
    whole = len(slots) == len(z0)

    def full(q):
        q = q.tolist() if hasattr(q, "tolist") else list(q)
        if whole:
            return q
        z = list(z0)
        for k, v in zip(slots, q):
            z[k] = v
        return z

    def constraint(mbs, t, item, q, q_t, velocity_level):
        z = full(q)
        if velocity_level:  # index 2: dphi/dt = grad . q_t + phi_t
            w = list(q_t)
            rates = phi_t(t) if phi_t is not None else None
            return [sum(g[k] * v for k, v in zip(slots, w)) + (rates[r] if rates is not None else 0.0)
                    for r, g in enumerate(grad(z, t))]
        return phi(z, t)

    def jacobian(mbs, t, item, q, q_t, velocity_level):
        return [[g[k] for k in slots] for g in grad(full(q), t)]
    return constraint, jacobian


def _frame(z, k):
    """Origin (complex) and e^{i phi} of the k-th body in a coordinate vector."""
    return complex(z[3 * k], z[3 * k + 1]), complex(math.cos(z[3 * k + 2]), math.sin(z[3 * k + 2]))


def _dot(a, b):
    return a.real * b.real + a.imag * b.imag


def distance_driver(si, sj, spec):
    """|P_j - P_i|^2 - d(t)^2 on z = (x, y, phi of i, of j), its gradient and
    its partial time derivative; si, sj: the points (complex) in i and j."""
    def parts(z):
        ri, ei_ = _frame(z, 0)
        rj, ej = _frame(z, 1)
        a, bb = si * ei_, sj * ej
        return rj + bb - ri - a, a, bb

    def phi(z, t):
        d, _, _ = parts(z)
        return [_dot(d, d) - evaluate(spec, t) ** 2]

    def grad(z, t):
        d, a, bb = parts(z)
        # d(d.d)/dz = 2 d . dd/dz; dd/dphi_i = -i a, dd/dphi_j = i bb
        return [[-2 * d.real, -2 * d.imag, -2 * _dot(d, 1j * a), 2 * d.real, 2 * d.imag, 2 * _dot(d, 1j * bb)]]

    def phi_t(t):
        return [-2 * evaluate(spec, t) * evaluate(spec, t, 1)]
    return phi, grad, phi_t


def rack_pinion(cc, sp, u0, rho, const):
    """u.(C - P) + rho (phi_i - phi_j) - const on z = (x, y, phi of the pinion
    i, of the rack j) and its gradient (no explicit time): C the pinion's
    centre cc in i, P the pitch line's point sp in j, u its direction u0 in j
    (complex). In the rack's frame the pinion centre's coordinate along the
    pitch line changes by -rho per radian of relative rotation (the pinion on
    the side of u turned +90 degrees, as kinem's Eqs. 4.19, 4.20)."""
    def parts(z):
        ri, ei_ = _frame(z, 0)
        rj, ej = _frame(z, 1)
        a, bb = cc * ei_, sp * ej
        return u0 * ej, ri + a - rj - bb, a, bb

    def phi(z, t):
        u, d, _, _ = parts(z)
        return [_dot(u, d) + rho * (z[2] - z[5]) - const]

    def grad(z, t):
        u, d, a, bb = parts(z)
        # du/dphi_j = i u; dd/dphi_i = i a; dd/dphi_j = -i bb
        return [[u.real, u.imag, _dot(u, 1j * a) + rho, -u.real, -u.imag, _dot(1j * u, d) - _dot(u, 1j * bb) - rho]]
    return phi, grad, None


def _contact(outline):
    """z -> (r_c, r_b, e^{i phi_b}, a = A_c p, g = A_c p', h = A_c p'') of z =
    (x, y, phi of the outline body c, of the other body b, theta), complex,
    with p(theta) and its derivatives by kinem.outline (the compiled core's
    evaluation, Eqs. 4.21-4.25); the last z's values are kept (Exudyn asks
    for the constraint and its Jacobian at the same coordinates)."""
    curve, last = OutlineSet([outline]).curve_at, [None, None]

    def contact(z):
        key = tuple(z)
        if key != last[0]:
            rc, ec = _frame(z, 0)
            rb, eb = _frame(z, 1)
            p, p1, p2, _ = curve(z[6])
            last[0], last[1] = key, (rc, rb, eb, p * ec, p1 * ec, p2 * ec)
        return last[1]
    return contact


def point_on_curve(outline, sb):
    """r_c + A_c p(theta) - r_b - A_b s_b = 0 (x and y rows) on z = (x, y,
    phi of the outline body c, of the point's body b, theta): cam-point (c
    the cam, b the follower, Eq. 4.26) and point-follower (c the slotted
    body, b the pin's, Eq. 4.30); sb the point in b (complex)."""
    contact = _contact(outline)

    def phi(z, t):
        rc, rb, eb, a, _, _ = contact(z)
        d = rc + a - rb - sb * eb
        return [d.real, d.imag]

    def grad(z, t):
        _, _, eb, a, g, _ = contact(z)
        ia, ib = 1j * a, -1j * sb * eb      # d/dphi_c, d/dphi_b
        return [[1.0, 0.0, ia.real, -1.0, 0.0, ib.real, g.real],
                [0.0, 1.0, ia.imag, 0.0, -1.0, ib.imag, g.imag]]
    return phi, grad, None


def cam_roller(outline, sb, rho):
    """[g . d, d . d - rho^2] on z = (x, y, phi of the cam c, of the
    follower b, theta), d = r_b + A_b s_b - r_c - a from the contact point
    to the roller's centre s_b (complex; Eq. 4.28)."""
    contact = _contact(outline)

    def parts(z):
        rc, rb, eb, a, g, h = contact(z)
        bb = sb * eb
        return rb + bb - rc - a, a, g, h, bb

    def phi(z, t):
        d, _, g, _, _ = parts(z)
        return [_dot(g, d), _dot(d, d) - rho * rho]

    def grad(z, t):
        d, a, g, h, bb = parts(z)
        # dd/dz: x_c -1, y_c -i, phi_c -i a, x_b 1, y_b i, phi_b i bb, theta -g; dg/dphi_c = i g, dg/dtheta = h
        dd = [-1.0, -1j, -1j * a, 1.0, 1j, 1j * bb, -g]
        dg = [0.0, 0.0, 1j * g, 0.0, 0.0, 0.0, h]
        return [[_dot(g, x) + _dot(d, y) for x, y in zip(dd, dg)], [2 * _dot(d, x) for x in dd]]
    return phi, grad, None


def cam_flat(outline, sb, normal):
    """[g . n, d . n] on z = (x, y, phi of the cam c, of the follower b,
    theta), n = A_b n_b the face's unit normal (n_b complex, unit), d = r_c +
    a - r_b - A_b s_b from the face's point s_b to the contact (Eq. 4.29)."""
    contact = _contact(outline)

    def parts(z):
        rc, rb, eb, a, g, h = contact(z)
        bb = sb * eb
        return rc + a - rb - bb, a, g, h, bb, normal * eb

    def phi(z, t):
        d, _, g, _, _, n = parts(z)
        return [_dot(g, n), _dot(d, n)]

    def grad(z, t):
        d, a, g, h, bb, n = parts(z)
        # dn/dphi_b = i n; dd/dz: x_c 1, y_c i, phi_c i a, x_b -1, y_b -i, phi_b -i bb, theta g
        dd = [1.0, 1j, 1j * a, -1.0, -1j, -1j * bb, g]
        return [[0.0, 0.0, _dot(1j * g, n), 0.0, 0.0, _dot(g, 1j * n), _dot(h, n)],
                [_dot(x, n) for x in dd[:5]] + [_dot(dd[5], n) + _dot(d, 1j * n), _dot(g, n)]]
    return phi, grad, None


PORTABLE = (evaluate, _piece, offset_functions, user_functions, _frame, _dot, distance_driver, rack_pinion, _contact,
            point_on_curve, cam_roller, cam_flat)


class _Recorder:
    """A MainSystem that also keeps every item added, in order, for kinem export."""

    def __init__(self, mbs):
        self.real, self.items = mbs, []

    def __getattr__(self, name):
        return getattr(self.real, name)

    def _add(self, method, item):
        self.items.append((method, item))
        return getattr(self.real, method)(item)

    def AddNode(self, item):  # noqa: N802 - Exudyn's names
        return self._add("AddNode", item)

    def AddObject(self, item):  # noqa: N802
        return self._add("AddObject", item)

    def AddMarker(self, item):  # noqa: N802
        return self._add("AddMarker", item)

    def AddSensor(self, item):  # noqa: N802
        return self._add("AddSensor", item)


def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


def _unit(v):
    v = np.asarray(v, float)
    return v / np.hypot(*v)


def _perp(u):
    return [-float(u[1]), float(u[0]), 0.0]


class _Build:
    """One mechanism in one Exudyn MainSystem."""

    def __init__(self, model, q0, qd0, symbolic, record=False):
        self.model, self.q0, self.qd0 = model, np.asarray(q0, float), np.asarray(qd0, float)
        self.symbolic = symbolic
        self.keep = []  # symbolic user functions must outlive the solve
        # record (kinem export): every item added (mbs.items) and, per user
        # function made, how the portable functions make it: (call, functions)
        self.made = []
        self.sc = exu.SystemContainer()
        self.system = self.sc.AddSystem()
        self.mbs = _Recorder(self.system) if record else self.system
        self.col = {b: 3 * k for k, b in enumerate(model.body_names)}
        self.fixed = grounded(model)
        self.node, self.body = {}, {}
        self.theta = {}   # the model's column of each outline angle -> its node
        mass, inertia = mass_properties(model)
        mbs = self.mbs
        for k, b in enumerate(model.body_names):
            x, y, phi = self.q0[3 * k: 3 * k + 3]
            if b in self.fixed:
                self.body[b] = mbs.AddObject(ei.ObjectGround(referencePosition=[x, y, 0.0],
                                                             referenceRotation=_rot(phi)))
            else:
                self.node[b] = mbs.AddNode(ei.NodeRigidBody2D(
                    referenceCoordinates=[0.0, 0.0, 0.0], initialCoordinates=[x, y, phi],
                    initialVelocities=self.qd0[3 * k: 3 * k + 3].tolist()))
                self.body[b] = mbs.AddObject(ei.ObjectRigidBody2D(mass=mass[k], inertia=inertia[k],
                                                                  nodeNumber=self.node[b]))
        self.mass = dict(zip(model.body_names, zip(mass, inertia)))
        self.ground_node = mbs.AddNode(ei.NodePointGround())
        self.zero = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=self.ground_node, coordinate=0))
        self.world = None

    # -- markers ------------------------------------------------------------
    def position(self, b, s):
        return self.mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=self.body[b], localPosition=[s[0], s[1], 0.0]))

    def rigid(self, b, s):
        return self.mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=self.body[b], localPosition=[s[0], s[1], 0.0]))

    def coordinate(self, b, k):
        """Marker on coordinate k (0 x, 1 y, 2 phi) of body b and its value
        at t = 0 as the marker reads it (a fixed body reads the ground's 0)."""
        if b in self.fixed:
            return self.zero, 0.0
        marker = self.mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=self.node[b], coordinate=k))
        return marker, self.q0[self.col[b] + k]

    def world_rigid(self, s):
        if self.world is None:
            self.world = self.mbs.AddObject(ei.ObjectGround())
        return self.mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=self.world, localPosition=[s[0], s[1], 0.0]))

    # -- constraints --------------------------------------------------------
    def coupling(self, a, b, factor=1.0, offset=0.0, f=None):
        """factor * q_b - q_a = offset (+ d(t)): Exudyn's CoordinateConstraint
        (it acts on the coordinates without reference values: here absolute)."""
        if f is None:
            return self.mbs.AddObject(ei.CoordinateConstraint(markerNumbers=[a, b], factor1=factor, offset=offset))
        d, d_t = offset_functions(self.system, f.spec, offset, self.symbolic)
        self.keep += [d, d_t]
        self.made.append((f"offset_functions(mbs, {f.spec!r}, {offset!r}, {self.symbolic!r})", (d, d_t)))
        return self.mbs.AddObject(ei.CoordinateConstraint(markerNumbers=[a, b], factor1=factor,
                                                          offsetUserFunction=d, offsetUserFunction_t=d_t))

    def prismatic(self, m0, m1, axis0, normal1, rotation):
        self.mbs.AddObject(ei.ObjectJointPrismatic2D(markerNumbers=[m0, m1], axisMarker0=list(axis0),
                                                     normalMarker1=list(normal1), constrainRotation=rotation))

    def _span(self, bodies, extra=()):
        """Markers [dummy ground, all node coordinates of the moving bodies
        and of the ``extra`` one-coordinate nodes] (a massless
        ObjectGenericODE2 spans their nodes), the places of those coordinates
        in z = (x, y, phi of each body in order, then each extra node's), and
        z at t = 0."""
        moving = [b for b in bodies if b not in self.fixed]
        z0 = [float(v) for b in bodies for v in self.q0[self.col[b]: self.col[b] + 3]]
        slots = [3 * k + j for k, b in enumerate(bodies) if b not in self.fixed for j in range(3)]
        slots += [len(z0) + k for k in range(len(extra))]
        z0 += [float(self.q0[col]) for col in extra]
        nodes = [self.node[b] for b in moving] + [self.theta[col] for col in extra]
        span = self.mbs.AddObject(ei.ObjectGenericODE2(nodeNumbers=nodes,
                                                       massMatrix=exu.MatrixContainer(np.zeros((len(slots),) * 2))))
        markers = [self.mbs.AddMarker(ei.MarkerNodeCoordinates(nodeNumber=self.ground_node)),
                   self.mbs.AddMarker(ei.MarkerObjectODE2Coordinates(objectNumber=span))]
        return markers, slots, z0

    def linear(self, bodies, row):
        """row . z = its value at t = 0: a built-in linear ObjectConnectorCoordinateVector
        (X q = offset); fixed bodies' terms go into the offset."""
        markers, slots, z0 = self._span(bodies)
        fixed = sum(r * v for k, (r, v) in enumerate(zip(row, z0)) if k not in slots)
        self.mbs.AddObject(ei.ObjectConnectorCoordinateVector(
            markerNumbers=markers, scalingMarker0=np.zeros((1, 0)), scalingMarker1=[[row[k] for k in slots]],
            offset=[sum(r * v for r, v in zip(row, z0)) - fixed]))

    def angle(self, col):
        """A NodeGenericODE2 for the model's artificial coordinate ``col``
        (an outline's angle theta), started at its value and rate; no mass of
        its own (the constraints that hold it determine it)."""
        self.theta[col] = self.mbs.AddNode(ei.NodeGenericODE2(
            referenceCoordinates=[0.0], initialCoordinates=[float(self.q0[col])],
            initialCoordinates_t=[float(self.qd0[col])], numberOfODE2Coordinates=1))
        return col

    def user(self, bodies, factory, *args, extra=(), rows=1):
        """``rows`` user constraint equations phi(z, t) = 0 over z (x, y,
        phi of each of ``bodies``, then the ``extra`` artificial coordinates)
        with phi, its gradient and its time derivative from factory(*args)
        (distance_driver, rack_pinion, point_on_curve, cam_roller,
        cam_flat); fixed bodies enter z with their constant pose. The user
        functions run at every Newton iteration: plain Python floats."""
        markers, slots, z0 = self._span(bodies, extra)
        constraint, jacobian = user_functions(*factory(*args), slots, z0)
        self.made.append((f"user_functions(*{factory.__name__}{tuple(args)!r}, {slots!r}, {z0!r})",
                          (constraint, jacobian)))
        self.mbs.AddObject(ei.ObjectConnectorCoordinateVector(
            markerNumbers=markers, scalingMarker0=np.zeros((rows, len(slots))),
            constraintUserFunction=constraint, jacobianUserFunction=jacobian))


class ExudynAdapter(Adapter):
    name = "exudyn"
    tolerance = TOLERANCE
    knobs = {"integrator": tuple(INTEGRATORS), "substeps": (1, 2, 5, 10, 20, 50, 100)}
    # velocity errors on the book's four-bar fell 2.9x, 8.2x and 53x per halving of dt from 1e-3 (the
    # start-up transient, damped by spectral_radius, dominates): refined as third order
    order = 3
    rate_steps = (2e-4, 4e-4, 8e-4, 1.2e-3, 1.6e-3)   # rate_step values the tuning sweep tries (dt auto)
    checks = {"dt": step_or_auto, "rate_step": positive, "substeps": count_or_none,
              "integrator": choice(*INTEGRATORS),
              "spectral_radius": fraction, "newton_test": choice(*NEWTON_TESTS),
              "newton_relative_tolerance": nonnegative, "newton_absolute_tolerance": nonnegative,
              "newton_max_iterations": count, "modified_newton": boolean, "symbolic_drivers": boolean,
              "linear_solver": choice(*SOLVERS), "adaptive_step": boolean}
    supports = SUPPORTS
    reasons = REASONS

    def version(self) -> str:
        return exu.config.Version()

    def defaults(self) -> dict:
        return {
            # Step. Positions do not depend on it (index 3): round-off at one
            # step per output interval. The velocity error is O(dt^2) (faster
            # where the start-up transient dominates) and decides. "auto":
            # rate_step / the mechanism's fastest rate (adapters.base.rate_scale),
            # so the same mechanism at any speed gets the same errors; then
            # checked by the engine's own error figures (adapters.base.self_check:
            # the velocity residual carried to the coordinates) and refined until
            # within TOLERANCE or the cost cap. A step costs ~10-40 us.
            "dt": "auto",
            # rate x step of dt = "auto": the first attempt, refined by the
            # self-check (docs/engines.md, "Settings chosen from the mechanism").
            "rate_step": 1.2e-3,
            # Steps per output interval; None: the fewest keeping step <= dt.
            "substeps": None,
            # Index-3 generalized-alpha: constraints held at position level.
            "integrator": "generalized-alpha",
            # Exudyn's default and the best of 0 .. 1 tried: 1.0 (no damping)
            # never damps the start-up error of Exudyn's initial accelerations
            # (they ignore d''(0)): velocity error x13 on quick_return_1;
            # 0.95 x3-8 on four_bar; 0.5 x1.3; 0 x4. Index 3 needs < 1.
            "spectral_radius": 0.9,
            # Newton's convergence test on the increment of the coordinates
            # (Exudyn's residualMode 1, which its docs suggest for kinematic
            # problems), not on the residual: the residual norm mixes inertia
            # and constraint forces and stalls at their round-off (~1e-10 in
            # the mm cases at dt = 1e-4), so quick_return_1 failed at t = 0.855
            # with Exudyn's default test and tolerances. Newton converges
            # quadratically: once an increment is below 1e-10 (length units;
            # a relative 1e-10 of the first increment also counts, Exudyn
            # wants both equal in this mode) the coordinates are at round-off.
            # Checked on the cases scaled to L = 0.55 .. 6.6e4 length units.
            "newton_test": "increment",
            "newton_relative_tolerance": 1e-10,
            "newton_absolute_tolerance": 1e-10,
            "newton_max_iterations": 25,
            # Full Newton (a fresh Jacobian each iteration): quadratic, so the
            # increment test leaves round-off. Modified Newton converges
            # linearly and stops up to ~1e-10 units short: four_bar 1e-11 of L
            # and velocities x300 worse, for ~30% less time (noisy timings).
            "modified_newton": False,
            # Driver functions as Exudyn symbolic user functions, evaluated in
            # C++. A Python offset function is called ~8 times per step: the
            # slider-crank took 34 us/step with it, 10 with a constant offset;
            # symbolic ones cost about half the Python ones. Same expressions
            # either way; False: Python user functions.
            "symbolic_drivers": True,
            # Dense LU (tens of coordinates). "EigenDense" runs with
            # ignoreSingularJacobian: it also solves consistent redundant
            # constraints (cases/stress/double_slider, parallelogram_redundant)
            # and passes the change point of cases/stress/change_point, where
            # "EXUdense" stops with a singular Jacobian, but costs ~1.5x per
            # step. "auto": EigenDense when the model has more equations than
            # coordinates (redundant constraints), else EXUdense.
            "linear_solver": "auto",
            # Fixed steps, so that every output instant is a step end and a
            # step failure is reported rather than hidden by step reduction.
            "adaptive_step": False,
        }

    def unsupported(self, model) -> Reason | None:
        why = super().unsupported(model)
        if why:
            return why
        fixed = grounded(model)
        for d in drives(model):
            if d.body in fixed:
                return Reason("driver", d.name, f"on body '{d.body}', which a 'ground' constraint fixes")
        for c in model.case.constraints:
            if c.type == "absolute" and c["body"] in fixed:
                return Reason("absolute", c.name, f"on body '{c['body']}', which a 'ground' constraint fixes")
        return None

    # -- run -------------------------------------------------------------------
    def build(self, model, q0, qd0, s, times, record=False):
        """(the assembled _Build, its sensors {body: (coordinates, velocities)},
        the SimulationSettings) for checked settings s (substeps resolved)."""
        interval = float(times[1] - times[0]) if len(times) > 1 else float(times[-1])
        b = _Build(model, q0, qd0, bool(s["symbolic_drivers"]), record)
        self._constraints(b, model)
        sensors = {name: [b.mbs.AddSensor(ei.SensorNode(nodeNumber=n, storeInternal=True, writeToFile=False,
                                                        outputVariableType=v))
                          for v in (exu.OutputVariableType.Coordinates, exu.OutputVariableType.Coordinates_t)]
                   for name, n in b.node.items()}
        b.angles = {col: [b.mbs.AddSensor(ei.SensorNode(nodeNumber=n, storeInternal=True, writeToFile=False,
                                                        outputVariableType=v))
                          for v in (exu.OutputVariableType.Coordinates, exu.OutputVariableType.Coordinates_t)]
                    for col, n in b.theta.items()}
        b.mbs.Assemble()
        return b, sensors, self._simulation(s, times, s["substeps"], interval, model.m > model.n)

    def simulate(self, model, q0, qd0, s, times):
        saved = exu.config.printToConsole
        exu.config.printToConsole = False   # the solver prints its failure reports
        try:
            b, sensors, ss = self.build(model, q0, qd0, s, times)
        except Exception as e:  # noqa: BLE001 - Exudyn raises plain exceptions on a bad model
            raise Failure(Status.FAILED, f"{type(e).__name__}: {e}") from None
        finally:
            exu.config.printToConsole = saved
        until, stopped = deadline(), []
        if until < math.inf:   # compare --max-seconds: the solver asks before every step (one Python call a step)
            def ask(mbs, t):
                if time.time() <= until:
                    return True
                stopped.append(t)
                return False    # Exudyn stops after this step
            b.mbs.SetPreStepUserFunction(ask)
        exu.config.printToConsole = False
        try:
            start = time.perf_counter()     # one solver call for the whole run
            try:
                ok = b.mbs.SolveDynamic(ss, solverType=getattr(exu.DynamicSolverType, INTEGRATORS[s["integrator"]]))
                error = ""
            except Exception as e:  # noqa: BLE001 - the solver raises on failure
                ok, error = False, f"{type(e).__name__}: {e}"
            wall = time.perf_counter() - start
        finally:
            exu.config.printToConsole = saved
        solver = b.mbs.sys.get("dynamicSolver")
        steps = max(int(solver.it.currentStepIndex) - 1, 0) if solver is not None else 0
        if stopped:
            in_time(stopped[0], steps, wall)
        if not ok:
            detail = solver.GetErrorString().strip() if solver is not None else ""
            at = f"Exudyn solver stopped at t = {solver.it.currentTime:.6g}: " if solver is not None else ""
            raise Failure(Status.FAILED, at + (detail or error or "no convergence"), steps)
        return self._collect(model, b, sensors, times, wall, steps)

    def _simulation(self, s, times, sub, interval, redundant):
        solver = s["linear_solver"] if s["linear_solver"] != "auto" else ("EigenDense" if redundant else "EXUdense")
        ss = exu.SimulationSettings()
        ti = ss.timeIntegration
        ti.startTime = 0.0
        ti.endTime = float(times[-1])
        ti.numberOfSteps = sub * (len(times) - 1)
        ti.verboseMode = 0
        ti.adaptiveStep = bool(s["adaptive_step"])
        ti.generalizedAlpha.spectralRadius = float(s["spectral_radius"])
        ti.newton.relativeTolerance = float(s["newton_relative_tolerance"])
        ti.newton.absoluteTolerance = float(s["newton_absolute_tolerance"])
        ti.newton.maxIterations = int(s["newton_max_iterations"])
        ti.newton.useModifiedNewton = bool(s["modified_newton"])
        ti.newton.residualMode = NEWTON_TESTS[s["newton_test"]]
        ss.solution.file.write = False
        ss.solution.sensors.writePeriod = float(interval)
        ss.linearSolver.solverType = getattr(exu.LinearSolverType, solver)
        ss.linearSolver.ignoreSingularJacobian = solver == "EigenDense"
        return ss

    def _collect(self, model, b, sensors, times, wall, steps):
        nt = len(times)
        Q = np.zeros((nt, model.n))
        QD = np.zeros((nt, model.n))
        Q[:, : len(b.q0)] = b.q0  # fixed bodies stay at their pose, at rest
        for name, (sq, sv) in sensors.items():
            k = b.col[name]
            pos, vel = b.mbs.GetSensorStoredData(sq), b.mbs.GetSensorStoredData(sv)
            if pos.shape[0] != nt or np.abs(pos[:, 0] - times).max() > 1e-9 * max(times[-1], 1.0):
                raise Failure(Status.FAILED, f"sensors sampled {pos.shape[0]} instants, not the {nt} output "
                              "instants", steps)
            Q[:, k: k + 3] = pos[:, 1:4]
            QD[:, k: k + 3] = vel[:, 1:4]
        for col, (sq, sv) in b.angles.items():   # the outline angles theta
            Q[:, col] = b.mbs.GetSensorStoredData(sq)[:, 1]
            QD[:, col] = b.mbs.GetSensorStoredData(sv)[:, 1]
        return Q, QD, wall, steps

    # -- constraints -------------------------------------------------------------
    def _constraints(self, b, model):
        for c in model.case.constraints:
            getattr(self, "_" + c.type.replace("-", "_"))(b, c)

    def _ground(self, b, c):
        pass  # the body is an ObjectGround (see _Build)

    def _absolute(self, b, c):
        k = {"x": 0, "y": 1, "phi": 2}[c["coord"]]
        if c.get("point") is None:
            m, _ = b.coordinate(c["body"], k)
            b.coupling(b.zero, m, offset=c["value"])
            return
        # the point stays on the fixed line x = value (or y = value)
        at = [c["value"], 0.0] if k == 0 else [0.0, c["value"]]
        normal = [1.0, 0.0, 0.0] if k == 0 else [0.0, 1.0, 0.0]
        b.prismatic(b.rigid(c["body"], c["point"]), b.world_rigid(at), _perp(normal), normal, False)

    def _revolute(self, b, c):
        b.mbs.AddObject(ei.ObjectJointRevolute2D(markerNumbers=[b.position(c["i"], c["si"]),
                                                                b.position(c["j"], c["sj"])]))

    def _revolute_revolute(self, b, c):
        b.mbs.AddObject(ei.ObjectConnectorDistance(markerNumbers=[b.position(c["i"], c["si"]),
                                                                  b.position(c["j"], c["sj"])],
                                                   distance=float(c["length"])))

    def _translational(self, b, c):
        # Line P_i Q_i on body i (marker 1: Exudyn's normal lives there); the
        # axis seen from body j is the line direction turned by phi0 = phi_i - phi_j.
        u = _unit(np.subtract(c["qi"], c["si"]))
        a = c["phi0"]
        uj = [math.cos(a) * u[0] - math.sin(a) * u[1], math.sin(a) * u[0] + math.cos(a) * u[1], 0.0]
        b.prismatic(b.rigid(c["j"], c["sj"]), b.rigid(c["i"], c["si"]), uj, _perp(u), True)

    def _revolute_translational(self, b, c):
        u = _unit(np.subtract(c["qj"], c["sj"]))
        b.prismatic(b.rigid(c["i"], c["si"]), b.rigid(c["j"], c["sj"]), [u[0], u[1], 0.0], _perp(u), False)

    def _driver(self, b, c):
        f = _Function(c["d"])
        k = {"x": 0, "y": 1, "phi": 2}[c["coord"]]
        body, rel = c["body"], c.get("relative_to")
        if rel is not None:  # phi_body - phi_rel = d(t); a fixed rel's marker reads 0, not its angle
            mr, vr = b.coordinate(rel, 2)
            m, _ = b.coordinate(body, 2)
            b.coupling(mr, m, offset=b.q0[b.col[rel] + 2] - vr, f=f)
            return
        if c.get("point") is None:
            m, _ = b.coordinate(body, k)
            b.coupling(b.zero, m, f=f)
            return
        # Point form: a helper body H whose x (y) follows d(t), y (x) and phi
        # held at 0; the point stays on H's line x = x_H (y = y_H).
        init = [0.0, 0.0, 0.0]
        vel = [0.0, 0.0, 0.0]
        init[k], vel[k] = f.value(0.0), f.value(0.0, 1)
        mass, inertia = b.mass[body]
        n = b.mbs.AddNode(ei.NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0], initialCoordinates=init,
                                             initialVelocities=vel))
        h = b.mbs.AddObject(ei.ObjectRigidBody2D(mass=mass, inertia=inertia, nodeNumber=n))
        for j in range(3):
            mj = b.mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=n, coordinate=j))
            b.coupling(b.zero, mj, f=f if j == k else None)
        normal = [1.0, 0.0, 0.0] if k == 0 else [0.0, 1.0, 0.0]
        mh = b.mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=h, localPosition=[0.0, 0.0, 0.0]))
        b.prismatic(b.rigid(body, c["point"]), mh, _perp(normal), normal, False)

    def _distance_driver(self, b, c):
        b.user([c["i"], c["j"]], distance_driver, complex(*c["si"]), complex(*c["sj"]), function_spec(c["d"]))

    def _gear(self, b, c):
        # rho_i (phi_i - phi_k) + sigma rho_j (phi_j - phi_k) = const (Eqs.
        # 4.17, 4.18), sigma = -1 for an internal gear; const from the start.
        ri, rj = float(c["ri"]), float(c["rj"]) * (-1.0 if c.get("internal") else 1.0)
        k = c.get("carrier")
        if k is None or k in b.fixed:
            mi, vi = b.coordinate(c["i"], 2)
            mj, vj = b.coordinate(c["j"], 2)
            if c["i"] in b.fixed:  # phi_j alone then: rho_j phi_j = const
                b.coupling(mi, mj, offset=vj - vi)
                return
            factor = -rj / ri   # phi_i = factor phi_j - offset
            b.coupling(mi, mj, factor=factor, offset=factor * vj - vi)
            return
        b.linear([c["i"], c["j"], k], [0.0, 0.0, ri, 0.0, 0.0, rj, 0.0, 0.0, -(ri + rj)])

    def _rack_pinion(self, b, c):
        # u.(C - P) + rho (phi_i - phi_j) = const, const from the start
        args = [complex(*c.get("center", (0.0, 0.0))), complex(*c["sj"]),
                complex(*_unit(c.get("u", (1.0, 0.0)))), float(c["radius"])]
        bodies = [c["pinion"], c["rack"]]
        z0 = [float(v) for x in bodies for v in b.q0[b.col[x]: b.col[x] + 3]]
        b.user(bodies, rack_pinion, *args, rack_pinion(*args, 0.0)[0](z0, 0.0)[0])

    def _curve(self, b, c, outline_body, other, factory, *args):
        """A two-row curve constraint (factory: point_on_curve, cam_roller,
        cam_flat) on the outline body, the other body and the constraint's
        angle theta (its own node)."""
        col = b.angle(b.model.coordinate_names.index(f"{c.name}.theta"))
        b.user([outline_body, other], factory, c["outline"], *args, extra=[col], rows=2)

    def _cam_point(self, b, c):
        self._curve(b, c, c["cam"], c["follower"], point_on_curve, complex(*c["sj"]))

    def _point_follower(self, b, c):
        self._curve(b, c, c["j"], c["i"], point_on_curve, complex(*c["si"]))

    def _cam_roller(self, b, c):
        self._curve(b, c, c["cam"], c["follower"], cam_roller, complex(*c["sj"]), float(c["radius"]))

    def _cam_flat(self, b, c):
        n = complex(*c["normal"])
        self._curve(b, c, c["cam"], c["follower"], cam_flat, complex(*c["sj"]), n / abs(n))


ADAPTER = ExudynAdapter()
