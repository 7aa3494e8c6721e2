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
