"""Time functions d(t) and outlines (Sec. 4.2.4) from their case-file tables."""
import math

from .. import functions as fn
from ..outline import OPEN_BC, Outline
from .checks import show

KINDS = ("poly", "harmonic", "table")
FUNCTION_FORMS = "a number, { poly = [...] }, { harmonic = {...} } or { table = {...} }"
OUTLINE_FORMS = ("{ spline = { theta = [...], s = [...] } or circle = { radius = R }, "
                 "center = [xi, eta] (optional) }")


def function(ck, where, key, v, end):
    """A number, { poly }, { harmonic } or { table } into a time function."""
    if isinstance(v, (int, float, str)) and not isinstance(v, bool):   # a number or a parameter's name
        c = ck.number(where, key, v)
        return None if c is None else fn.constant(c)
    if isinstance(v, dict) and len(v) > 1:   # name the key that does not belong
        kinds = [k for k in v if k in KINDS]
        extra = [k for k in v if k not in KINDS]
        if extra:
            ck.bad(where, key, f"unknown key {show(extra[0])}" + (f" beside '{kinds[0]}'" if kinds else ""),
                   FUNCTION_FORMS)
        else:
            ck.bad(where, key, f"two kinds of function, '{kinds[0]}' and '{kinds[1]}'", FUNCTION_FORMS)
        return None
    if not isinstance(v, dict) or len(v) != 1:
        ck.bad(where, key, f"got {show(v)}", FUNCTION_FORMS)
        return None
    (kind, body), = v.items()
    if kind == "poly":
        c = ck.numbers(where, key, body)
        if c is not None and len(c) > 32:
            ck.bad(where, key, f"poly of {len(c)} coefficients", "at most 32")
            return None
        return None if c is None else fn.Poly(c)
    if kind == "harmonic":
        return _harmonic(ck, where, key, body)
    if kind == "table":
        return _table(ck, where, key, body, end)
    ck.bad(where, key, f"unknown function kind {show(kind)}", FUNCTION_FORMS)
    return None


def _harmonic(ck, where, key, body):
    if not ck.table(where, f"{key}.harmonic", body, ("amplitude", "omega", "phase", "offset"), ("amplitude", "omega"),
                    "{ amplitude = A, omega = w, phase = p, offset = c }"):
        return None
    vals = {k: ck.number(where, f"{key}.harmonic.{k}", x) for k, x in body.items()}
    return None if None in vals.values() else fn.Harmonic(**vals)


def _table(ck, where, key, body, end):
    if not ck.table(where, f"{key}.table", body, ("t", "value"), ("t", "value"), "{ t = [...], value = [...] }"):
        return None
    pair = _pair(ck, where, f"{key}.table", body, ("t", "value"), 2)
    if pair is None:
        return None
    t, val = pair
    if not ck.increasing(where, f"{key}.table.t", t, "times"):
        return None
    if end is not None and (t[0] > 0 or t[-1] < end):
        ck.bad(where, f"{key}.table.t", f"covers [{t[0]:g}, {t[-1]:g}]", f"a table that covers [0, {end:g}]")
        return None
    return fn.Table(t, val)


def _pair(ck, where, key, body, names, min_len):
    """Two lists of numbers of equal length (a table's abscissae and values), or None."""
    x, y = (ck.numbers(where, f"{key}.{n}", body[n], min_len) for n in names)
    if x is None or y is None:
        return None
    if len(x) != len(y):
        ck.bad(where, key, f"{len(x)} {names[0]} and {len(y)} {names[1]}", f"lists {' and '.join(names)} of equal length")
        return None
    return x, y


def outline(ck, where, key, v):
    """{ spline = {...} or circle = {...}, center = [xi, eta] } into an Outline (Sec. 4.2.4)."""
    if not isinstance(v, dict) or len([k for k in ("spline", "circle") if k in v]) != 1:
        ck.bad(where, key, f"got {show(v)}", OUTLINE_FORMS)
        return None
    if not ck.keys(f"{where}: key '{key}'", v, ("spline", "circle", "center")):
        return None
    center = ck.vector(where, f"{key}.center", v["center"], 2, "[xi, eta]") if "center" in v else (0.0, 0.0)
    if center is None:
        return None
    if "circle" in v:
        body = v["circle"]
        if not ck.table(where, f"{key}.circle", body, ("radius",), ("radius",), "{ radius = R }"):
            return None
        r = ck.number(where, f"{key}.circle.radius", body["radius"], positive=True)
        return None if r is None else Outline.circle(r, center)
    return _spline(ck, where, f"{key}.spline", v["spline"], center)


def _spline(ck, where, w, body, center):
    if not ck.table(where, w, body, ("theta", "s", "degrees", "periodic", "bc"), ("theta", "s"),
                    "{ theta = [...], s = [...], degrees, periodic, bc }"):
        return None
    flags = {}
    for flag in ("degrees", "periodic"):
        flags[flag] = body.get(flag, False)
        if not isinstance(flags[flag], bool):
            ck.bad(where, f"{w}.{flag}", f"got {show(flags[flag])}", "true or false")
            return None
    pair = _pair(ck, where, w, body, ("theta", "s"), 4)
    if pair is None:
        return None
    theta, s = pair
    if flags["degrees"] or (ck.degrees and "degrees" not in body):   # its own flag, else the case's units
        theta = tuple(math.radians(x) for x in theta)
    if not ck.increasing(where, f"{w}.theta", theta, "angles"):
        return None
    if min(s) <= 0:
        ck.bad(where, f"{w}.s", f"radius {min(s):g}", "positive polar radii s")
        return None
    bc = body.get("bc", "not-a-knot")
    if flags["periodic"]:
        if "bc" in body:
            ck.bad(where, f"{w}.bc", "a periodic outline has no end conditions", "no bc with periodic = true")
            return None
        if s[0] != s[-1]:
            ck.bad(where, f"{w}.s", f"first {s[0]:g} and last {s[-1]:g} differ",
                   "the last radius of a periodic table equal to the first")
            return None
        turn = 2 * math.pi
        if abs(theta[-1] - theta[0] - turn) > 1e-9 * turn:  # 2 pi typed to 9 digits passes
            ck.bad(where, f"{w}.theta", f"spans {math.degrees(theta[-1] - theta[0]):.9g} degrees",
                   "a periodic table that spans one full turn (360 degrees, 2 pi)")
            return None
        theta = theta[:-1] + (theta[0] + turn,)
    elif bc not in OPEN_BC:
        ck.bad(where, f"{w}.bc", f"got {show(bc)}", "one of " + ", ".join(OPEN_BC))
        return None
    return Outline.spline(theta, s, flags["periodic"], bc, center)
