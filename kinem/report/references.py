"""Independent references for the native row: the closed forms of
kinem.reference for the repository's slider-crank, four-bar and quick-return
cases, evaluated at the case's instants.

Each closed form takes its dimensions (link lengths, pivots, slider line) from
the case's assembled configuration at t = 0 and its crank angle from the
case's driving function, never from the solver's later instants. A case of
that name whose geometry the closed form does not fit at t = 0 (someone
else's case called slider_crank) gets none.
"""
import numpy as np

from .. import reference

FIT = 1e-6   # relative to L: the closed form must reproduce the t = 0 assembly this well to apply


def closed_form(model, ref):
    """(label, {point name: complex positions over ref's instants}) or None.
    ref: the reference SolveResult of model's case."""
    make = CLOSED_FORMS.get(model.case.name)
    if make is None or not ref.success:
        return None
    traj = ref.trajectory
    try:
        label, points = make(model, traj)
    except (KeyError, ValueError, StopIteration):   # another geometry than the closed form's
        return None
    fits = all(abs(p[0] - _xy(traj, n)[0]) <= FIT * model.length for n, p in points.items())
    return (label, points) if fits and all(np.isfinite(p).all() for p in points.values()) else None


def error(model, traj, points) -> float:
    """Max distance of traj's named points to the closed form's, over the
    instants both have (case length units)."""
    return max(float(np.abs(_xy(traj, n)[:len(p)] - p[:len(traj)]).max()) for n, p in points.items())


def _xy(traj, name):
    return traj[f"{name}.x"] + 1j * traj[f"{name}.y"]


def _crank(model, t, body="crank"):
    """The crank's driven angle, as an offset from t = 0."""
    from ..functions import FunctionSet

    c = next(c for c in model.case.constraints
             if c.type == "driver" and c.get("body") == body and c.get("coord") == "phi")
    d = FunctionSet([c["d"]])(np.asarray(t), 0)[:, 0]
    return d - d[0]


def _ground(model, traj, joint):
    """Global position of the ground-side point of a revolute joint named ``joint``."""
    from adapters.base import grounded

    c = next(c for c in model.case.constraints if c.name == joint and c.type == "revolute")
    fixed = grounded(model)
    side = "i" if c["i"] in fixed else "j"
    body, local = c[side], c["s" + side]
    if isinstance(local, str):
        return complex(_xy(traj, local)[0])
    at = complex(*local)
    return complex(traj[f"{body}.x"][0], traj[f"{body}.y"][0]) + at * np.exp(1j * traj[f"{body}.phi"][0])


def slider_crank(model, traj):
    O = _ground(model, traj, "O")
    B0, A0 = _xy(traj, "B")[0], _xy(traj, "A")[0]
    r, l, e = abs(B0 - O), abs(A0 - B0), (A0 - O).imag
    theta = np.angle(B0 - O) + _crank(model, traj.t)
    side = -1.0 if A0.real < B0.real else 1.0
    zero = np.zeros_like(theta)
    xA = reference.slider_crank(theta, zero, zero, r, l, e, side)["x"]
    return ("closed form kinem.reference.slider_crank (points A, B)",
            {"B": O + r * np.exp(1j * theta), "A": O + xA + 1j * e})


def four_bar(model, traj):
    O2, O4 = (_xy(traj, n)[0] for n in ("O2", "O4"))
    A0, B0 = _xy(traj, "A")[0], _xy(traj, "B")[0]
    u = (O4 - O2) / abs(O4 - O2)          # the ground line's direction
    a, b, c, d = abs(A0 - O2), abs(B0 - A0), abs(B0 - O4), abs(O4 - O2)
    th2 = np.angle((A0 - O2) / u) + _crank(model, traj.t)
    zero = np.zeros_like(th2)
    best = None
    for sign in (1.0, -1.0):                # the assembly the case starts in
        B = O2 + u * reference.four_bar(th2, zero, zero, a, b, c, d, sign)["B"]
        if best is None or abs(B[0] - B0) < abs(best[0] - B0):
            best = B
    return ("closed form kinem.reference.four_bar (points A, B)", {"A": O2 + u * a * np.exp(1j * th2), "B": best})


def quick_return(model, traj):
    O, C = _ground(model, traj, "O"), _ground(model, traj, "C")
    u = (O - C) / abs(O - C)               # the closed form's +y: from the rocker pivot C to the crank pivot O
    to_local = 1j / u
    A0, B0, D0 = (_xy(traj, n)[0] for n in "ABD")
    theta = np.angle((A0 - O) * to_local) + _crank(model, traj.t)
    p = reference.quick_return(theta, abs(O - C), abs(A0 - O), abs(B0 - C), abs(D0 - B0),
                               ((D0 - O) * to_local).imag)
    return ("closed form kinem.reference.quick_return (points A, B, D)",
            {n: O + p[n] / to_local for n in "ABD"})


CLOSED_FORMS = {"slider_crank": slider_crank, "four_bar": four_bar,
                "quick_return_1": quick_return, "quick_return_2": quick_return, "quick_return_3": quick_return}
