"""Mechanisms not in cases/ (issue 24): a Watt II six-bar, a Klann-type
(Stephenson III) leg linkage, a Geneva wheel over its engaged quarter turn
and a geared five-bar. Each is built assembled at t = 0 (dyads solved in the
plane) and driven at ``f`` times its base speed for 1/f of the time, so the
motion and the output instants are the same at every f; ``k`` scales every
length."""
import math

import numpy as np

STEPS = 100


def dyad(p, q, r1, r2, sign=1.0):
    """The point x with |x - p| = r1 and |x - q| = r2, on the side ``sign``
    of the line p -> q."""
    d = abs(q - p)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = (q - p) / d
    return p + a * u + sign * h * 1j * u


def _local(origin, phi, point):
    """point (complex, world) in the frame of a body at origin with angle phi."""
    z = (point - origin) * np.exp(-1j * phi)
    return [float(z.real), float(z.imag)]


def _q(z, phi):
    return {"q": [float(z.real), float(z.imag), float(phi)]}


def _case(name, unit, bodies, points, constraints, w, phi0, f, end):
    cons = [{"type": "ground", "body": "ground"}] + constraints
    cons.append({"type": "driver", "name": "drive", "body": "crank", "coord": "phi",
                 "d": {"poly": [phi0, w * f]}})
    return {"name": name, "units": {"length": unit}, "time": {"end": end / f, "steps": STEPS},
            "bodies": bodies, "points": points, "constraints": cons}


def _rev(name, i, si, j, sj):
    return {"type": "revolute", "name": name, "i": i, "si": si, "j": j, "sj": sj}


def watt2(f=1.0, k=1.0):
    """Watt II six-bar: a crank-rocker four-bar O2-A-B-O4 whose rocker
    (ternary) drives a second four-bar O4-C-D-O6; the crank turns once."""
    a, b, c, c2, e, g = 40 * k, 120 * k, 90 * k, 70 * k, 150 * k, 110 * k
    o2, o4, o6 = 0j, 160 * k + 0j, 120 * k - 150j * k
    th = 0.3
    A = o2 + a * np.exp(1j * th)
    B = dyad(A, o4, b, c, 1.0)
    p4 = np.angle(B - o4)
    C = o4 + c2 * np.exp(1j * (p4 + math.pi * 0.8))
    D = dyad(C, o6, e, g, -1.0)
    p3, p5, p6 = np.angle(B - A), np.angle(D - C), np.angle(D - o6)
    bodies = {"ground": _q(0j, 0.0), "crank": _q(o2, th), "coupler": _q(A, p3), "rocker": _q(o4, p4),
              "coupler2": _q(C, p5), "output": _q(o6, p6)}
    points = {"B": {"body": "rocker", "at": _local(o4, p4, B)}, "C": {"body": "rocker", "at": _local(o4, p4, C)},
              "D": {"body": "output", "at": _local(o6, p6, D)}}
    cons = [_rev("O2", "ground", [0.0, 0.0], "crank", [0.0, 0.0]),
            _rev("A", "crank", [a, 0.0], "coupler", [0.0, 0.0]),
            _rev("B", "coupler", [b, 0.0], "rocker", "B"),
            _rev("O4", "rocker", [0.0, 0.0], "ground", [o4.real, o4.imag]),
            _rev("C", "rocker", "C", "coupler2", [0.0, 0.0]),
            _rev("D", "coupler2", [e, 0.0], "output", "D"),
            _rev("O6", "output", [0.0, 0.0], "ground", [o6.real, o6.imag])]
    return _case("watt2", "mm", bodies, points, cons, 2 * math.pi, th, f, 1.0)


def klann(f=1.0, k=1.0):
    """Klann-type leg (Stephenson III six-bar): crank O-A, ternary arm
    A-B-C with rocker P1-B, ternary leg C-E-F with rocker P2-E; the foot F
    is a named point. The crank turns once."""
    a, ab, p1b, ce, p2e = 30 * k, 90 * k, 70 * k, 130 * k, 100 * k   # |C - P2| stays in 171..195
    o, p1, p2 = 0j, -50 * k + 60j * k, -90 * k + 10j * k
    th = 0.5
    A = o + a * np.exp(1j * th)
    B = dyad(A, p1, ab, p1b, -1.0)
    p3 = np.angle(B - A)
    C = A + 1.3 * (B - A) * np.exp(-0.6j)
    E = dyad(C, p2, ce, p2e, -1.0)
    p5 = np.angle(E - C)
    F = C + 1.6 * (E - C) * np.exp(1.1j)
    p4, p6 = np.angle(B - p1), np.angle(E - p2)
    bodies = {"ground": _q(0j, 0.0), "crank": _q(o, th), "arm": _q(A, p3), "rocker1": _q(p1, p4),
              "leg": _q(C, p5), "rocker2": _q(p2, p6)}
    points = {"C": {"body": "arm", "at": _local(A, p3, C)}, "F": {"body": "leg", "at": _local(C, p5, F)}}
    cons = [_rev("O", "ground", [0.0, 0.0], "crank", [0.0, 0.0]),
            _rev("A", "crank", [a, 0.0], "arm", [0.0, 0.0]),
            _rev("B", "arm", [ab, 0.0], "rocker1", [p1b, 0.0]),
            _rev("P1", "rocker1", [0.0, 0.0], "ground", [p1.real, p1.imag]),
            _rev("C", "arm", "C", "leg", [0.0, 0.0]),
            _rev("E", "leg", [ce, 0.0], "rocker2", [p2e, 0.0]),
            _rev("P2", "rocker2", [0.0, 0.0], "ground", [p2.real, p2.imag])]
    return _case("klann", "mm", bodies, points, cons, 2 * math.pi, th, f, 1.0)


def geneva(f=1.0, k=1.0):
    """Four-slot Geneva wheel over its engaged quarter turn: the drive pin
    (crank radius a) slides in a radial slot of the wheel (centre distance
    a sqrt 2); the crank turns from -40 to +40 degrees about the line of
    centres (the pin leaves the slot at 45)."""
    a = 50 * k
    c = a * math.sqrt(2)
    w0 = c + 0j
    th = -math.radians(40)
    P = a * np.exp(1j * th)
    pw = np.angle(P - w0)
    bodies = {"ground": _q(0j, 0.0), "crank": _q(0j, th), "wheel": _q(w0, pw)}
    points = {"pin": {"body": "crank", "at": [a, 0.0]}, "rim": {"body": "wheel", "at": [0.0, 0.6 * a]}}
    cons = [_rev("O", "ground", [0.0, 0.0], "crank", [0.0, 0.0]),
            _rev("W", "wheel", [0.0, 0.0], "ground", [c, 0.0]),
            {"type": "revolute-translational", "name": "slot", "i": "crank", "si": "pin", "j": "wheel",
             "sj": [0.0, 0.0], "qj": [a, 0.0]}]
    return _case("geneva", "mm", bodies, points, cons, math.radians(80), th, f, 1.0)


def geared_five_bar(f=1.0, k=1.0):
    """Geared five-bar: crank 1 about O1 drives crank 2 about O2 through a
    gear pair (radii 30 and 45, so 2:3); links from each crank meet at P."""
    r1, r2, a1, a2, l1, l2 = 30 * k, 45 * k, 25 * k, 35 * k, 110 * k, 100 * k
    o1, o2 = 0j, (r1 + r2) + 0j
    th1, th2 = 0.4, 1.2
    A, B = o1 + a1 * np.exp(1j * th1), o2 + a2 * np.exp(1j * th2)
    P = dyad(A, B, l1, l2, 1.0)
    p3, p4 = np.angle(P - A), np.angle(P - B)
    bodies = {"ground": _q(0j, 0.0), "crank": _q(o1, th1), "crank2": _q(o2, th2), "link1": _q(A, p3),
              "link2": _q(B, p4)}
    points = {"P": {"body": "link1", "at": [l1, 0.0]}}
    cons = [_rev("O1", "ground", [0.0, 0.0], "crank", [0.0, 0.0]),
            _rev("O2", "crank2", [0.0, 0.0], "ground", [o2.real, 0.0]),
            {"type": "gear", "name": "mesh", "i": "crank", "ri": r1, "j": "crank2", "rj": r2},
            _rev("A", "crank", [a1, 0.0], "link1", [0.0, 0.0]),
            _rev("B", "crank2", [a2, 0.0], "link2", [0.0, 0.0]),
            _rev("P", "link1", "P", "link2", [l2, 0.0])]
    return _case("geared_five_bar", "mm", bodies, points, cons, 2 * math.pi, th1, f, 0.5)


MECHANISMS = {"watt2": watt2, "klann": klann, "geneva": geneva, "geared_five_bar": geared_five_bar}
