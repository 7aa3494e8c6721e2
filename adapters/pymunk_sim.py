"""pymunk (Chipmunk2D, Munk2D fork) adapter.

Bodies. No shapes (nothing collides); mass and moment come from
``mass_properties`` with the centre of gravity at the body origin, so pymunk's
body position and velocity are those of the case's body frame. Grounded
bodies are STATIC. A body with an absolute angle driver that is pinned by a
revolute joint to a static (or already prescribed) body -- a crank -- is
KINEMATIC with its whole pose prescribed. Every other body is DYNAMIC. Joints
between two non-dynamic bodies are left out: the prescribed poses satisfy them.

Time stepping. ``Space.step`` first moves every body with its stored
velocity, then solves the velocity constraints at the new positions with the
bias -(1 - error_bias**dt) C / dt. With error_bias 0 the bias removes the
whole position error over the next step, so a stored velocity is the one
that carries the body over the NEXT step (a forward secant, half a step
ahead of the positions) and positions are second-order accurate. Hence:
  * a kinematic body is set before the step from t_j so that the step lands
    it exactly on its pose at t_{j+1} with the velocity
    (pose(t_{j+2}) - pose(t_{j+1})) / dt: the constraint solve at t_{j+1} then
    hands the others the velocities of the step they are about to take;
  * a driven joint's target (GearJoint phase, PinJoint distance) set before
    the step from t_j is d(t_{j+2}), the value the solved velocity reaches one
    step later; these joints always use error_bias 0;
  * ``centered_velocity``: the reported velocity at an output instant is the
    mean of the stored velocities just before and just after it (second
    order); otherwise the stored forward one (first order).

GrooveJoint solves a 2x2 point-to-point impulse and projects it onto the
groove normal. The projection is the exact 1-D solve only when the axis is
an eigenvector of the effective-mass tensor: each body non-dynamic, or with
its centre of gravity on the line (groove body) or at the anchor (anchor
body). Otherwise the anchor drifts off the line by O(dt) x sliding speed
(1e-5 L on quick_return_2 at dt = 1e-4), so helper bodies make every groove
exact: a point helper (infinite moment) pinned at an off-centre anchor, or a
line helper welded (PivotJoint + GearJoint) to the groove body, centred on
the line.
"""
import math
import time

import numpy as np
import pymunk


from .base import (CHECK_EVERY, Adapter, Failure, Reason, Status, boolean, count, count_or_auto, count_or_none,
                   drive_table, drives, fraction, grounded, in_time, mass_properties, nonnegative, numbers, positive,
                   step_or_auto)

# Agreement with native at the default settings, in the figures of
# adapters.compare (max over instants, bodies and named points). The scheme is
# second order: errors ~ c (Omega dt)^2 with c < 1 measured (Omega: the fastest
# body rate), <= 2e-8 on the book's cases at dt = 1e-4. The bounds allow rates
# up to ~10 rad/s at that step and stay 10x below the 1e-5 target.
TOLERANCE = {
    "position_error_rel": 1e-6,     # |r_engine - r_native| / L
    "angle_error": 1e-6,            # rad
    "constraint_residual": 1e-6,    # native scaled residual of the engine's positions
    "velocity_error_rel": 1e-5,     # |v_engine - v_native| / the run's peak speed
    "angular_velocity_error_rel": 1e-5,  # |omega_engine - omega_native| / the run's peak angular speed
}

GROOVE = 1e4   # groove half-length in units of L: far beyond any sliding in a
               # mechanism of size L; leaving it is checked at every output instant
DRIFT = 1e-3   # loop-closure drift (native scaled residual ~ error / L) at which the
               # solver has lost the mechanism: 1e3 x TOLERANCE, reached only when
               # Gauss-Seidel diverges (too few iterations)
UNCONVERGED = 1e-6  # velocity residual of the loop-closure constraints, relative to the run's
               # fastest rate, above which the velocity solve has not converged: a converged
               # run leaves <= 1e-7 (measured over 100+ random quick-returns at 25-100
               # iterations), an unconverged one 3e-7 to 0.2 with velocity errors ~4e5 x it
TINY = 1e-12   # offset (in L) below which a point is on a line / at a centre
TABLE_CHUNK = 65536   # engine steps whose driving tables (Python lists) are made at a time, between output
               # intervals: never the whole run's at once (23 s for 10^7 steps), so --max-seconds bounds them

STATIC, KINEMATIC = pymunk.Body.STATIC, pymunk.Body.KINEMATIC


def _values(f, t):
    """d(t) of a kinem function at an array of instants."""
    return drive_table([f], t, 0)[:, 0]


class _Along:
    """A quantity over the step instants, made for a range of them when read
    (``make(lo, hi)``: its values at tt[lo:hi]), never for the whole run at
    once: a[lo:hi], a[k], a.after(n) (a[n:]), np.asarray(a) (all of it, for
    an exported script). What it is made of is elementwise in the instants
    (the core's d(t), numpy's arithmetic): the same numbers to the bit in a
    window as all at once. (10^7 steps made at once took 8 to 16 s, load
    4.5, before the first interval's check of --max-seconds.)"""

    def __init__(self, make, n, shift=0):
        self.make, self.n, self.shift = make, n, shift

    def __len__(self):
        return self.n - self.shift

    def __getitem__(self, k):
        if isinstance(k, slice):
            lo, hi, step = k.indices(len(self))
            if step != 1:
                raise ValueError("a prescribed quantity is read in contiguous windows")
            return self.make(lo + self.shift, max(lo, hi) + self.shift)
        k = range(len(self))[k]
        return self.make(k + self.shift, k + self.shift + 1)[0]

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self[:], dtype)

    def after(self, n):
        """The quantity from step n on (a[n:])."""
        return _Along(self.make, self.n, self.shift + n)


def _along(tt, f):
    """_Along of f(instants) -> array over the step instants tt."""
    return _Along(lambda lo, hi: f(tt[lo:hi]), len(tt))


def _pose(n, make):
    """(x, y, phi) as _Alongs of one ``make(lo, hi)`` -> (x, y, phi) arrays, the last two windows kept (a
    window reads each coordinate at two overlapping ranges)."""
    kept = {}

    def part(i):
        def window(lo, hi):
            if (lo, hi) not in kept:
                if len(kept) >= 2:
                    kept.pop(next(iter(kept)))
                kept[(lo, hi)] = make(lo, hi)
            return kept[(lo, hi)][i]
        return _Along(window, n)

    return part(0), part(1), part(2)


def _prescribed(model, tt):
    """Bodies whose pose is a function of time: an absolute angle driver and a
    revolute joint to a grounded or already prescribed body. Returns
    {body: (x, y, phi) over tt, each an _Along} and the names of the drivers
    they consume."""
    poses, n = {}, len(tt)
    for c in model.case.constraints:
        if c.type == "ground":
            poses[c["body"]] = tuple(_Along(lambda lo, hi, v=float(v): np.full(hi - lo, v), n) for v in c["value"])
    fixed = set(poses)
    driven = {d.body: d for d in drives(model) if d.coord == "phi" and d.relative_to is None}
    pins = [c for c in model.case.constraints if c.type == "revolute"]
    used, changed = set(), True
    while changed:
        changed = False
        for name, d in driven.items():
            if name in poses:
                continue
            for c in pins:
                ends = {c["i"]: c["si"], c["j"]: c["sj"]}
                other = c["j"] if c["i"] == name else c["i"] if c["j"] == name else None
                if other in poses:
                    def make(lo, hi, other=poses[other], f=d.f, a=complex(*ends[other]), b=complex(*ends[name])):
                        ox, oy, ophi = (x[lo:hi] for x in other)
                        phi = _values(f, tt[lo:hi])
                        pin = ox + 1j * oy + a * np.exp(1j * ophi)
                        r = pin - b * np.exp(1j * phi)
                        return r.real, r.imag, phi

                    poses[name] = _pose(n, make)
                    used.add(d.name)
                    changed = True
                    break
    return {b: p for b, p in poses.items() if b not in fixed}, used


class _Mechanism:
    """The case's mechanism in one pymunk Space."""

    def __init__(self, model, q0, qd0, s, tt):
        self.model, self.L, self.tt = model, model.length, tt
        self.error_bias = float(s["error_bias"])
        self.space = pymunk.Space()
        self.space.iterations = int(s["iterations"])
        self.space.gravity = (0.0, 0.0)
        self.space.damping = 1.0                 # none
        self.kinematic = []                      # (body, x, y, phi over tt: _Alongs)
        self.targets = []                        # (joint, attribute, value over tt: an _Along)
        self.grooves = []                        # (name, body a, point, axis, body b, anchor)
        self.ground = self.place(pymunk.Body(body_type=STATIC), (0, 0, 0), (0, 0, 0))

        poses, used = _prescribed(model, tt)
        fixed = grounded(model)
        # A body sliding on a static body cannot turn: infinite moment
        # replaces its rotation lock (decided first, so that no GearJoint
        # ever joins two bodies of infinite moment).
        no_turn = {c[k] for c in model.case.constraints if c.type == "translational"
                   for k, other in (("i", "j"), ("j", "i")) if c[other] in fixed and c[k] not in fixed | set(poses)}
        mass, inertia = mass_properties(model)
        self.body = {}
        for k, name in enumerate(model.body_names):
            q, qd = q0[3 * k: 3 * k + 3], qd0[3 * k: 3 * k + 3]
            if name in fixed:
                b, qd = pymunk.Body(body_type=STATIC), (0.0, 0.0, 0.0)
            elif name in poses:
                b = pymunk.Body(body_type=KINEMATIC)
                self.kinematic.append((b, *poses[name]))
            else:
                b = pymunk.Body(float(mass[k]), math.inf if name in no_turn else float(inertia[k]))
            self.body[name] = self.place(b, q, qd)

        by_name = {d.name: d for d in drives(model)}
        for c in model.case.constraints:
            if c.type == "ground" or c.name in used:
                continue
            names = [c[k] for k in ("i", "j", "body", "relative_to") if c.get(k) is not None]
            if not any(self.dynamic(self.body[n]) for n in names):
                continue                         # holds by construction of the poses
            if c.type == "driver":
                self.driver(by_name[c.name])
            else:
                getattr(self, c.type.replace("-", "_"))(c)

    # -- bodies ------------------------------------------------------------------
    def place(self, body, q, qd):
        body.angle = float(q[2])                 # first: it turns the body about its centre
        body.position = (float(q[0]), float(q[1]))
        body.velocity = (float(qd[0]), float(qd[1]))
        body.angular_velocity = float(qd[2])
        self.space.add(body)
        return body

    @staticmethod
    def dynamic(b):
        return b.body_type == pymunk.Body.DYNAMIC

    def helper(self, at, s, moment):
        """Dynamic helper centred on point s of body ``at``, moving with it;
        its mass is at's (1:1 mass ratios keep Gauss-Seidel converging)."""
        p, v = at.local_to_world(s), at.velocity_at_local_point(s)
        w = at.angular_velocity if math.isfinite(moment) else 0.0
        return self.place(pymunk.Body(at.mass, moment), (p.x, p.y, at.angle), (v.x, v.y, w))

    def moving_helper(self, x, y, phi):
        """KINEMATIC helper whose pose follows (x, y, phi) over tt."""
        b = pymunk.Body(body_type=KINEMATIC)
        self.kinematic.append((b, x, y, phi))
        return self.place(b, (x[0], y[0], phi[0]), (0.0, 0.0, 0.0))

    # -- joints ------------------------------------------------------------------
    def add(self, joint, error_bias=None):
        joint.error_bias = self.error_bias if error_bias is None else error_bias
        joint.collide_bodies = False
        self.space.add(joint)
        return joint

    def lock(self, a, b, phase, ratio=1.0, error_bias=None):
        """GearJoint ratio phi_b - phi_a = phase, unless neither body can turn."""
        if any(self.dynamic(x) and math.isfinite(x.moment) for x in (a, b)):
            return self.add(pymunk.GearJoint(a, b, phase, ratio), error_bias)
        return None

    def point_on_line(self, name, a, pa, ua, b, sb):
        """Point sb of body b on the line through pa along ua of body a (local
        coordinates): a GrooveJoint made exact by helpers (module docstring)."""
        ua = complex(*ua) / abs(complex(*ua))
        if self.dynamic(b) and math.hypot(*sb) > TINY * self.L:
            h = self.helper(b, sb, math.inf)
            self.add(pymunk.PivotJoint(b, h, sb, (0.0, 0.0)))
            b, sb = h, (0.0, 0.0)
        if self.dynamic(a) and abs((complex(*pa).conjugate() * ua).imag) > TINY * self.L:
            h = self.helper(a, pa, a.moment)
            self.add(pymunk.PivotJoint(a, h, pa, (0.0, 0.0)))
            self.lock(a, h, 0.0)
            a, pa = h, (0.0, 0.0)
        ends = [complex(*pa) + sign * GROOVE * self.L * ua for sign in (-1, 1)]
        self.add(pymunk.GrooveJoint(a, b, *[(e.real, e.imag) for e in ends], sb))
        self.grooves.append((name, a, pa, (ua.real, ua.imag), b, sb))

    def revolute(self, c):
        self.add(pymunk.PivotJoint(self.body[c["i"]], self.body[c["j"]], tuple(c["si"]), tuple(c["sj"])))

    def revolute_revolute(self, c):
        j = self.add(pymunk.PinJoint(self.body[c["i"]], self.body[c["j"]], tuple(c["si"]), tuple(c["sj"])))
        j.distance = float(c["length"])          # not the distance of the pose at creation

    def distance_driver(self, c):
        j = self.add(pymunk.PinJoint(self.body[c["i"]], self.body[c["j"]], tuple(c["si"]), tuple(c["sj"])),
                     error_bias=0.0)
        d = _along(self.tt, lambda t: _values(c["d"], t))
        j.distance = float(d[0])
        self.targets.append((j, "distance", d.after(2)))

    def translational(self, c):
        bi, bj = self.body[c["i"]], self.body[c["j"]]
        phi0 = float(c["phi0"])                  # phi_i - phi_j
        self.lock(bi, bj, -phi0)                 # skipped when both have infinite moments (no_turn)
        # With no relative rotation every point of one body slides parallel
        # to u on the other: the groove runs through the other body's origin
        # and is anchored there (on the non-dynamic body when there is one).
        si, sj = complex(*c["si"]), complex(*c["sj"])
        u = complex(*c["qi"]) - si               # in i's frame
        turn = complex(math.cos(phi0), math.sin(phi0))   # i's frame -> j's frame
        if self.dynamic(bj):
            a, b, p = bi, bj, si - sj / turn
        else:
            a, b, p, u = bj, bi, sj - si * turn, u * turn
        self.point_on_line(c.name, a, (p.real, p.imag), (u.real, u.imag), b, (0.0, 0.0))

    def revolute_translational(self, c):
        self.point_on_line(c.name, self.body[c["j"]], tuple(c["sj"]), tuple(np.subtract(c["qj"], c["sj"])),
                           self.body[c["i"]], tuple(c["si"]))

    def absolute(self, c):
        b = self.body[c["body"]]
        if c["coord"] == "phi":
            self.lock(self.ground, b, float(c["value"]))
        else:
            x = c["coord"] == "x"
            line = (float(c["value"]), 0.0) if x else (0.0, float(c["value"]))
            self.point_on_line(c.name, self.ground, line, (0.0, 1.0) if x else (1.0, 0.0), b,
                               tuple(c.get("point") or (0.0, 0.0)))

    def driver(self, d):
        b = self.body[d.body]
        v = _along(self.tt, lambda t: _values(d.f, t))
        zero = _along(self.tt, np.zeros_like)
        if d.relative_to is not None:            # phi_b - phi_k = d(t)
            j = self.lock(self.body[d.relative_to], b, float(v[0]), error_bias=0.0)
            if j is not None:
                self.targets.append((j, "phase", v.after(2)))
        elif d.coord == "phi":
            self.lock(self.moving_helper(zero, zero, v), b, 0.0)
        else:                                    # a groove across the axis, moving along it
            x = d.coord == "x"
            h = self.moving_helper(v if x else zero, zero if x else v, zero)
            self.point_on_line(d.name, h, (0.0, 0.0), (0.0, 1.0) if x else (1.0, 0.0), b,
                               tuple(d.point or (0.0, 0.0)))

    def gear(self, c):
        # kinem: ri (phi_i - phi_k) + sigma rj (phi_j - phi_k - phi0) = 0, sigma = -1
        # for an internal gear, phi_k a grounded carrier's angle (0 without
        # one): phi_i = ratio phi_j + const with ratio = -sigma rj / ri.
        ratio = (1.0 if c.get("internal") else -1.0) * float(c["rj"]) / float(c["ri"])
        phik = self.body[c["carrier"]].angle if c.get("carrier") else 0.0
        self.lock(self.body[c["i"]], self.body[c["j"]], (ratio - 1.0) * phik + ratio * float(c["phi0"]), ratio)

    def off_groove(self):
        """Name of a groove whose anchor has left it, or None."""
        for name, a, pa, ua, b, sb in self.grooves:
            d = a.world_to_local(b.local_to_world(sb))
            if abs((d.x - pa[0]) * ua[0] + (d.y - pa[1]) * ua[1]) >= GROOVE * self.L:
                return name
        return None


class PymunkAdapter(Adapter):
    name = "pymunk"
    tolerance = TOLERANCE
    knobs = {"substeps": (1, 2, 5, 10, 20, 50, 100), "iterations": (3, 5, 10, 25, 100)}
    order = 2      # error_bias 0: positions and velocities O(dt^2)
    rate_steps = (0.5e-3, 1e-3, 2e-3, 3e-3, 4e-3)   # rate_step values the tuning sweep tries (dt auto)
    checks = {"dt": step_or_auto, "rate_step": positive, "substeps": count_or_none, "iterations": count_or_auto,
              "auto_iterations": numbers(2, count), "error_bias": fraction, "centered_velocity": boolean}
    supports = {
        "ground": "STATIC body",
        "absolute": "phi: GearJoint to a static body; x, y (point forms): GrooveJoint on a static line",
        "revolute": "PivotJoint",
        "translational": "GrooveJoint through the other body's origin plus a rotation lock "
                         "(infinite moment when sliding on a static body, else GearJoint ratio 1)",
        "revolute-revolute": "PinJoint (distance set to the link length)",
        "revolute-translational": "GrooveJoint (half-length 1e4 L, checked); a helper body pinned at "
                                  "an off-centre pin keeps it exact",
        "driver": "angle of a body pinned to a static or prescribed body: KINEMATIC body, pose set every "
                  "step; other angles: GearJoint to a KINEMATIC helper; x, y (point forms): GrooveJoint "
                  "on a moving KINEMATIC helper; relative_to: GearJoint whose phase is set every step",
        "distance-driver": "PinJoint whose distance is set every step",
        "gear": "GearJoint on absolute angles (no carrier, or a grounded carrier)",
    }
    reasons = {
        "rack-pinion": "pymunk has no joint coupling a rotation to a translation",
        "cam-point": "no exact curve constraint in pymunk (collision shapes only give contact)",
        "cam-roller": "no exact curve constraint in pymunk (collision shapes only give contact)",
        "cam-flat": "no exact curve constraint in pymunk (collision shapes only give contact)",
        "point-follower": "no exact pin-in-curved-slot constraint in pymunk (GrooveJoint is straight)",
    }

    def version(self) -> str:
        return pymunk.version

    def defaults(self) -> dict:
        return {
            # Step. Errors are O(dt^2) with error_bias 0 (2e-6 L at 1e-3 on the
            # book's cases, 2e-10 at 1e-5). "auto": rate_step / the mechanism's
            # fastest rate (adapters.base.rate_scale), so a mechanism turning 4x
            # faster gets a quarter of the step and the same errors; then
            # checked by the engine's own error figures (adapters.base.self_check:
            # closure and velocity residuals carried to the coordinates) and
            # refined until they are within TOLERANCE or the cost cap.
            "dt": "auto",
            # rate x step of dt = "auto" (docs/engines.md, "Settings chosen
            # from the mechanism"): the first attempt; the self-check refines it.
            "rate_step": 2e-3,
            # Steps per output interval; None: the fewest with h / substeps
            # <= dt. When given it wins, and dt = h / substeps.
            "substeps": None,
            # Gauss-Seidel sweeps per step; "auto": auto_iterations[0], and
            # once more with auto_iterations[1] when the run diverged (DRIFT)
            # or its velocity solve did not converge (UNCONVERGED), recorded
            # in the run's notes (its cost counts both attempts).
            "iterations": "auto",
            # With error_bias 0 an unconverged solve feeds its residual back
            # through the bias and can diverge. The sweep's cheapest setting
            # within TOLERANCE on the five lower-pair cases has 25
            # (quick_return_1 needs 25 when the block passes the rocker's
            # centre; results are unchanged from 25 to 400), but random
            # four-bars and quick-returns of tests/test_engines_property.py
            # diverge or leave the velocity solve unconverged at 25 or 50
            # and hold at 100 (2.35x the cost of 25 per step).
            "auto_iterations": (25, 100),
            # Fraction of a joint's error left after one second: 0 removes it
            # over the next step (O(dt^2) errors); pymunk's 0.9**60 leaves O(dt).
            "error_bias": 0.0,
            # Mean of the staggered velocities around each output instant
            # (second order) rather than the forward one (first order).
            "centered_velocity": True,
        }

    def unsupported(self, model) -> Reason | None:
        why = super().unsupported(model)
        if why:
            return why
        fixed = grounded(model)
        for c in model.case.constraints:
            if c.type == "gear" and c.get("carrier") is not None and c["carrier"] not in fixed:
                return Reason("gear", c.name, f"on the moving carrier '{c['carrier']}': GearJoint relates absolute "
                              "angles, so only fixed axes can be represented")
        return None

    def resolve(self, model, s, q0=None, qd0=None):
        if s["iterations"] == "auto":
            s["iterations"] = s["auto_iterations"][0]
        return super().resolve(model, s, q0, qd0)

    def retry(self, model, s, times, auto, failure=None, Q=None, QD=None):
        """With iterations = "auto", once with auto_iterations[1] sweeps when
        the run diverged (DRIFT) or its velocity solve did not converge
        (UNCONVERGED): pymunk's Gauss-Seidel has no convergence test."""
        more = s["auto_iterations"][1]
        if "iterations" not in auto or more <= s["iterations"]:
            return None
        if failure is not None:
            why = failure.detail if failure.status is Status.DIVERGED else None
        else:
            res = velocity_residual(model, Q, QD, times, ~model.driving) if model.n == Q.shape[1] else 0.0
            why = (f"the velocity solve did not converge: the joints' velocity residual is {res:.1e} of the "
                   f"fastest rate (limit {UNCONVERGED:g})") if res > UNCONVERGED else None
        return (f"{why} at {s['iterations']} iterations", {"iterations": more}) if why else None

    def simulate(self, model, q0, qd0, s, times):
        n_sub, dt = s["substeps"], s["dt"]
        # the step instants t_0 .. t_{N+1}, t_j = j dt (np.arange(n) * dt's numbers), made a window at a time
        # (80 MB and about a second at 10^7 steps all at once)
        tt = _Along(lambda lo, hi: np.arange(lo, hi) * dt, n_sub * (len(times) - 1) + 2)
        try:
            mech = _Mechanism(model, q0, qd0, s, tt)
        except (ValueError, ArithmeticError) as e:
            raise Failure(Status.FAILED, f"building the mechanism: {e}") from None
        return self._step(model, mech, s, times, tt)

    def _step(self, model, mech, s, times, tt):
        n_sub, dt = s["substeps"], s["dt"]
        bodies = [mech.body[b] for b in model.body_names]
        Q = np.zeros((len(times), 3 * len(bodies)))
        QD = np.zeros_like(Q)
        before = np.zeros(Q.shape[1])

        def read_q(X):
            for k, b in enumerate(bodies):
                p = b.position
                X[3 * k: 3 * k + 3] = p.x, p.y, b.angle

        def read_v(X):
            for k, b in enumerate(bodies):
                v = b.velocity
                X[3 * k: 3 * k + 3] = v.x, v.y, b.angular_velocity

        # Before step j: the pose that the step carries onto pose(t_{j+1}) with
        # the velocity (pose(t_{j+2}) - pose(t_{j+1})) / dt; as lists for
        # steps lo .. made - 1 (``window``), TABLE_CHUNK steps at a time.
        kin, targets, lo, made = [], [], 0, 0   # the tables hold steps lo .. made - 1

        def window(j, n):
            """The tables of steps j .. j + n - 1 at least, made outside the stepping's timing."""
            nonlocal kin, targets, lo, made
            if lo <= j and j + n <= made:
                return
            hi = min(max(j + n, j + TABLE_CHUNK), len(tt) - 2)
            kin, lo, made = [], j, hi
            for b, *pose in mech.kinematic:
                vel = [(a[j + 2:hi + 2] - a[j + 1:hi + 1]) / dt for a in pose]
                start = [a[j + 1:hi + 1] - dt * v for a, v in zip(pose, vel)]
                kin.append((b, list(zip(start[0], start[1])), start[2].tolist(),
                            list(zip(vel[0], vel[1])), vel[2].tolist()))
            targets = [(jt, attr, v[j:hi].tolist()) for jt, attr, v in mech.targets]

        closure = ~model.driving if model.n == Q.shape[1] else None   # no artificial coordinates
        space, centered = mech.space, s["centered_velocity"]
        perf, stepper = time.perf_counter, space.step

        def steps(n, j):
            """n engine steps from step number j, prescribed bodies and targets set before each."""
            for i in range(j - lo, j - lo + n):
                for b, p, a, v, w in kin:
                    b.angle, b.position, b.velocity, b.angular_velocity = a[i], p[i], v[i], w[i]
                for jt, attr, v in targets:
                    setattr(jt, attr, v[i])
                stepper(dt)

        if not mech.kinematic and not mech.targets:        # nothing to set between steps: the tightest loop
            def steps(n, j):  # noqa: F811
                for _ in range(n):
                    stepper(dt)

            def window(j, n):  # noqa: F811
                pass

        read_q(Q[0])
        read_v(QD[0])
        wall, step = 0.0, 0
        for k in range(1, len(times)):
            in_time(times[k - 1], step, wall)   # compare --max-seconds, between output intervals
            window(step, n_sub)
            first = n_sub - 1 if centered else n_sub
            start = perf()
            steps(first, step)
            wall += perf() - start
            step += first
            if centered:
                read_v(before)                   # the velocity over [t_k - dt, t_k]
                start = perf()
                steps(1, step)
                wall += perf() - start
                step += 1
            read_q(Q[k])
            read_v(QD[k])                        # the velocity over [t_k, t_k + dt]
            if centered:
                QD[k] = 0.5 * (QD[k] + before)
            t = times[k]
            if not (np.isfinite(Q[k]).all() and np.isfinite(QD[k]).all()
                    and np.abs(Q[k] - Q[0]).max() < 1e6 * model.length):
                raise Failure(Status.DIVERGED, f"the solution diverged at t = {t:.6g} (non-finite or beyond 1e6 L)",
                              step, wall=wall)
            off = mech.off_groove()
            if off:
                raise Failure(Status.DIVERGED, f"at t = {t:.6g} '{off}' slid off its groove "
                              f"(half-length {GROOVE:g} L)", step, wall=wall)
            if closure is not None:
                drift = model.scaled_residual(model.phi(Q[k], t))[closure].max(initial=0.0)
                if drift > DRIFT:
                    raise Failure(Status.DIVERGED, f"at t = {t:.6g} the joints drifted apart by {drift:.1e} L "
                                  f"(limit {DRIFT:g}): the iterative solver lost the mechanism (more 'iterations' "
                                  f"may help; now {s['iterations']})", step, wall=wall)
        return Q, QD, wall, step


def velocity_residual(model, Q, QD, times, rows):
    """Max over the instants of the scaled velocity residual |Phi_q qd - nu|
    of the constraint ``rows``, relative to the run's fastest rate (the
    largest |omega| and |v| / L of the engine's own velocities)."""
    n = Q.shape[1] // 3
    w = np.abs(QD[:, 2::3]).max(initial=0.0)
    v = np.hypot(QD[:, 0::3], QD[:, 1::3]).max(initial=0.0) / model.length
    rate = max(w, v)
    if n == 0 or rate == 0.0:
        return 0.0
    worst = 0.0
    for i, (q, qd, t) in enumerate(zip(Q, QD, times)):
        if not i % CHECK_EVERY:
            in_time(t)   # the run's time limit (Adapter.run) holds for its checks too
        r = model.jacobian(q, t, sparse=False) @ qd - model.nu(t)
        worst = max(worst, float(model.scaled_residual(r)[rows].max(initial=0.0)))
    return worst / rate


ADAPTER = PymunkAdapter()
