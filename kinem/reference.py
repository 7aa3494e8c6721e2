"""Closed-form kinematics used as references by the tests, the report and
the stress suite: the slider-crank and the four-bar with exact first and
second time derivatives (chain rule, no numerical differencing), and the
IFToMM N-four-bar benchmark (a chain of parallelograms) as a case with its
exact solution."""
import numpy as np


def slider_crank(theta, w, a, r, l, e=0.0, side=-1.0):
    """Crank pin B = r (cos theta, sin theta) about the origin, slider pin A on
    the line y = e on the side ``side`` (-1: left of B), rod of length l.
    theta, w, a: crank angle, rate and acceleration (arrays).
    Returns dict of xA, vA, aA (slider) and rod angle phi, omega, alpha, where
    the rod angle is that of the vector A -> B."""
    xB, yB = r * np.cos(theta), r * np.sin(theta)
    vxB, vyB = -yB * w, xB * w
    axB, ayB = -xB * w * w - yB * a, -yB * w * w + xB * a
    # side = -1: A left of B, rod angle phi = asin((yB - e)/l); side = +1: phi = pi - asin(...)
    s = (yB - e) / l
    psi = np.arcsin(s)
    c = np.cos(psi)
    dpsi = vyB / (l * c)
    ddpsi = (ayB + l * s * dpsi**2) / (l * c)
    phi = psi if side < 0 else np.pi - psi
    dphi, ddphi = (dpsi, ddpsi) if side < 0 else (-dpsi, -ddpsi)
    xA = xB - l * np.cos(phi)
    vA = vxB + l * np.sin(phi) * dphi
    aA = axB + l * np.cos(phi) * dphi**2 + l * np.sin(phi) * ddphi
    return {"x": xA, "vx": vA, "ax": aA, "phi": phi, "omega": dphi, "alpha": ddphi}


def four_bar(th2, w2, a2, a, b, c, d, sign=1.0):
    """Crank a about O2 = (0, 0), coupler b, rocker c about O4 = (d, 0).
    sign = +1 picks the assembly with B to the left of the line A -> O4.
    Returns angles th3 (coupler A -> B), th4 (rocker O4 -> B), their rates and
    accelerations."""
    A = a * np.exp(1j * th2)
    dv = d - A
    D = np.abs(dv)
    along = (D * D + b * b - c * c) / (2 * D)
    h = np.sqrt(b * b - along * along)
    B = A + (along + 1j * sign * h) * dv / D
    th3 = np.angle(B - A)
    th4 = np.angle(B - d)
    s34 = np.sin(th3 - th4)
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN on a change point itself
        return _rates(th2, w2, a2, a, b, c, B, th3, th4, s34)


def _rates(th2, w2, a2, a, b, c, B, th3, th4, s34):
    w3 = a * w2 * np.sin(th4 - th2) / (b * s34)
    w4 = a * w2 * np.sin(th2 - th3) / (c * -s34)
    e2, e3, e4 = np.exp(1j * th2), np.exp(1j * th3), np.exp(1j * th4)
    R = a * a2 * e2 + 1j * (a * w2 * w2 * e2 + b * w3 * w3 * e3 - c * w4 * w4 * e4)
    a3 = -(np.conj(e4) * R).imag / (b * s34)
    a4 = (np.conj(e3) * R).imag / (c * -s34)
    return {"th3": th3, "w3": w3, "a3": a3, "th4": th4, "w4": w4, "a4": a4, "B": B}


def wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def rel_error(got, ref, angle=False):
    """Max error over the run relative to the run's peak magnitude of the
    reference (a rate that crosses zero has no pointwise relative error)."""
    diff = wrap(got - ref) if angle else got - ref
    return float(np.max(np.abs(diff)) / max(np.max(np.abs(ref)), 1e-300))


def n_four_bar(n: int, omega: float = 1.0, turns: float = 0.5, steps_per_turn: int = 200,
               start: float = 0.5) -> dict:
    """The N-four-bar of the IFToMM benchmark library as a case dict: N+1
    cranks of 1 m pinned to the ground at x = 0, 1, ..., N, N couplers of 1 m
    joining their tips; crank 0 driven phi = pi/2 + start - omega t, so the
    chain passes the horizontal position (every bar parallel, Jacobian rank
    short by N) after (pi/2 + start)/omega. Exact solution: every crank
    angle equals the driver, every coupler keeps phi = 0."""
    end = turns * 2 * np.pi / omega
    phi0 = np.pi / 2 + start
    bodies = {"ground": {"q": [0.0, 0.0, 0.0]}}
    cons = [{"type": "ground", "body": "ground"}]
    for k in range(n + 1):
        bodies[f"crank{k}"] = {"q": [float(k), 0.0, phi0]}
        cons.append({"type": "revolute", "name": f"G{k}", "i": "ground", "si": [float(k), 0.0],
                     "j": f"crank{k}", "sj": [0.0, 0.0]})
    tip = np.exp(1j * phi0)
    for k in range(n):
        bodies[f"coupler{k}"] = {"q": [k + tip.real, tip.imag, 0.0]}
        cons.append({"type": "revolute", "name": f"L{k}", "i": f"crank{k}", "si": [1.0, 0.0],
                     "j": f"coupler{k}", "sj": [0.0, 0.0]})
        cons.append({"type": "revolute", "name": f"R{k}", "i": f"crank{k + 1}", "si": [1.0, 0.0],
                     "j": f"coupler{k}", "sj": [1.0, 0.0]})
    cons.append({"type": "driver", "name": "drive", "body": "crank0", "coord": "phi",
                 "d": {"poly": [phi0, -omega]}})
    return {"name": f"n_four_bar_{n}", "units": {"length": "m"},
            "description": f"IFToMM N-four-bar, N = {n}: a chain of parallelograms driven through the horizontal position",
            "time": {"end": end, "steps": max(1, int(round(turns * steps_per_turn)))},
            "bodies": bodies, "constraints": cons}


# -- mechanisms as case dicts (the tests, the stress suite and the benchmarks build them) -------

def slider_crank_case(r, l, e=0.0, fn=None, phi0=0.5, end=2.0, steps=100, crank_origin=0.0, rod_origin=0.0,
                      name="slider-crank", unit="m"):
    """Offset slider-crank: crank r about the origin, rod l, slider on y = e
    left of the crank pin. Body origins along the links at the fractions
    crank_origin, rod_origin (from mid-link); fn: the crank's d(t) (default
    constant speed 2 rad/s from phi0). Estimates are slightly off on purpose."""
    fn = fn if fn is not None else {"poly": [phi0, 2.0]}
    ref = slider_crank(np.array([phi0]), np.zeros(1), np.zeros(1), r, l, e)
    psi, xA = ref["phi"][0], ref["x"][0]
    cr, ro = crank_origin, rod_origin
    c0 = cr * r * np.exp(1j * phi0)
    r0 = xA + 1j * e + (0.5 + ro) * l * np.exp(1j * psi)
    return {
        "name": name, "units": {"length": unit}, "time": {"end": end, "steps": steps},
        "bodies": {
            "ground": {"q": [0.0, 0.0, 0.0]},
            "crank": {"q": [c0.real, c0.imag + 0.01 * r, phi0]},
            "rod": {"q": [r0.real + 0.02 * r, r0.imag, psi + 0.01]},
            "slider": {"q": [xA - 0.01 * r, e, 0.0]},
        },
        "points": {"B": {"body": "crank", "at": [(1 - cr) * r, 0.0]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "name": "O", "i": "ground", "si": [0.0, 0.0], "j": "crank", "sj": [-cr * r, 0.0]},
            {"type": "revolute", "name": "B", "i": "crank", "si": [(1 - cr) * r, 0.0], "j": "rod", "sj": [(0.5 - ro) * l, 0.0]},
            {"type": "revolute", "name": "A", "i": "rod", "si": [-(0.5 + ro) * l, 0.0], "j": "slider", "sj": [0.0, 0.0]},
            {"type": "translational", "name": "T", "i": "ground", "si": [0.0, e], "qi": [r, e], "j": "slider", "sj": [0.0, 0.0]},
            {"type": "driver", "name": "crank-drive", "body": "crank", "coord": "phi", "d": fn},
        ],
    }


def four_bar_case(a, b, c, g, fn=None, phi0=0.5, sign=1.0, end=2.0, steps=100, name="four-bar", unit="m"):
    """Four-bar: crank a about (0, 0), coupler b, rocker c about (g, 0); body
    origins at link midpoints; assembly ``sign`` as in four_bar()."""
    fn = fn if fn is not None else {"poly": [phi0, 2.0]}
    ref = four_bar(np.array([phi0]), np.zeros(1), np.zeros(1), a, b, c, g, sign)
    th3, th4 = ref["th3"][0], ref["th4"][0]
    A = a * np.exp(1j * phi0)
    cm = A + b / 2 * np.exp(1j * th3)
    rm = g + c / 2 * np.exp(1j * th4)
    return {
        "name": name, "units": {"length": unit}, "time": {"end": end, "steps": steps},
        "bodies": {
            "ground": {"q": [0.0, 0.0, 0.0]},
            "crank": {"q": [A.real / 2, A.imag / 2, phi0]},
            "coupler": {"q": [cm.real, cm.imag, th3 + 0.02]},
            "rocker": {"q": [rm.real, rm.imag, th4 - 0.02]},
        },
        "points": {"A": {"body": "crank", "at": [a / 2, 0.0]}, "B": {"body": "rocker", "at": [c / 2, 0.0]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "name": "O2", "i": "ground", "si": [0.0, 0.0], "j": "crank", "sj": [-a / 2, 0.0]},
            {"type": "revolute", "name": "A", "i": "crank", "si": [a / 2, 0.0], "j": "coupler", "sj": [-b / 2, 0.0]},
            {"type": "revolute", "name": "B", "i": "coupler", "si": [b / 2, 0.0], "j": "rocker", "sj": [c / 2, 0.0]},
            {"type": "revolute", "name": "O4", "i": "rocker", "si": [-c / 2, 0.0], "j": "ground", "sj": [g, 0.0]},
            {"type": "driver", "name": "crank-drive", "body": "crank", "coord": "phi", "d": fn},
        ],
    }


def quick_return(theta, oc, rc, rocker, link, height, w=0.0, a=0.0):
    """Positions of the crank-shaper of Sec. 4.4.2 (model 3 geometry): crank
    pivot O = (0, 0), rocker pivot C = (0, -oc), crank rc, rocker length
    ``rocker`` through the crank pin A, link BD of length ``link`` to the tool
    D on y = height, D right of B. Returns A, B, D (complex) and the angles;
    with the crank's rate w and acceleration a also vA, aA, vB, aB, vD, aD
    (chain rule: the rocker's angle is arg(A - C), D.x = B.x + S with
    S = sqrt(link^2 - (height - B.y)^2))."""
    A = rc * np.exp(1j * theta)
    vA, aA = 1j * w * A, (1j * a - w * w) * A
    C = -1j * oc
    W = A - C
    phr = np.angle(W)
    dphr = (vA / W).imag                           # d/dt log W = |W|'/|W| + i phr'
    ddphr = (aA / W - (vA / W) ** 2).imag
    B = C + rocker * np.exp(1j * phr)
    vB, aB = 1j * dphr * (B - C), (1j * ddphr - dphr**2) * (B - C)
    u = height - B.imag
    S = np.sqrt(link**2 - u**2)
    dS = u * vB.imag / S
    ddS = (-vB.imag**2 + u * aB.imag) / S - dS**2 / S
    D = B.real + S + 1j * height
    return {"A": A, "B": B, "D": D, "rocker": phr, "link": np.angle(D - B),
            "vA": vA, "aA": aA, "vB": vB, "aB": aB, "vD": vB.real + dS, "aD": aB.real + ddS}


def quick_return_case(oc, rc, rocker, link, height, fn=None, phi0=0.52, end=2.0, steps=100, name="quick-return",
                      unit="mm"):
    """Model 3 of Sec. 4.4.2 (ground, rocker, crank, tool; two revolutes, a
    translational, a revolute-revolute BD, a revolute-translational A) for any
    assemblable geometry; ground frame at O."""
    fn = fn if fn is not None else {"poly": [phi0, 3.0]}
    p = quick_return(np.array([phi0]), oc, rc, rocker, link, height)
    phr = p["rocker"][0]
    rmid = -1j * oc + rocker / 2 * np.exp(1j * phr)
    D = p["D"][0]
    return {
        "name": name, "units": {"length": unit}, "time": {"end": end, "steps": steps},
        "bodies": {
            "ground": {"q": [0.0, 0.0, 0.0]},
            "rocker": {"q": [rmid.real, rmid.imag, phr]},
            "crank": {"q": [rc / 2 * np.cos(phi0), rc / 2 * np.sin(phi0), phi0]},
            "tool": {"q": [D.real, height, 0.0]},
        },
        "points": {"A": {"body": "crank", "at": [rc / 2, 0.0]}, "B": {"body": "rocker", "at": [rocker / 2, 0.0]},
                   "D": {"body": "tool", "at": [0.0, 0.0]}},
        "constraints": [
            {"type": "ground", "body": "ground"},
            {"type": "revolute", "name": "O", "i": "ground", "si": [0.0, 0.0], "j": "crank", "sj": [-rc / 2, 0.0]},
            {"type": "revolute", "name": "C", "i": "ground", "si": [0.0, -oc], "j": "rocker", "sj": [-rocker / 2, 0.0]},
            {"type": "translational", "name": "T", "i": "ground", "si": [0.0, height], "qi": [rc, height],
             "j": "tool", "sj": "D"},
            {"type": "revolute-revolute", "name": "BD", "i": "rocker", "si": "B", "j": "tool", "sj": "D", "length": link},
            {"type": "revolute-translational", "name": "A", "i": "crank", "si": "A", "j": "rocker",
             "sj": [0.0, 0.0], "qj": [rocker / 4, 0.0]},
            {"type": "driver", "name": "crank-drive", "body": "crank", "coord": "phi", "d": fn},
        ],
    }


# -- gears, racks, pins in slots and cams of Sec. 4.2: the report's closed forms ----------------
# A motion is a triple (value, rate, acceleration) of arrays over the instants; every function
# below maps the driven coordinate's triple to the others' by the chain rule (no differencing).

def drive(f, t):
    """(d(t) - d(0), d'(t), d''(t)) of a driving function of kinem.functions,
    evaluated here with numpy (a Table: scipy's not-a-knot CubicSpline, as
    Sec. 4.2.8 states), not by the compiled core."""
    from scipy.interpolate import CubicSpline

    from .functions import Harmonic, Poly, Table

    t = np.asarray(t, float)
    if isinstance(f, Poly):
        c = np.polynomial.Polynomial(f.coeffs)
        d = (c(t), c.deriv(1)(t), c.deriv(2)(t))
    elif isinstance(f, Harmonic):
        arg = f.omega * t + f.phase
        d = (f.offset + f.amplitude * np.sin(arg), f.amplitude * f.omega * np.cos(arg),
             -f.amplitude * f.omega**2 * np.sin(arg))
    elif isinstance(f, Table):
        sp = CubicSpline(np.asarray(f.t, float), np.asarray(f.value, float))
        d = (sp(t), sp(t, 1), sp(t, 2))
    else:
        raise ValueError(f"no closed form for the driving function {f!r}")
    return (d[0] - d[0][0], d[1], d[2])


def scaled(k, m):
    """k times a motion."""
    return tuple(k * x for x in m)


def turned(z0, pivot, turn):
    """Position, velocity and acceleration (complex) of a body point at z0 at
    t = 0 when its body turns by ``turn`` (a motion) about a fixed pivot."""
    d, w, a = turn
    r = (z0 - pivot) * np.exp(1j * d)
    return pivot + r, 1j * w * r, (1j * a - w * w) * r


def gear_pair(turn_i, ri, rj):
    """Eq. 4.17, spur gears on fixed centres: (phi_i - phi_i^0) rho_i +
    (phi_j - phi_j^0) rho_j = 0, so gear j turns by -rho_i / rho_j times
    gear i's turn."""
    return scaled(-ri / rj, turn_i)


def planetary(turn_sun, r_sun, r_planet, r_ring):
    """Eq. 4.18 on each mesh with the carrier k, the ring fixed: sun-planet
    (external) rho_s (phi_s - phi_k) = -rho_p (phi_p - phi_k), planet-ring
    (internal: both turn the same sense relative to k) rho_p (phi_p - phi_k)
    = rho_r (0 - phi_k). Returns the turns of the carrier,
    rho_s / (rho_s + rho_r) of the sun's, and of the planet,
    (1 - rho_r / rho_p) of the carrier's."""
    carrier = scaled(r_sun / (r_sun + r_ring), turn_sun)
    return carrier, scaled(1.0 - r_ring / r_planet, carrier)


def rack_travel(turn, h):
    """Eqs. 4.19, 4.20: rolling without slip, a pinion turning by phi moves
    the rack relative to its centre by h phi along the pitch line's
    direction u, h the centre's signed distance from the line (positive on
    the side of u turned +90 degrees): the contact point's velocity
    phidot k x (-h n) = h phidot u. A fixed rack: the centre moves by -h phi."""
    return scaled(h, turn)


def circle_x(Y, R, side):
    """Pin on a circular slot x^2 + y^2 = R^2 (Eq. 4.30 with s = R): x =
    side sqrt(R^2 - y^2) and its rates, y a motion (x x' + y y' = 0)."""
    y, vy, ay = Y
    x = side * np.sqrt(R * R - y * y)
    vx = -y * vy / x
    return x, vx, -(vy * vy + y * ay + vx * vx) / x


def polar_spline(theta, s, bc="periodic"):
    """s(theta), s'(theta), s''(theta) of an outline's table (Sec. 4.2.4):
    scipy's CubicSpline with the table's own end conditions, evaluated by
    scipy (not by the compiled core's pieces)."""
    from scipy.interpolate import CubicSpline

    sp = CubicSpline(np.asarray(theta, float), np.asarray(s, float), bc_type=bc)
    return lambda x: (sp(x), sp(x, 1), sp(x, 2))


def pin_in_outline(Y, s, theta0, check=None):
    """Pin on a slot p = s(theta) e^{i theta} (Eq. 4.30) whose y is the motion
    Y: theta solves s(theta) sin(theta) = y at each instant (a bracketed
    scalar root, Brent, from the previous instant's theta; theta0 at t = 0).
    Returns the pin's x (a motion) and theta. Rates: g = s sin, h = s cos:
    theta' = y' / g', theta'' = (y'' - g'' theta'^2) / g', x' = h' theta',
    x'' = h'' theta'^2 + h' theta''. ``check(k)``: called before each
    instant k (the caller's time limit; a root costs about 2 ms, the call
    far less)."""
    from scipy.optimize import brentq

    y, vy, ay = Y
    th = np.empty_like(y)
    prev = theta0
    for k, yk in enumerate(y):
        if check is not None:
            check(k)
        f = lambda x: s(x)[0] * np.sin(x) - yk   # noqa: E731
        step = 0.05
        while f(prev - step) * f(prev + step) > 0:
            step *= 2
            if step > 1.0:
                raise ValueError(f"no slot point at y = {yk:g} near theta = {prev:g}")
        prev = th[k] = brentq(f, prev - step, prev + step, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    s0, s1, s2 = s(th)
    c, n = np.cos(th), np.sin(th)
    g1, g2 = s1 * n + s0 * c, s2 * n + 2 * s1 * c - s0 * n
    h1, h2 = s1 * c - s0 * n, s2 * c - 2 * s1 * n - s0 * c
    w = vy / g1
    al = (ay - g2 * w * w) / g1
    return (s0 * c, h1 * w, h2 * w * w + h1 * al), th


def cam_flat_lift(centre, n, R, side=1.0):
    """Eq. 4.29 for a circular cam and a flat face of normal n (unit,
    complex): the face's height along n is the circle centre's plus side R
    (the eccentric cam's lift e sin(phi) + R); centre a motion (complex)."""
    h, v, a = ((np.conj(n) * z).real for z in centre)
    return h + side * R, v, a


def roller_on_circle(psi, e, rho, side=1.0):
    """Example 4.4: a roller (centre on the y axis through the camshaft) on a
    circular cam whose centre is at e (cos psi, sin psi): the roller centre's
    height d = e sin(psi) + side rho cos(gamma), sin(gamma) = e cos(psi) / rho,
    rho the sum of the radii; psi a motion. With S = rho cos(gamma) =
    sqrt(rho^2 - e^2 cos^2 psi) and u = e^2 sin(psi) cos(psi):
    S' = u psi' / S, S'' = (e^2 cos(2 psi) psi'^2 + u psi'') / S - S'^2 / S."""
    p, w, a = psi
    S = np.sqrt(rho * rho - (e * np.cos(p)) ** 2)
    u = e * e * np.sin(p) * np.cos(p)
    dS = u * w / S
    ddS = (e * e * np.cos(2 * p) * w * w + u * a) / S - dS * dS / S
    return (e * np.sin(p) + side * S, e * np.cos(p) * w + side * dS,
            -e * np.sin(p) * w * w + e * np.cos(p) * a + side * ddS)


def radial_follower(theta, s):
    """Eq. 4.26 for a radial point follower: its tip is at s(theta) from the
    outline's centre, theta the contact's polar angle on the cam (a motion):
    r' = s' theta', r'' = s'' theta'^2 + s' theta''."""
    th, w, a = theta
    s0, s1, s2 = s(th)
    return s0, s1 * w, s2 * w * w + s1 * a
