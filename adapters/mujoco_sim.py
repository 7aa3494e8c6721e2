"""MuJoCo adapter: the mechanism as a kinematic tree of hinges and slides in
the plane z = 0, its loops closed by soft equality constraints
(docs/engines/mujoco.md).

MuJoCo has no 2-D mode: every joint here is a hinge about z or a slide in
the xy plane. A joint of the tree is exact (its coordinate is the motion);
an equality is soft (a spring-damper on its residual, time constant
solref[0]). So the tree takes as many of the case's constraints as it can:
the joints that carry a driven coordinate first, then translational,
revolute, revolute-translational and absolute constraints. Ground bodies
are static children of the world; a body the tree does not reach is free in
the plane (slide x, slide y, hinge z). Each other constraint closes a loop:
  revolute                connect between two sites
  translational,          a helper body with the constraint's tree joints,
  revolute-translational, under the other body, welded to this one
  absolute
  revolute-revolute       a link body hinged at P_i, its tip connected to P_j
  distance-driver         the same link with a driven slide along it
  gear                    joint equality (linear) between two hinges that
                          measure the gears' angles relative to the carrier
  rack-pinion             helper at the pinion's centre under the rack
                          (slides along and across the line, hinge), welded
                          to the pinion; joint equality slide = -radius hinge
MuJoCo 4 adds the curvature term Jdot v to the reference acceleration of
connect and weld only, so every nonlinear loop is closed by one of those two
(a tendon equality for revolute-revolute: 26x the error on quick_return_3);
joint equalities are linear (Jdot = 0). The model is written in the pose q0:
every joint coordinate is 0 at the start and every equality holds at qpos0.
Body frames are the case's frames, centre of mass at the body origin.

Driving: the driven joint has a huge armature; before every mj_step its qpos
and qvel are set from d(t), d'(t), and a generalised force armature * d''(t)
gives it the driver's acceleration within the step, so reaction forces do
not move it (engines.md: mocap bodies and per-step equality offsets lag by
O(dt)).
"""
import time
from xml.sax.saxutils import quoteattr

import numpy as np


from kinem.functions import Poly

from .base import (Adapter, Drive, Failure, Reason, Status, boolean, choice, count, count_or_none, drive_table, drives,
                   finite, grounded, in_time, mass_properties, nonnegative, numbers, positive,
                   positive_or_none, step_or_auto)

# Each self-check figure's order in the step (adapters.base.refine), measured on
# generated slider-cranks, four-bars and quick-returns at 1-32 steps per output
# interval (docs/engines.md): positions and angles follow the loop equalities'
# residual r ~ (rate x tc)^2 with tc = solref[0] = 3 dt, so dt^2; velocities
# its rate, ~ r / tc, so dt^1 (slopes 0.94-1.0 from 8 to 32 steps).
ORDER = {"position_error_rel": 2, "angle_error": 2, "velocity_error_rel": 1, "angular_velocity_error_rel": 1}
# The armatures above are absolute (kg m^2 in the case's units): a mechanism
# 1000x larger has 1e6x the inertia, and its driven joint then yields to the
# reactions (a quick-return at 1000x its size diverged). Beyond a largest body
# inertia of ARMATURE_INERTIA (above every case of the repository, which keep
# their armature) the armature grows with it.
ARMATURE_INERTIA = 1e6
HELD_ARMATURE = 1e12  # driven joints' armature when set only at output instants (defaults: "armature")
WORLD = "@world"      # '@' and ':' never occur in a case's names
TREE_TYPES = ("translational", "revolute", "revolute-translational", "absolute")  # preference order

# Errors the tests accept at the default settings. A loop-closing equality
# lags its kinematic motion by a residual r that the measurements fit as
# r / L <~ 1.5e-3 (omega tc)^2 (tc = solref[0] = 3 dt = 7.5e-4 s, omega the
# crank speed, <= 3 rad/s in the cases), i.e. <~ 7.5e-9; the worst measured
# over the five cases is 6.7e-9 (docs/engines/mujoco.md). The bounds allow
# 15x that (a driver 4x faster) and stay 100x below the issue's 1e-5.
# position: / model.length; angle: rad; velocity: linear / model.length and
# angular, per second (measured worst 2.3e-6; the residual's rate ~ r / tc).
# In the harness's figures (adapters/compare.py): velocity_error_rel divides by
# the characteristic speed >= L max|omega|, so 3e-5 /s over omega >= 1 rad/s
# is the same bound or looser. (That was the error at a fixed 2.5e-4 s step; dt =
# "auto" now runs each mechanism at the step its self-check finds within these.)
TOLERANCE = {"position_error_rel": 1e-7, "angle_error": 1e-7, "velocity_error_rel": 3e-5,
             "angular_velocity_error_rel": 3e-5}


def _rot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def _num(x):
    return repr(float(x))


def _vec(v):
    return f"{_num(v[0])} {_num(v[1])} 0"


class Plan:
    """How a model in the pose q0 becomes MuJoCo bodies, joints and
    equalities. ``problem`` says why it cannot (else None).

    bodies:    (name, parent, world position, angle, joints, case body or None),
               parents before children; joints are (kind, point, axis) in the
               body's frame, in MuJoCo's order (each moves the frame the next
               sees); None: static
    equality:  ("connect" | "weld", (body, point), (body, point)): two sites
               ("joint", (body, joint number), ((body, joint number) or None, polycoef))
    driven:    (Drive, body, joint number, a, v0): joint coordinate = a (d(t) - v0)
    """

    def __init__(self, model, q0, tree="spanning"):
        """tree: "spanning" (a tree of joints, loops closed by equalities) or
        "free" (every body free in the plane, every constraint an equality)."""
        self.model = model
        self.names = list(model.body_names)
        self.index = {b: k for k, b in enumerate(self.names)}
        self.q0 = np.asarray(q0, float)
        self.ground = grounded(model)
        self.problem = None
        self.bodies, self.equality, self.driven = [], [], []
        self.count = 0
        self._build(tree)

    # -- geometry at q0 ------------------------------------------------------
    def pose(self, body):
        if body == WORLD:
            return np.zeros(2), 0.0
        k = 3 * self.index[body]
        return self.q0[k:k + 2], self.q0[k + 2]

    def world(self, body, s):
        r, phi = self.pose(body)
        return r + _rot(phi) @ np.asarray(s, float)

    def local(self, body, p):
        r, phi = self.pose(body)
        return _rot(-phi) @ (np.asarray(p, float) - r)

    def direction(self, body, u):
        """A world direction in the body's frame, unit length."""
        v = _rot(-self.pose(body)[1]) @ np.asarray(u, float)
        return v / np.linalg.norm(v)

    def line(self, c):
        """World unit direction of a translational or revolute-translational line."""
        b, s, q = (c["i"], c["si"], c["qi"]) if c.type == "translational" else (c["j"], c["sj"], c["qj"])
        u = self.world(b, q) - self.world(b, s)
        return u / np.linalg.norm(u)

    @staticmethod
    def ends(c):
        """The two bodies of a constraint; (child, parent) when it is a tree edge or helper."""
        if c.type == "absolute":
            return c["body"], WORLD
        return (c["pinion"], c["rack"]) if c.type == "rack-pinion" else (c["i"], c["j"])

    def joints(self, c, child):
        """The joints that leave ``child`` the freedom constraint c gives it
        relative to the other body (None: free in the plane)."""
        z = (0.0, 0.0)
        if c is None:
            return [("slide", z, self.direction(child, (1, 0))), ("slide", z, self.direction(child, (0, 1))),
                    ("hinge", z, None)]
        if c.type == "revolute":
            return [("hinge", c["si"] if child == c["i"] else c["sj"], None)]
        if c.type == "translational":
            return [("slide", z, self.direction(child, self.line(c)))]
        if c.type == "revolute-translational":
            u = self.direction(child, self.line(c))
            if child == c["i"]:                         # the pin slides along the line, then turns
                return [("slide", z, u), ("hinge", c["si"], None)]
            pin = self.local(child, self.world(c["i"], c["si"]))
            return [("hinge", pin, None), ("slide", z, u)]  # the line turns about the pin, then slides
        if c["coord"] == "phi":                         # absolute
            return [("slide", z, self.direction(child, (1, 0))), ("slide", z, self.direction(child, (0, 1)))]
        across = (0, 1) if c["coord"] == "x" else (1, 0)
        return [("slide", z, self.direction(child, across)), ("hinge", c.get("point") or z, None)]

    # -- building --------------------------------------------------------------
    def _name(self, prefix):
        self.count += 1
        return f"{prefix}:{self.count}"

    def _build(self, tree):
        cons = [c for c in self.model.case.constraints if c.type not in ("ground", "driver")]
        forced = []                                     # (Drive, constraint) whose joint is driven
        if tree == "spanning":
            for dr in drives(self.model):
                c = self._drive_edge(dr, cons)
                if c is None:
                    return
                forced.append((dr, c))
        edges = self._spanning(cons, [c for _, c in forced]) if tree == "spanning" else []
        if self.problem:
            return
        parent = self.parent = self._orient(edges)
        for b in self.names:                            # parents before children
            self._add_case_body(b, parent)
        for c in cons:
            if c in edges or all(b in self.ground or b == WORLD for b in self.ends(c)):
                continue
            self._close(c)
        for dr in drives(self.model):
            self._map_drive(dr, dict(forced).get(dr), parent)

    def _spanning(self, cons, first):
        """A spanning forest: driven joints first, then by TREE_TYPES order."""
        up = {b: b for b in self.names + [WORLD]}
        for b in self.ground:
            up[b] = WORLD

        def root(b):
            while up[b] != b:
                b = up[b]
            return b

        rank = {t: k for k, t in enumerate(TREE_TYPES)}
        order = first + sorted((c for c in cons if c.type in rank and c not in first), key=lambda c: rank[c.type])
        edges = []
        for c in order:
            ra, rb = (root(b) for b in self.ends(c))
            if ra == rb:
                if c in first:
                    self.problem = Reason(c.type, c.name, "a driven joint that closes a loop of driven joints")
                    return []
                continue
            if ra == WORLD:
                ra, rb = rb, ra
            up[ra] = rb
            edges.append(c)
        return edges

    def _orient(self, edges):
        """body -> (parent, constraint): outwards from the ground; a body left
        over roots a floating part and is free in the plane."""
        parent = {b: (WORLD, None) for b in self.ground}
        frontier = [WORLD] + [b for b in self.names if b in self.ground]
        while len(parent) < len(self.names):
            while frontier:
                p = frontier.pop(0)
                for c in edges:
                    a, b = self.ends(c)
                    ch = b if a == p else a if b == p else None
                    if ch is not None and ch != WORLD and ch not in parent:
                        parent[ch] = (p, c)
                        frontier.append(ch)
            rest = [b for b in self.names if b not in parent]
            if rest:
                parent[rest[0]] = (WORLD, None)
                frontier = [rest[0]]
        return parent

    def _add_case_body(self, b, parent):
        if any(x[0] == b for x in self.bodies):
            return
        p, c = parent[b]
        if p != WORLD:
            self._add_case_body(p, parent)
        r, phi = self.pose(b)
        joints = None if b in self.ground else self.joints(c, b)
        self.bodies.append((b, p, r, phi, joints, b))

    def _close(self, c):
        if c.type == "revolute":
            self.equality.append(("connect", (c["i"], c["si"]), (c["j"], c["sj"])))
        elif c.type in ("revolute-revolute", "distance-driver"):
            # a link hinged at P_i, pointing at P_j, its tip (at the length) connected
            # to P_j; for a distance driver the tip slides along the link, driven
            pi, pj = self.world(c["i"], c["si"]), self.world(c["j"], c["sj"])
            d = pj - pi
            h = self._name("link")
            joints = [("hinge", (0.0, 0.0), None)]
            tip = c["length"] if c.type == "revolute-revolute" else np.hypot(*d)
            if c.type == "distance-driver":
                joints.append(("slide", (0.0, 0.0), (1.0, 0.0)))
                self.driven.append((Drive(c.name, c["i"], "distance", None, None, c["d"]), h, 1, 1.0, tip))
            self.bodies.append((h, c["i"], pi, np.arctan2(d[1], d[0]), joints, None))
            self.equality.append(("connect", (h, (tip, 0.0)), (c["j"], c["sj"])))
        elif c.type == "gear":
            # rho_i (phi_i - phi_k) + sigma rho_j (phi_j - phi_k) = const, k the carrier
            # (none: the world), each relative angle a hinge coordinate: a joint equality
            k = c.get("carrier") or WORLD
            ai, aj = self._angle_joint(c["i"], k), self._angle_joint(c["j"], k)
            sigma = -1.0 if c.get("internal") else 1.0
            if ai is not None and aj is None:           # theta_i = 0
                self.equality.append(("joint", ai[:2], (None, (0.0,) * 5)))
            elif aj is not None:                        # theta_j = -(rho_i s_i) / (sigma rho_j s_j) theta_i
                ratio = 0.0 if ai is None else -c["ri"] * ai[2] / (sigma * c["rj"] * aj[2])
                self.equality.append(("joint", aj[:2], (ai[:2] if ai else None, (0.0, ratio, 0.0, 0.0, 0.0))))
        elif c.type == "rack-pinion":
            # u . (C - P) + rho (phi_i - phi_j) = const: a helper under the rack at the
            # pinion's centre, sliding along u and across it and turning, welded to the pinion
            i, j = c["pinion"], c["rack"]
            h = self._name("helper")
            u = _rot(self.pose(j)[1]) @ np.asarray(c["u"], float)
            z = (0.0, 0.0)
            joints = [("slide", z, self.direction(i, u)), ("slide", z, self.direction(i, (-u[1], u[0]))),
                      ("hinge", z, None)]
            self.bodies.append((h, j, self.world(i, c["center"]), self.pose(i)[1], joints, None))
            self.equality.append(("weld", (h, (0.0, 0.0)), (i, c["center"])))
            self.equality.append(("joint", (h, 0), ((h, 2), (0.0, -c["radius"], 0.0, 0.0, 0.0))))
        else:
            child, parent = self.ends(c)
            h = self._name("helper")
            r, phi = self.pose(child)
            self.bodies.append((h, parent, r, phi, self.joints(c, child), None))
            self.equality.append(("weld", (h, (0.0, 0.0)), (child, (0.0, 0.0))))

    def _angle_joint(self, x, k):
        """(body, joint number, sign) of a hinge whose coordinate is
        sign (phi_x - phi_k) + const; None if that angle is constant. A helper
        free in the plane under k, welded to x, gives one where the tree does not."""
        static = self.ground | {WORLD}
        if x == k or (x in static and k in static):
            return None
        for child, other, sign in ((x, k, 1.0), (k, x, -1.0)):
            if child in static:
                continue
            p, c = self.parent[child]
            if p == other or (p in static and other in static):
                kinds = [j[0] for j in self.joints(c, child)]
                return (child, kinds.index("hinge"), sign) if "hinge" in kinds else None
        h = self._name("helper")
        r, phi = self.pose(x)
        self.bodies.append((h, k, r, phi, self.joints(None, x), None))
        self.equality.append(("weld", (h, (0.0, 0.0)), (x, (0.0, 0.0))))
        return (h, 2, 1.0)

    def _drive_edge(self, dr, cons):
        """The constraint whose tree joint carries the driven coordinate."""
        b = dr.body
        if b in self.ground:
            self.problem = Reason("driver", dr.name, f"moves ground body '{b}'")
            return None
        for c in cons:
            if c.type not in ("revolute", "translational", "revolute-translational") or b not in (c["i"], c["j"]):
                continue
            other = c["j"] if b == c["i"] else c["i"]
            if dr.coord == "phi" and c.type != "translational":
                if other == dr.relative_to or (dr.relative_to is None and other in self.ground):
                    return c
            elif dr.coord != "phi" and other in self.ground and abs(self.line(c)[0 if dr.coord == "x" else 1]) > 1e-6:
                # a slide moves every point of a translating body, and the pin of a
                # revolute-translational joint, along the line
                pin = (c.type == "revolute-translational" and b == c["i"]
                       and tuple(c["si"]) == tuple(dr.point or (0, 0)))
                if c.type == "translational" or pin:
                    return c
        if dr.coord == "phi":
            to = f"body '{dr.relative_to}'" if dr.relative_to else "a ground body"
            self.problem = Reason("driver", dr.name, f"phi of '{b}' needs a revolute or revolute-translational "
                                  f"joint between '{b}' and {to}: a driven angle must be one hinge's coordinate")
        else:
            self.problem = Reason("driver", dr.name, f"{dr.coord} of '{b}' needs a translational joint between "
                                  f"'{b}' and a ground body, or a revolute-translational one whose pin is the driven "
                                  f"point, along a line with an {dr.coord} component: a driven position must be one "
                                  "slide's coordinate")
        return None

    def _map_drive(self, dr, c, parent):
        k = 3 * self.index[dr.body]
        n = {"x": 0, "y": 1, "phi": 2}[dr.coord]
        if c is None:                                   # tree = "free": the body's own planar joints
            if dr.relative_to is not None or dr.point is not None:
                self.problem = Reason("driver", dr.name, "with tree = 'free' only a body's own x, y or phi can be "
                                      "driven")
                return
            self.driven.append((dr, dr.body, n, 1.0, self.q0[k + n]))
            return
        child = dr.body if parent[dr.body][1] is c else (c["j"] if dr.body == c["i"] else c["i"])
        kinds = [j[0] for j in self.joints(c, child)]
        if dr.coord == "phi":
            # the hinge turns the child relative to its parent
            ref = self.q0[3 * self.index[dr.relative_to] + 2] if dr.relative_to else 0.0
            a = 1.0 if child == dr.body else -1.0
            self.driven.append((dr, child, kinds.index("hinge"), a, self.q0[k + 2] - ref))
        else:
            # the slide moves the body along the line, a unit world vector
            v0 = self.world(dr.body, dr.point or (0.0, 0.0))[n]
            self.driven.append((dr, child, kinds.index("slide"), 1.0 / self.line(c)[n], v0))


def mjcf(plan, s) -> str:
    """The MJCF text of a Plan with the settings s (dt and solref resolved)."""
    mass, inertia = mass_properties(plan.model)
    armature = {(b, j) for _, b, j, _, _ in plan.driven}
    sites, equality = {}, []

    def site(body, point):
        name = f"site:{sum(len(v) for v in sites.values())}"
        sites.setdefault(body, []).append((name, point))
        return name

    for kind, a, b in plan.equality:
        if kind == "connect":
            equality.append(f'<connect site1="{site(*a)}" site2="{site(*b)}"/>')
        elif kind == "weld":
            equality.append(f'<weld site1="{site(*a)}" site2="{site(*b)}"/>')
        else:   # joint: b = (joint2 or None, polycoef)
            other = f' joint2={quoteattr(f"{b[0][0]}:{b[0][1]}")}' if b[0] else ""
            equality.append(f'<joint joint1={quoteattr(f"{a[0]}:{a[1]}")}{other} polycoef="{" ".join(_num(x) for x in b[1])}"/>')
    children = {}
    for item in plan.bodies:
        children.setdefault(item[1], []).append(item)

    def body(name, parent, r, phi, joints, case_body):
        rp, phip = plan.pose(parent)                    # parents are case bodies or the world
        pos, rel = _rot(-phip) @ (r - rp), phi - phip
        out = [f'<body name={quoteattr(name)} pos="{_vec(pos)}" quat="{_num(np.cos(rel / 2))} 0 0 {_num(np.sin(rel / 2))}">']
        if joints is not None:
            # a helper or link weighs as little as the lightest body: it only follows
            k = plan.index[case_body] if case_body is not None else None
            m = mass[k] if k is not None else mass.min()
            i = inertia[k] if k is not None else inertia.min()
            out.append(f'<inertial pos="0 0 0" mass="{_num(m)}" diaginertia="{_num(i)} {_num(i)} {_num(i)}"/>')
            for j, (kind, at, axis) in enumerate(joints):
                arm = f' armature="{_num(s["armature"])}"' if (name, j) in armature else ""
                ax = "0 0 1" if axis is None else _vec(axis)
                out.append(f'<joint name={quoteattr(f"{name}:{j}")} type="{kind}" pos="{_vec(at)}" axis="{ax}"{arm}/>')
        out += [f'<site name="{n}" pos="{_vec(p)}"/>' for n, p in sites.get(name, [])]
        for item in children.get(name, []):
            out += body(*item)
        out.append("</body>")
        return out

    def on(key):
        return "enable" if s[key] else "disable"

    flag = (f'<flag contact="disable" gravity="disable" autoreset="disable" refsafe="{on("refsafe")}" '
            f'diagexact="{on("diagexact")}"/>')
    out = ['<mujoco model="kinem">', '<compiler angle="radian" inertiafromgeom="false"/>',
           f'<option timestep="{_num(s["dt"])}" integrator="{s["integrator"]}" solver="Newton" jacobian="dense" '
           f'tolerance="{_num(s["tolerance"])}" iterations="{int(s["iterations"])}" gravity="0 0 0">{flag}</option>',
           f'<default><equality solref="{_num(s["solref"][0])} {_num(s["solref"][1])}" '
           f'solimp="{" ".join(_num(x) for x in s["solimp"])}"/></default>', "<worldbody>"]
    for item in children.get(WORLD, []):
        out += body(*item)
    out.append("</worldbody>")
    if equality:
        out += ["<equality>"] + equality + ["</equality>"]
    out.append("</mujoco>")
    return "\n".join(out)


class MujocoAdapter(Adapter):
    name = "mujoco"
    tolerance = TOLERANCE
    order = ORDER
    supports = {
        "ground": "static body, child of the world, no joints",
        "absolute": "in the tree: a slide across the held coordinate and a hinge at the point (phi: slides x and "
                    "y) from the world; closing a loop: a helper body with these joints welded to the body",
        "revolute": "in the tree: hinge about z at the joint; closing a loop: connect between two sites",
        "translational": "in the tree: slide along the line; closing a loop: a helper body with that slide, "
                         "welded to the other body",
        "revolute-translational": "in the tree: slide along the line and hinge at the pin; closing a loop: a "
                                  "helper body with these joints, welded to the pin's body",
        "revolute-revolute": "link body hinged at P_i, its tip connected to P_j (connect)",
        "driver": "coordinate of one tree joint, armature 1e9, qpos and qvel set from d(t) before every step: "
                  "the hinge for phi of a body pinned to ground (or relative_to the body it is pinned to); the "
                  "slide for x/y (point forms included) of a body on a translational joint with ground, or of "
                  "the pin of a revolute-translational joint on a ground line. Other forms: unsupported (no "
                  "joint coordinate equals them)",
        "gear": "joint equality (linear polycoef) between the hinges that measure each gear's angle relative "
                "to the carrier (or the ground); a helper body free in the plane under the carrier, welded to "
                "the gear, where the tree has no such hinge",
        "rack-pinion": "helper body under the rack at the pinion's centre with slides along and across the "
                       "pitch line and a hinge, welded to the pinion; joint equality slide = -radius x hinge",
        "distance-driver": "link body hinged at P_i with a slide along it, its tip connected to P_j; the slide "
                           "is driven like a driver",
    }
    _CURVE = ("MuJoCo has no constraint along a curve; geom contact is soft (it penetrates by design), "
              "one-sided and against a discretised outline")
    reasons = {
        "cam-point": _CURVE,
        "cam-roller": _CURVE,
        "cam-flat": _CURVE,
        "point-follower": _CURVE,
    }

    def version(self) -> str:
        import mujoco

        return mujoco.__version__

    def defaults(self) -> dict:
        return {
            # RK4: ~100x smaller errors than implicitfast or Euler at the same step (docs/engines/mujoco.md),
            # ~3x their cost per step
            "integrator": "RK4",
            # engine step (s); the step used divides the output interval. "auto": rate_step / the
            # mechanism's rate scale (adapters.base.rate_scale: its fastest body rate, or the rate its
            # accelerations and their changes imply), since the loop errors scale as (rate x dt)^2:
            # faster mechanisms get proportionally smaller steps. A number: that step whatever the mechanism
            "dt": "auto",
            # rate x step of dt = "auto" ("settings chosen from the mechanism"): the first attempt, then
            # checked by the engine's own error figures (adapters.base.self_check: the loops' residual
            # carried to the coordinates: MuJoCo's errors against native, positions within 1 %,
            # velocities within 15 %) and refined until they are within TOLERANCE or the cost cap
            # (refine; orders ORDER), solref following the step. Coarser than most mechanisms need (the book's and generated ones
            # afford 2e-3 to 4e-2): a first step that is fine enough already is never coarsened, so
            # this is set to be refined, once, to within 1.5x the cheapest (docs/engines.md)
            "rate_step": 1.2e-2,
            # engine steps per output interval; None: the fewest with a step <= dt
            "substeps": None,
            # (time constant s, damping ratio) of the loop-closing equalities; None: (3 dt, 1). 2 dt
            # (refsafe's least) gives 1.7x smaller position but 4x larger velocity errors; MuJoCo's default
            # 0.02 s leaves 2e-3 of the size
            "solref": None,
            # impedance 0.9999, MuJoCo's largest, whatever the violation: as hard as MuJoCo allows
            "solimp": (0.9999, 0.9999, 0.001, 0.5, 2.0),
            # MuJoCo's clamp of solref[0] to >= 2 dt (explicit integrators go unstable below it)
            "refsafe": True,
            # exact constraint-space inertia diagonal for the impedance: no measurable gain here
            "diagexact": False,
            # armature of driven joints (mass x length^2 of the case); None: 1e9 with drive "overwrite"
            # (qpos and qvel overwritten each step: ample even in mm units), 1e12 otherwise (between
            # overwrites the reactions move the joint by ~ force / armature: 1e9 leaves 3x larger errors)
            "armature": None,
            # "overwrite": qpos, qvel of driven joints set from d(t), d'(t) before every step, plus a force
            # armature * d''(t); "interval": set only at output instants, the interval stepped in C by
            # mj_step(m, d, substeps) with the force held (exact for drivers of constant d'', i.e.
            # polynomials of degree <= 2; 0.86x the cost at the same errors on the book cases); "auto":
            # "interval" where it is exact, else "overwrite"; "force": that force alone after the initial
            # state (drifts unless the armature dwarfs the reactions)
            "drive": "auto",
            # "spanning": a spanning tree of joints, loops closed by equalities; "free": every body free in
            # the plane and every constraint an equality (3-25x larger errors, for comparison)
            "tree": "spanning",
            # Newton solver: converge fully every step (early exit would leave part of the loop error)
            "tolerance": 1e-12,
            "iterations": 100,
        }

    knobs = {"integrator": ("RK4", "implicitfast", "Euler"), "substeps": (1, 2, 4, 8, 16, 40)}
    rate_steps = (1.6e-3, 4e-3, 8e-3, 1.2e-2, 1.6e-2, 3.2e-2)   # rate_step values the sweep tries (dt auto)
    checks = {"integrator": choice("RK4", "Euler", "implicit", "implicitfast"), "dt": step_or_auto,
              "rate_step": positive, "substeps": count_or_none, "solref": numbers(2, finite, optional=True),
              "solimp": numbers(5), "refsafe": boolean, "diagexact": boolean, "armature": positive_or_none,
              "drive": choice("auto", "overwrite", "interval", "force"), "tree": choice("spanning", "free"),
              "tolerance": nonnegative, "iterations": count}

    def unsupported(self, model, q0=None, tree="spanning") -> Reason | None:
        why = super().unsupported(model)
        if why is None:
            plan = Plan(model, model.q0 if q0 is None else q0, tree)
            why = plan.problem
        return why

    def unsupported_with(self, model, q0, s):
        return self.unsupported(model, q0, s["tree"])

    def refine(self, model, s, times, Q, QD, state, last=False, first=False):
        """adapters.base's refinement by the self-check; a solref derived from
        the step (the default, 3 dt) is derived again from the refined step:
        the loop error is the equalities' softness, ~ solref[0]^2, so a
        smaller step with the old time constant would leave it unchanged."""
        again = super().refine(model, s, times, Q, QD, state, last, first)
        if again and s["solref"] == (3 * s["dt"], 1.0):
            again = (again[0], dict(again[1], solref=None))
        return again

    def build(self, model, q0, s):
        """(Plan, MJCF text) of the model in the pose q0 with the settings s
        (substeps and dt resolved; solref filled in here)."""
        if s["solref"] is None:
            s["solref"] = (3 * s["dt"], 1.0)
        s["solref"] = tuple(float(x) for x in s["solref"])
        plan = Plan(model, q0, s["tree"])
        if s["drive"] == "auto":
            s["drive"] = "interval" if all(held(dr.f) for dr, *_ in plan.driven) else "overwrite"
        if s["armature"] is None:   # scale-free: at least ARMATURE_RATIO x the largest body inertia
            top = float(mass_properties(model)[1].max(initial=0.0))
            s["armature"] = (1e9 if s["drive"] == "overwrite" else HELD_ARMATURE) * max(1.0, top / ARMATURE_INERTIA)
        return plan, mjcf(plan, s)

    def simulate(self, model, q0, qd0, s, times):
        import mujoco

        messages = []
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(messages.append)  # into the status, not onto stderr
        try:
            return self._simulate(model, q0, qd0, s, times)
        except ValueError as e:  # MuJoCo's compiler errors (bad settings, degenerate model)
            raise Failure(Status.FAILED, str(e)) from None
        except Failure as e:
            if messages:
                e.detail = f"{e.detail}: {messages[0].strip()}"
            raise
        finally:
            mujoco.set_mju_user_warning(previous)

    def _simulate(self, model, q0, qd0, s, times):
        import mujoco

        sub = s["substeps"]
        plan, xml = self.build(model, q0, s)
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        bid = [m.body(b).id for b in plan.names]
        initial_state(m, d, plan, qd0)

        # driven joints: coordinate a (d(t) - v0), rate a d'(t), force armature a d''(t),
        # evaluated before the loop at every step's start
        jid = [m.joint(f"{b}:{j}").id for _, b, j, _, _ in plan.driven]
        qadr, vadr = m.jnt_qposadr[jid].astype(int), m.jnt_dofadr[jid].astype(int)
        tk = np.arange((len(times) - 1) * sub + 1) * s["dt"]
        P, V, F = drive_tables(plan, tk, s["armature"])
        d.qpos[qadr], d.qvel[vadr] = P[0], V[0]
        every_step = s["drive"] == "overwrite" and len(jid) > 0
        at_output = s["drive"] in ("overwrite", "interval")

        Q = np.empty((len(times), 3 * len(bid)))
        QD = np.empty_like(Q)
        vel = np.zeros(6)
        warnings = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
                    mujoco.mjtWarning.mjWARN_BADQPOS)

        def sample(k, n):
            if at_output:
                d.qpos[qadr], d.qvel[vadr] = P[n], V[n]
            mujoco.mj_forward(m, d)
            for j, i in enumerate(bid):
                w, _, _, z = d.xquat[i]
                prev = Q[k - 1, 3 * j + 2] if k else q0[3 * j + 2]
                phi = prev + np.angle(np.exp(1j * (2 * np.arctan2(z, w) - prev)))  # continuous angle
                Q[k, 3 * j:3 * j + 3] = d.xpos[i][0], d.xpos[i][1], phi
                mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, i, vel, 0)
                QD[k, 3 * j:3 * j + 3] = vel[3], vel[4], vel[2]

        sample(0, 0)
        wall, n = 0.0, 0
        for k in range(1, len(times)):
            in_time(times[k - 1], n, wall)   # compare --max-seconds, between output intervals
            if every_step:                  # driving between steps: the cheapest per-step Python
                start = time.perf_counter()
                for _ in range(sub):
                    d.qpos[qadr], d.qvel[vadr] = P[n], V[n]
                    d.qfrc_applied[vadr] = F[n]
                    mujoco.mj_step(m, d)
                    n += 1
                wall += time.perf_counter() - start
            else:                           # the interval stepped in C (driving force held over it)
                d.qfrc_applied[vadr] = F[n]
                start = time.perf_counter()
                mujoco.mj_step(m, d, sub)
                wall += time.perf_counter() - start
                n += sub
            bad = [w.name for w in warnings if d.warning[w].number > 0]
            if bad or not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
                raise Failure(Status.DIVERGED, f"MuJoCo diverged before t = {times[k]:.6g} "
                              f"({', '.join(bad) or 'non-finite'})", n)
            sample(k, n)
        return Q, QD, wall, n


def held(f) -> bool:
    """d'' of the kinem function f is constant (a polynomial of degree <= 2):
    a force held over an interval drives its joint exactly."""
    return isinstance(f, Poly) and len(f.coeffs) <= 3


def initial_state(m, d, plan, qd0):
    """Joint velocities: the case bodies' velocities qd0, and zero rate of
    every equality's residual (this fixes the helpers' and links' joints)."""
    import mujoco

    mujoco.mj_forward(m, d)
    rows, target = [d.efc_J.reshape(d.nefc, m.nv)], [np.zeros(d.nefc)]
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for k, b in enumerate(plan.names):
        mujoco.mj_jacBody(m, d, jp, jr, m.body(b).id)
        rows.append(np.array([jp[0], jp[1], jr[2]]))
        target.append(qd0[3 * k:3 * k + 3])
    if m.nv:
        d.qvel[:] = np.linalg.lstsq(np.vstack(rows), np.concatenate(target), rcond=None)[0]


def drive_tables(plan, tk, armature):
    """Driven joints' coordinates, rates and forces at the instants tk:
    a (d(t) - v0), a d'(t), armature a d''(t), each (len(tk), joints)."""
    f = [dr.f for dr, _, _, _, _ in plan.driven]
    a = np.array([x[3] for x in plan.driven])
    v0 = np.array([x[4] for x in plan.driven])
    return (a * (drive_table(f, tk, 0) - v0), a * drive_table(f, tk, 1), armature * a * drive_table(f, tk, 2))


ADAPTER = MujocoAdapter()
