"""The case file's sections other than [[constraints]]: units, [time],
[solver], [engines.*], [bodies] and [points]."""
from ..spec import Body, Point, frozen_map
from .checks import IDENT_RE, names, show

MAX_ITEMS = 100_000
ENGINES = ("pymunk", "mujoco", "exudyn")  # settings are checked against each adapter when it runs
SOLVER_KEYS = ("tolerance", "max_iterations", "linear_solver", "jacobian_reuse", "block")
LINEAR_SOLVERS = ("auto", "dense", "sparse")


def units(ck, u):
    if not isinstance(u, dict):
        ck.bad("units", None, f"got {show(u)}", "a table such as { length = \"mm\" }")
        return {}
    ck.keys("units", u, ("length",))
    if "length" in u:
        ck.string("units", "length", u["length"])
    return {k: v for k, v in u.items() if k == "length" and isinstance(v, str)}


def engines(ck, e):
    """[engines.<name>] tables of settings: scalars or short lists of numbers."""
    if not isinstance(e, dict):
        ck.bad("[engines]", None, f"got {show(e)}", "a table of [engines.<name>] tables")
        return {}
    out = {}
    for name, table in e.items():
        where = f"[engines.{name}]"
        if name not in ENGINES:
            ck.bad(where, None, f"unknown engine '{name}'", "one of " + ", ".join(ENGINES))
            continue
        if not isinstance(table, dict):
            ck.bad(where, None, f"got {show(table)}", "a table of settings")
            continue
        ok = {}
        for k, v in table.items():
            if isinstance(v, int) and not isinstance(v, bool):
                v = int(v) if ck.number(where, k, v) is not None else None  # counts stay whole
            elif isinstance(v, float):
                v = ck.number(where, k, v)
            elif isinstance(v, list):
                v = ck.numbers(where, k, v)
                v = None if v is None or len(v) > 16 else v
            elif not isinstance(v, (str, bool)):
                ck.bad(where, k, f"got {show(v)}", "a number, string, boolean or list of numbers")
                v = None
            if v is not None:
                ok[k] = v
        out[name] = frozen_map(ok)
    return out


def time(ck, t):
    """(end, steps) of [time]."""
    where = "[time]"
    if not isinstance(t, dict):
        ck.bad(where, None, f"got {show(t)}", "a table with end and steps (or dt)")
        return 1.0, 1
    ck.keys(where, t, ("end", "steps", "dt"), ("end",))
    end = ck.number(where, "end", t["end"], positive=True) if "end" in t else None
    if ("steps" in t) == ("dt" in t):
        ck.bad(where, "steps", "give exactly one of 'steps' and 'dt'")
        return end or 1.0, 1
    if "steps" in t:
        steps = ck.integer(where, "steps", t["steps"])
    else:
        dt = ck.number(where, "dt", t["dt"], positive=True)
        steps = None
        if dt is not None and end is not None:
            n = round(end / dt)
            if n < 1 or n > 10**7 or abs(n * dt - end) > 1e-9 * end:
                ck.bad(where, "dt", f"end/dt = {end / dt:g}", "a step that divides end into 1 to 1e7 intervals")
            else:
                steps = n
    return end or 1.0, steps or 1


def solver(ck, s):
    """The [solver] settings given (the Case's defaults fill the rest)."""
    where = "[solver]"
    if not isinstance(s, dict):
        ck.bad(where, None, f"got {show(s)}", "a table")
        return {}
    ck.keys(where, s, SOLVER_KEYS)
    out = {}
    if "tolerance" in s:
        tol = ck.number(where, "tolerance", s["tolerance"], positive=True)
        if tol is not None and tol >= 1:
            ck.bad(where, "tolerance", f"got {tol:g}", "a number between 0 and 1")
        elif tol is not None:
            out["tolerance"] = tol
    if "max_iterations" in s:
        it = ck.integer(where, "max_iterations", s["max_iterations"], 1, 1000)
        if it is not None:
            out["max_iterations"] = it
    if "jacobian_reuse" in s:
        if not isinstance(s["jacobian_reuse"], bool):
            ck.bad(where, "jacobian_reuse", f"got {show(s['jacobian_reuse'])}", "true or false")
        else:
            out["jacobian_reuse"] = s["jacobian_reuse"]
    if "block" in s:
        b = ck.integer(where, "block", s["block"], 1, 4096)
        if b is not None:
            out["block"] = b
    if "linear_solver" in s:
        ls = s["linear_solver"]
        if ls not in LINEAR_SOLVERS:
            ck.bad(where, "linear_solver", f"got {show(ls)}", "one of " + ", ".join(LINEAR_SOLVERS))
        else:
            out["linear_solver"] = ls
    return out


def bodies(ck, b):
    """name -> Body of [bodies]."""
    if not isinstance(b, dict) or not b:
        ck.bad("[bodies]", None, f"got {show(b)}", "a table with at least one body")
        return {}
    if len(b) > MAX_ITEMS:
        ck.bad("[bodies]", None, f"{len(b)} bodies", f"at most {MAX_ITEMS}")
        return {}
    out = {}
    for name, v in b.items():
        where = f"body '{name}'"
        if not IDENT_RE.match(name):
            ck.bad(where, None, "bad name", "a name of letters, digits, '_' and '-' that starts with a letter or '_'")
            continue
        if not isinstance(v, dict):
            ck.bad(where, None, f"got {show(v)}", "a table such as { q = [x, y, phi] }")
            continue
        ck.keys(where, v, ("q", "mass", "inertia"), ("q",))
        q = ck.vector(where, "q", v["q"], 3, "[x, y, phi]") if "q" in v else None
        mass = ck.number(where, "mass", v["mass"], positive=True) if "mass" in v else None
        inertia = ck.number(where, "inertia", v["inertia"], positive=True) if "inertia" in v else None
        if q is not None:
            out[name] = Body(name, q, mass, inertia)
    return out


def points(ck, p, bodies):
    """name -> Point of [points]."""
    if not isinstance(p, dict):
        ck.bad("[points]", None, f"got {show(p)}", "a table of points")
        return {}
    if len(p) > MAX_ITEMS:
        ck.bad("[points]", None, f"{len(p)} points", f"at most {MAX_ITEMS}")
        return {}
    out = {}
    for name, v in p.items():
        where = f"point '{name}'"
        if not IDENT_RE.match(name):
            ck.bad(where, None, "bad name", "a name of letters, digits, '_' and '-'")
            continue
        if name in bodies:
            ck.bad(where, None, "has the name of a body", "point names distinct from body names")
            continue
        if not isinstance(v, dict):
            ck.bad(where, None, f"got {show(v)}", "a table such as { body = \"crank\", at = [xi, eta] }")
            continue
        if not ck.keys(where, v, ("body", "at"), ("body", "at")):
            continue
        body = v["body"]
        if not isinstance(body, str) or body not in bodies:
            ck.bad(where, "body", f"unknown body {show(body)}", "one of " + names(bodies))
            continue
        at = ck.vector(where, "at", v["at"], 2, "[xi, eta]")
        if at is not None:
            out[name] = Point(name, body, at)
    return out
