"""The mechanisms of issue 14's peer comparison, each as a kinem case and as a
pylinkage 1.3 linkage with the same geometry, drive and output instants, and
the hand-tight slider-crank floor (``floor_slider_crank``).

Every mechanism turns its crank once at OMEGA rad/s from PHI0 in INSTANTS
output instants: positions, velocities and accelerations of every point.
pylinkage (closed-form dyads, numba: ``Linkage.step_fast_with_kinematics``)
is a benchmark-only dependency (``pip install -e .[bench]``).
"""
import math

import numba
import numpy as np

INSTANTS = 500
OMEGA = 2.0
PHI0 = 0.5
DT = 2 * math.pi / OMEGA / INSTANTS          # one crank turn in INSTANTS steps
END = DT * (INSTANTS - 1)                    # kinem: INSTANTS output instants t = 0 .. END


def circles(p1, r1, p2, r2, pick):
    """The intersection of circle (p1, r1) and circle (p2, r2) (complex
    points) that ``pick`` (a key on complex numbers) ranks first."""
    d = p2 - p1
    D = abs(d)
    a = (D * D + r1 * r1 - r2 * r2) / (2 * D)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    both = [p1 + (a + s * 1j * h) * d / D for s in (1.0, -1.0)]
    return min(both, key=pick)


def _polar(z):
    return [z.real, z.imag]


# -- kinem cases -----------------------------------------------------------------------------------

def _case(name, bodies, points, revolutes, extra=()):
    """A case dict: ``bodies`` name -> (origin, phi); ``revolutes`` (name, i,
    si, j, sj) with local points; the crank driven at OMEGA from PHI0."""
    return {
        "name": name, "units": {"length": "m"}, "time": {"end": END, "steps": INSTANTS - 1},
        "bodies": {"ground": {"q": [0.0, 0.0, 0.0]}} | {k: {"q": [o.real, o.imag, phi]} for k, (o, phi) in bodies.items()},
        "points": {k: {"body": b, "at": _polar(at)} for k, (b, at) in points.items()},
        "constraints": [{"type": "ground", "body": "ground"}]
        + [{"type": "revolute", "name": n, "i": i, "si": _polar(si), "j": j, "sj": _polar(sj)} for n, i, si, j, sj in revolutes]
        + list(extra)
        + [{"type": "driver", "name": "crank-drive", "body": "crank", "coord": "phi", "d": {"poly": [PHI0, OMEGA]}}],
    }


def _local(z, origin, phi):
    return (z - origin) * complex(math.cos(-phi), math.sin(-phi))


def _body(frm, to):
    """A link body from joint ``frm`` towards ``to``: (origin, phi)."""
    return frm, math.atan2((to - frm).imag, (to - frm).real)


# slider-crank: crank r about O, rod l, slider on the x axis left of the crank pin
R, L_ROD = 0.1, 0.3


def slider_crank_geometry(phi):
    B = R * complex(math.cos(phi), math.sin(phi))
    A = B.real - math.sqrt(L_ROD**2 - B.imag**2)
    return B, complex(A, 0.0)


def slider_crank_case():
    B, A = slider_crank_geometry(PHI0)
    bodies = {"crank": _body(0j, B), "rod": _body(B, A), "slider": (A, 0.0)}
    rev = [("O", "ground", 0j, "crank", 0j), ("B", "crank", R + 0j, "rod", 0j), ("A", "rod", L_ROD + 0j, "slider", 0j)]
    trans = {"type": "translational", "name": "T", "i": "ground", "si": [0.0, 0.0], "qi": [R, 0.0],
             "j": "slider", "sj": [0.0, 0.0]}
    return _case("slider-crank", bodies, {"B": ("crank", R + 0j), "A": ("slider", 0j)}, rev, [trans])


# four-bar with a coupler point P: crank a about O2, coupler b, rocker c about O4 = (g, 0)
FA, FB, FC, FG = 0.1, 0.3, 0.22, 0.2
P_DIST, P_ANGLE = 0.15, 0.3      # P from A at this distance and angle from A -> B


def four_bar_geometry(phi):
    A = FA * complex(math.cos(phi), math.sin(phi))
    B = circles(A, FB, complex(FG, 0), FC, pick=lambda z: -z.imag)   # B above the ground line
    return A, B, A + P_DIST * (B - A) / abs(B - A) * complex(math.cos(P_ANGLE), math.sin(P_ANGLE))


def four_bar_case():
    A, B, P = four_bar_geometry(PHI0)
    cp = _body(A, B)
    bodies = {"crank": _body(0j, A), "coupler": cp, "rocker": _body(complex(FG, 0), B)}
    rev = [("O2", "ground", 0j, "crank", 0j), ("A", "crank", FA + 0j, "coupler", 0j),
           ("B", "coupler", FB + 0j, "rocker", FC + 0j), ("O4", "rocker", 0j, "ground", complex(FG, 0))]
    return _case("four-bar", bodies, {"A": ("crank", FA + 0j), "B": ("rocker", FC + 0j),
                                      "P": ("coupler", _local(P, *cp))}, rev)


# Theo Jansen's leg: crank m about O, frame pivot Q = (-a, -l), links j, k, b, c, d, e, f, g, h, i
J = dict(a=38.0, b=41.5, c=39.3, d=40.1, e=55.8, f=39.4, g=36.7, h=65.7, i=49.0, j=50.0, k=61.9, l=7.8, m=15.0)
QJ = complex(-J["a"], -J["l"])


def jansen_geometry(phi):
    C = J["m"] * complex(math.cos(phi), math.sin(phi))
    B = circles(C, J["j"], QJ, J["b"], pick=lambda z: -z.imag)       # upper joint
    D = circles(C, J["k"], QJ, J["c"], pick=lambda z: z.imag)        # lower joint
    E = circles(B, J["e"], QJ, J["d"], pick=lambda z: z.real)        # left of the frame pivot
    F = circles(E, J["f"], D, J["g"], pick=lambda z: z.real)
    G = circles(F, J["i"], D, J["h"], pick=lambda z: z.imag)         # the foot, lowest
    return C, B, D, E, F, G


def jansen_case():
    C, B, D, E, F, G = jansen_geometry(PHI0)
    tri, foot = _body(QJ, B), _body(D, F)
    bodies = {"crank": _body(0j, C), "linkj": _body(C, B), "linkk": _body(C, D), "tri": tri,
              "linkc": _body(QJ, D), "linkf": _body(E, F), "foot": foot}
    m = J["m"] + 0j
    rev = [("O", "ground", 0j, "crank", 0j), ("C1", "crank", m, "linkj", 0j), ("C2", "crank", m, "linkk", 0j),
           ("B", "linkj", J["j"] + 0j, "tri", J["b"] + 0j), ("Q1", "ground", QJ, "tri", 0j),
           ("Q2", "ground", QJ, "linkc", 0j), ("D1", "linkk", J["k"] + 0j, "linkc", J["c"] + 0j),
           ("D2", "linkc", J["c"] + 0j, "foot", 0j), ("E", "tri", _local(E, *tri), "linkf", 0j),
           ("F", "linkf", J["f"] + 0j, "foot", J["g"] + 0j)]
    points = {"C": ("crank", m), "B": ("linkj", J["j"] + 0j), "D": ("linkk", J["k"] + 0j),
              "E": ("linkf", 0j), "F": ("linkf", J["f"] + 0j), "G": ("foot", _local(G, *foot))}
    case = _case("jansen", bodies, points, rev)
    case["units"] = {"length": "mm"}
    return case


# -- pylinkage ------------------------------------------------------------------------------------

def pylinkage_linkage(name):
    """(linkage, crank, joint names in output order) built with pylinkage 1.3's
    component API; position hints pick the same assembly as the kinem case."""
    from pylinkage.actuators import Crank
    from pylinkage.components import Ground
    from pylinkage.dyads import FixedDyad, RRPDyad, RRRDyad
    from pylinkage.simulation import Linkage

    step = OMEGA * DT  # rad per step
    if name == "slider-crank":
        O, L1, L2 = Ground(0.0, 0.0, name="O"), Ground(-1.0, 0.0, name="L1"), Ground(1.0, 0.0, name="L2")
        cr = Crank(anchor=O, radius=R, angular_velocity=step, initial_angle=PHI0, name="B")
        A = slider_crank_geometry(PHI0)[1]
        sl = RRPDyad(revolute_anchor=cr.output, line_anchor1=L1, line_anchor2=L2, distance=L_ROD, x=A.real, y=0.0, name="A")
        parts = [O, L1, L2, cr, sl]
    elif name == "four-bar":
        O2, O4 = Ground(0.0, 0.0, name="O2"), Ground(FG, 0.0, name="O4")
        cr = Crank(anchor=O2, radius=FA, angular_velocity=step, initial_angle=PHI0, name="A")
        _, B, _ = four_bar_geometry(PHI0)
        b = RRRDyad(cr.output, O4, distance1=FB, distance2=FC, x=B.real, y=B.imag, name="B")
        p = FixedDyad(cr.output, b, distance=P_DIST, angle=P_ANGLE, name="P")
        parts = [O2, O4, cr, b, p]
    else:
        O, Q = Ground(0.0, 0.0, name="O"), Ground(QJ.real, QJ.imag, name="Q")
        cr = Crank(anchor=O, radius=J["m"], angular_velocity=step, initial_angle=PHI0, name="C")
        _, B, D, E, F, G = jansen_geometry(PHI0)
        b = RRRDyad(cr.output, Q, distance1=J["j"], distance2=J["b"], x=B.real, y=B.imag, name="B")
        d = RRRDyad(cr.output, Q, distance1=J["k"], distance2=J["c"], x=D.real, y=D.imag, name="D")
        e = RRRDyad(b, Q, distance1=J["e"], distance2=J["d"], x=E.real, y=E.imag, name="E")
        f = RRRDyad(e, d, distance1=J["f"], distance2=J["g"], x=F.real, y=F.imag, name="F")
        g = RRRDyad(f, d, distance1=J["i"], distance2=J["h"], x=G.real, y=G.imag, name="G")
        parts = [O, Q, cr, b, d, e, f, g]
    link = Linkage(parts, name=name)
    link.set_input_velocity(cr, omega=OMEGA)
    return link, [p.name for p in parts]


def pylinkage_run(name):
    """Positions, velocities and accelerations (INSTANTS, joints, 2) and the
    joint names, building the linkage and stepping it."""
    link, names = pylinkage_linkage(name)
    p, v, a = link.step_fast_with_kinematics(iterations=INSTANTS, dt=1.0)
    return p, v, a, names


# -- the floor: the slider-crank's Newton/LU analysis written tightly in numba --------------------

@numba.njit(cache=True)
def _lu_solve(Jm, piv, b):
    n = b.shape[0]
    for j in range(n):  # the row interchanges (applied to whole rows of the factors, as LAPACK's getrf)
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
    for j in range(n):
        for i in range(j + 1, n):
            b[i] -= Jm[i, j] * b[j]
    for j in range(n - 1, -1, -1):
        b[j] /= Jm[j, j]
        for i in range(j):
            b[i] -= Jm[i, j] * b[j]


@numba.njit(cache=True, fastmath=False)
def march(q0, qd0, qdd0, phi0, w, r, l, h, steps, tol, Q, QD, QDD):
    """Coordinates (x, y, phi) of ground, crank (origin at O), rod (origin
    at B) and slider (origin at A): 12 equations (ground 3, O 2, B 2, A 2,
    slider on the x axis 2, driver 1), Newton from the Taylor predictor,
    dense 12 x 12 LU with partial pivoting, one final correction,
    velocities and accelerations from the same LU. Returns Newton
    iterations in all."""
    n = 12
    Jm = np.zeros((n, n))
    piv = np.zeros(n, np.int64)
    f = np.zeros(n)
    q = q0.copy()
    qd = qd0.copy()
    qdd = qdd0.copy()
    scale = np.array([r, r, 1.0, r, r, r, r, r, r, r, 1.0, 1.0])  # residual scales (length rows by L ~ r)
    total = 0
    for k in range(steps):
        t = k * h
        if k > 0:
            for i in range(n):
                q[i] += h * qd[i] + 0.5 * h * h * qdd[i]
        for it in range(26):
            c1, s1, c2, s2 = np.cos(q[5]), np.sin(q[5]), np.cos(q[8]), np.sin(q[8])
            f[0] = q[0]; f[1] = q[1]; f[2] = q[2]
            f[3] = q[3] - q[0]; f[4] = q[4] - q[1]
            f[5] = q[6] - q[3] - r * c1; f[6] = q[7] - q[4] - r * s1
            f[7] = q[9] - q[6] - l * c2; f[8] = q[10] - q[7] - l * s2
            f[9] = q[10] - q[1]; f[10] = q[11] - q[2]; f[11] = q[5] - phi0 - w * t
            worst = 0.0
            for i in range(n):
                worst = max(worst, abs(f[i]) / scale[i])
            # the Jacobian at q (also after convergence: the final correction and the rates use it)
            Jm[:, :] = 0.0
            Jm[0, 0] = 1.0; Jm[1, 1] = 1.0; Jm[2, 2] = 1.0
            Jm[3, 3] = 1.0; Jm[3, 0] = -1.0; Jm[4, 4] = 1.0; Jm[4, 1] = -1.0
            Jm[5, 6] = 1.0; Jm[5, 3] = -1.0; Jm[5, 5] = r * s1
            Jm[6, 7] = 1.0; Jm[6, 4] = -1.0; Jm[6, 5] = -r * c1
            Jm[7, 9] = 1.0; Jm[7, 6] = -1.0; Jm[7, 8] = l * s2
            Jm[8, 10] = 1.0; Jm[8, 7] = -1.0; Jm[8, 8] = -l * c2
            Jm[9, 10] = 1.0; Jm[9, 1] = -1.0; Jm[10, 11] = 1.0; Jm[10, 2] = -1.0; Jm[11, 5] = 1.0
            for j in range(n):  # LU, partial pivoting
                p = j
                for i in range(j + 1, n):
                    if abs(Jm[i, j]) > abs(Jm[p, j]):
                        p = i
                piv[j] = p
                if p != j:
                    for c in range(n):
                        Jm[j, c], Jm[p, c] = Jm[p, c], Jm[j, c]
                d = 1.0 / Jm[j, j]
                for i in range(j + 1, n):
                    m = Jm[i, j] * d
                    if m != 0.0:
                        Jm[i, j] = m
                        for c in range(j + 1, n):
                            Jm[i, c] -= m * Jm[j, c]
            for i in range(n):
                f[i] = -f[i]
            _lu_solve(Jm, piv, f)
            for i in range(n):
                q[i] += f[i]           # a Newton step, or the final correction once converged
            if worst <= tol:
                break
            total += 1
        c1, s1, c2, s2 = np.cos(q[5]), np.sin(q[5]), np.cos(q[8]), np.sin(q[8])
        qd[:] = 0.0
        qd[11] = w
        _lu_solve(Jm, piv, qd)
        g = qdd
        g[:] = 0.0
        g[5] = -r * c1 * qd[5] * qd[5]; g[6] = -r * s1 * qd[5] * qd[5]
        g[7] = -l * c2 * qd[8] * qd[8]; g[8] = -l * s2 * qd[8] * qd[8]
        _lu_solve(Jm, piv, g)
        Q[k] = q
        QD[k] = qd
        QDD[k] = qdd
    return total


def floor_slider_crank(instants=INSTANTS):
    """The slider-crank of ``slider_crank_case`` over ``instants`` output
    instants, hand-tight: (q, qd, qdd) arrays (instants, 12) and the Newton
    iterations in all. Starts from the assembled configuration at t = 0 with
    its rates (as a warm analysis does)."""
    B, A = slider_crank_geometry(PHI0)
    p2 = math.atan2((A - B).imag, (A - B).real)
    q0 = np.array([0, 0, 0, 0, 0, PHI0, B.real, B.imag, p2, A.real, 0, 0], float)
    Q, QD, QDD = (np.empty((instants, 12)) for _ in range(3))
    it = march(q0, np.zeros(12), np.zeros(12), PHI0, OMEGA, R, L_ROD, DT, instants, 1e-12, Q, QD, QDD)
    return Q, QD, QDD, it
