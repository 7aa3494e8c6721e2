"""The mechanisms of issue 14's peer comparison, each as a kinem case and as a
pylinkage 1.3 linkage with the same geometry, drive and output instants, and
the hand-tight slider-crank floor (``floor_slider_crank``: C,
benchmarks/floor/slider_crank.c, compiled at run time into a temporary
directory with gcc or $CC).

Every mechanism turns its crank once at OMEGA rad/s from PHI0 in INSTANTS
output instants: positions, velocities and accelerations of every point.
pylinkage (closed-form dyads, numba: ``Linkage.step_fast_with_kinematics``)
is a benchmark-only dependency (``pip install -e .[bench]``).
"""
import atexit
import ctypes
import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

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


# -- the floor: the slider-crank's Newton/LU analysis written tightly in C ------------------------

FLOOR_SOURCE = Path(__file__).resolve().parent / "floor" / "slider_crank.c"
CC = os.environ.get("CC", "gcc")
CFLAGS = ("-O3", "-march=native", "-shared", "-fPIC")
_FLOOR = []


def floor_library():
    """The C floor (benchmarks/floor/slider_crank.c) compiled once per process
    with ``CC CFLAGS`` into a temporary directory (removed at exit) and loaded
    with ctypes. Raises RuntimeError when the compiler is missing or fails."""
    if _FLOOR:
        return _FLOOR[0]
    tmp = tempfile.mkdtemp(prefix="kinem-floor-")
    atexit.register(shutil.rmtree, tmp, True)
    so = os.path.join(tmp, "slider_crank.so")
    cmd = [CC, *CFLAGS, "-o", so, str(FLOOR_SOURCE), "-lm"]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise RuntimeError(f"the C floor needs a C compiler ({' '.join(cmd)}): {e}") from e
    if out.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{out.stderr}")
    lib = ctypes.CDLL(so)
    d, i, p = ctypes.c_double, ctypes.c_int, ctypes.c_void_p
    common = [p, d, d, d, d, d, d, i, d, p, p, p, p]
    lib.floor_march.argtypes, lib.floor_march.restype = common, i
    lib.floor_time.argtypes, lib.floor_time.restype = common + [i, p], i
    _FLOOR.append(lib)
    return lib


def floor_pivots():
    """The C floor's static pivot order [(row, column)] and the Jacobian's
    structure [(row, column, constant)] it was chosen from."""
    lib = floor_library()
    piv = (ctypes.c_int * 24).in_dll(lib, "PIVOTS")
    size = ctypes.c_int.in_dll(lib, "PATTERN_SIZE").value
    pat = (ctypes.c_int * (3 * size)).in_dll(lib, "PATTERN")
    return [tuple(piv[2 * k: 2 * k + 2]) for k in range(12)], [tuple(pat[3 * k: 3 * k + 3]) for k in range(size)]


def markowitz_order(pattern, n=12):
    """A greedy Markowitz order over a structure [(row, column, constant)]:
    at each step the active entry of least (r - 1)(c - 1) (r, c: active
    entries in its row and column), constant entries first among equals,
    then the lowest row and column; eliminating it adds its fill. Returns
    [(row, column)]."""
    rows = {i: {} for i in range(n)}
    for i, j, const in pattern:
        rows[i][j] = bool(const)
    order = []
    while rows:
        count = {}
        for r in rows.values():
            for j in r:
                count[j] = count.get(j, 0) + 1
        _, _, i, j = min(((len(r) - 1) * (count[j] - 1), not c, i, j) for i, r in rows.items() for j, c in r.items())
        order.append((i, j))
        pivot_row = rows.pop(i)
        for r in rows.values():
            if j in r:
                del r[j]
                for c in pivot_row:
                    if c != j:
                        r[c] = False  # an updated or filled entry varies
    return order


def _floor_start():
    B, A = slider_crank_geometry(PHI0)
    p2 = math.atan2((A - B).imag, (A - B).real)
    return np.array([0, 0, 0, 0, 0, PHI0, B.real, B.imag, p2, A.real, 0, 0], float)


def floor_slider_crank(instants=INSTANTS, tol=1e-12):
    """The slider-crank of ``slider_crank_case`` over ``instants`` output
    instants, hand-tight (the C floor): (q, qd, qdd) arrays (instants, 12)
    and the Newton iterations in all. Starts from the assembled
    configuration at t = 0 with its rates (as a warm analysis does)."""
    Q, QD, QDD = (np.empty((instants, 12)) for _ in range(3))
    info = np.zeros(3, np.intc)
    status = floor_library().floor_march(_floor_start().ctypes.data, PHI0, OMEGA, R, L_ROD, L_ROD, DT, instants, tol,
                                         Q.ctypes.data, QD.ctypes.data, QDD.ctypes.data, info.ctypes.data)
    if status:
        raise RuntimeError(f"the C floor did not converge at instant {status - 1}")
    return Q, QD, QDD, int(info[0])


def floor_info(instants=INSTANTS):
    """(Newton iterations, dense fallbacks, polishing corrections) of a floor run."""
    Q, QD, QDD = (np.empty((instants, 12)) for _ in range(3))
    info = np.zeros(3, np.intc)
    floor_library().floor_march(_floor_start().ctypes.data, PHI0, OMEGA, R, L_ROD, L_ROD, DT, instants, 1e-12,
                                Q.ctypes.data, QD.ctypes.data, QDD.ctypes.data, info.ctypes.data)
    return tuple(int(x) for x in info)


def floor_seconds(repeats, instants=INSTANTS):
    """Seconds of each of ``repeats`` floor runs in a row, timed inside C
    (CLOCK_MONOTONIC, no Python or ctypes around the analysis)."""
    Q, QD, QDD = (np.empty((instants, 12)) for _ in range(3))
    info = np.zeros(3, np.intc)
    seconds = np.empty(repeats)
    status = floor_library().floor_time(_floor_start().ctypes.data, PHI0, OMEGA, R, L_ROD, L_ROD, DT, instants, 1e-12,
                                        Q.ctypes.data, QD.ctypes.data, QDD.ctypes.data, info.ctypes.data, repeats,
                                        seconds.ctypes.data)
    if status:
        raise RuntimeError(f"the C floor did not converge at instant {status - 1}")
    return seconds
