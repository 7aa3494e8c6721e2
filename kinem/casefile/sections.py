"""The case file's sections other than [[constraints]]: units, [time],
[solver], [engines.*], [bodies] and [points]."""
import math

from ..spec import Body, Equivalence, Point, frozen_map
from .checks import END_RANGE, MAX_STEPS, MAX_UNIT, NAME_RE, names, show

MAX_ITEMS = 100_000
MAX_SENSITIVITY = 8   # [report] sensitivity: design parameters (not texts: a name of [parameters] and its path are one)
SENSITIVITY_EXPECTED = (f"a list of 1 to {MAX_SENSITIVITY} design parameter paths (or names of [parameters]), each "
                        "parameter counted once")
SOLVER_KEYS = ("tolerance", "max_iterations", "linear_solver", "jacobian_reuse", "block")
LINEAR_SOLVERS = ("auto", "dense", "sparse")


def units(ck, u):
    """units = { length = "mm", angle = "rad" or "deg" }: length is shown in
    reports; angle "deg" sets ``ck.degrees`` (every angle of the case in degrees)."""
    if not isinstance(u, dict):
        ck.bad("units", None, f"got {show(u)}", "a table such as { length = \"mm\" }")
        return {}
    ck.keys("units", u, ("length", "angle"))
    out = {}
    if "angle" in u:
        if u["angle"] in ("rad", "deg"):
            out["angle"] = u["angle"]
            ck.degrees = u["angle"] == "deg"
        else:
            ck.bad("units", "angle", f"got {show(u['angle'])}", '"rad" (the default) or "deg"')
    if "length" in u and ck.string("units", "length", u["length"], max_len=MAX_UNIT,
                                   expected=f"1 to {MAX_UNIT} printable characters such as \"mm\"") is not None:
        if u["length"] and u["length"].isprintable():
            out["length"] = u["length"]
        else:
            ck.bad("units", "length", f"got {show(u['length'])}",
                   f"1 to {MAX_UNIT} printable characters such as \"mm\"")
    return out


def parameters(ck, p):
    """[parameters]: name -> number, the case's named dimensions; a number
    elsewhere in the file may be given as one of these names (a string,
    never an expression: nothing is evaluated). Sets ``ck.parameters``."""
    if not isinstance(p, dict) or len(p) > MAX_ITEMS:
        ck.bad("[parameters]", None, f"got {show(p)}" if not isinstance(p, dict) else f"{len(p)} parameters",
               "a table of names and numbers such as { crank = 50.0 }" if not isinstance(p, dict)
               else f"at most {MAX_ITEMS}")
        return {}
    out = {}
    for name, v in p.items():
        if ck.name("parameter", name) is None:
            continue
        if isinstance(v, str):   # one parameter naming another would be an expression by another name
            ck.bad("[parameters]", name, f"got {show(v)}", "a number (a parameter's value is not another's name)")
            v = None
        else:
            v = ck.number("[parameters]", name, v)
        if v is None:
            ck.rejected_parameters.add(name)
        else:
            out[name] = v
    ck.parameters = out
    return out


def engines(ck, e):
    """[engines.<name>] tables of settings: scalars or short lists of numbers,
    kept raw; the engine registry (adapters) checks names and keys when they are used."""
    if not isinstance(e, dict):
        ck.bad("[engines]", None, f"got {show(e)}", "a table of [engines.<name>] tables")
        return {}
    out = {}
    for name, table in e.items():
        where = f"[engines.{show(name)[1:-1]}]"
        if ck.name(where, name) is None:
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
                v = ck.numbers(where, k, v, max_len=16)
            elif not isinstance(v, (str, bool)):
                ck.bad(where, k, f"got {show(v)}", "a number, string, boolean or list of numbers")
                v = None
            if v is not None:
                ok[k] = v
        out[name] = frozen_map(ok)
    return out


def end_time(ck, where, key, v):
    """An end time within END_RANGE (the case file's [time] end and --end)."""
    end = ck.number(where, key, v)
    if end is not None and not END_RANGE[0] <= end <= END_RANGE[1]:
        ck.bad(where, key, f"got {end:g}", f"a time from {END_RANGE[0]:g} to {END_RANGE[1]:g} s")
        return None
    return end


def steps(ck, where, key, v):
    """A number of output intervals, 1 to MAX_STEPS (the case file's [time] steps and --steps)."""
    return ck.integer(where, key, v, 1, MAX_STEPS)


def time(ck, t):
    """(end, steps) of [time]; end None if not valid."""
    where = "[time]"
    if t is None:  # missing: reported with the top level's keys
        return None, 1
    if not isinstance(t, dict):
        ck.bad(where, None, f"got {show(t)}", "a table with end and steps (or dt)")
        return None, 1
    ck.keys(where, t, ("end", "steps", "dt"), ("end",))
    end = end_time(ck, where, "end", t["end"]) if "end" in t else None
    if ("steps" in t) == ("dt" in t):
        ck.bad(where, "steps", "give exactly one of 'steps' and 'dt'")
        return end, 1
    if "steps" in t:
        return end, steps(ck, where, "steps", t["steps"]) or 1
    dt = ck.number(where, "dt", t["dt"], positive=True)
    if dt is None or end is None:
        return end, 1
    ratio = end / dt  # inf for a tiny dt: rejected before round()
    if not ratio <= MAX_STEPS + 0.5 or round(ratio) < 1 or abs(round(ratio) * dt - end) > 1e-9 * end:
        ck.bad(where, "dt", f"end/dt = {ratio:g}", f"a step that divides end into 1 to {MAX_STEPS} intervals")
        return end, 1
    return end, round(ratio)


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
    """name -> Body of [bodies]; a drawn body (``points = [...]``, kinem.casefile.drawn)
    may leave out q, and its ``carries`` holds the names of the points it lists until they are placed."""
    if b is None or not isinstance(b, dict) or not b or len(b) > MAX_ITEMS:
        ck.unknowable.add("body")  # references to bodies are not checked again
        if b is not None:  # missing: reported with the top level's keys
            ck.bad("[bodies]", None, f"got {show(b)}" if not isinstance(b, dict) or not b else f"{len(b)} bodies",
                   "a table with at least one body" if not isinstance(b, dict) or not b else f"at most {MAX_ITEMS}")
        return {}
    out = {}
    for name, v in b.items():
        where = f"body {show(name)}"
        n_before = ck.failures
        if ck.name(where, name) is None:
            pass
        elif not isinstance(v, dict):
            ck.bad(where, None, f"got {show(v)}", "a table such as { q = [x, y, phi] } or { points = [\"A\", \"B\"] }")
        else:
            ck.keys(where, v, ("q", "points", "mass", "inertia"), () if "points" in v else ("q",))
            q = ck.vector(where, "q", v["q"], 3, "[x, y, phi]") if "q" in v else None
            if q is not None and ck.degrees:
                q = (q[0], q[1], math.radians(q[2]))
            mass = ck.number(where, "mass", v["mass"], positive=True) if "mass" in v else None
            inertia = ck.number(where, "inertia", v["inertia"], positive=True) if "inertia" in v else None
            listed = v.get("points", [])
            if not isinstance(listed, list) or len(listed) > MAX_ITEMS or not all(isinstance(n, str) for n in listed):
                ck.bad(where, "points", f"got {show(listed)}", "a list of names of points drawn in the global frame")
            elif "points" in v and not listed and q is None:
                ck.bad(where, "points", "empty", "one or more points, or q = [x, y, phi]")
            if ck.failures == n_before:
                out[name] = Body(name, q, mass, inertia, tuple(dict.fromkeys(listed)))
        if name not in out:
            ck.rejected.add(name)
    return out


def points(ck, p, bodies):
    """name -> Point of [points] given in a body's frame; name -> (body or
    None, (x, y)) of the points drawn in the global frame (``frame = "global"``),
    placed by kinem.casefile.drawn."""
    if not isinstance(p, dict) or len(p) > MAX_ITEMS:
        ck.unknowable.add("point")
        ck.bad("[points]", None, f"got {show(p)}" if not isinstance(p, dict) else f"{len(p)} points",
               "a table of points" if not isinstance(p, dict) else f"at most {MAX_ITEMS}")
        return {}, {}
    out, drawn = {}, {}
    for name, v in p.items():
        where = f"point {show(name)}"
        if ck.name(where, name) is None:
            pass
        elif name in bodies or name in ck.rejected:
            ck.bad(where, None, "has the name of a body", "point names distinct from body names")
        elif not isinstance(v, dict):
            ck.bad(where, None, f"got {show(v)}", "a table such as { body = \"crank\", at = [xi, eta] }")
        elif v.get("frame") == "global":
            if ck.keys(where, v, ("body", "at", "frame"), ("at",)):
                body = ck.choice(where, "body", v["body"], bodies, "body") if "body" in v else None
                at = ck.vector(where, "at", v["at"], 2, "[x, y] in the global frame")
                if at is not None and ("body" not in v or body is not None):
                    drawn[name] = (body, at)
        elif "frame" in v and v["frame"] != "body":
            ck.bad(where, "frame", f"got {show(v['frame'])}", '"global" (at = [x, y] as drawn) or "body" (the default)')
        elif ck.keys(where, v, ("body", "at", "frame"), ("body", "at")):
            body = ck.choice(where, "body", v["body"], bodies, "body")
            at = ck.vector(where, "at", v["at"], 2, "[xi, eta]")
            if body is not None and at is not None:
                out[name] = Point(name, body, at)
        if name not in out and name not in drawn:
            ck.rejected.add(name)
    return out, drawn


def equivalent(ck, e, points):
    """[equivalent] group = "...", points = [named points that must coincide
    with those of the group's other cases]."""
    where = "[equivalent]"
    if not isinstance(e, dict):
        ck.bad(where, None, f"got {show(e)}", 'a table such as { group = "crank-shaper", points = ["A", "B"] }')
        return None
    if not ck.keys(where, e, ("group", "points"), ("group", "points")):
        return None
    group = ck.string(where, "group", e["group"], NAME_RE, "a group name of a-z, 0-9, '_' and '-'")
    listed = e["points"]
    if not isinstance(listed, list) or not listed or len(listed) > MAX_ITEMS \
            or not all(isinstance(n, str) for n in listed):
        ck.bad(where, "points", f"got {show(listed)}", "a list of one or more named points")
        return None
    unknown = [n for n in listed if n not in points]
    if unknown:
        ck.bad(where, "points", f"unknown point(s) {', '.join(show(n)[1:-1] for n in unknown[:20])}",
               "points of [points]: " + (names(points) or "(none defined)"))
        return None
    return Equivalence(group, tuple(dict.fromkeys(listed))) if group else None


def report(ck, r, points):
    """[report]: points = the named points the report draws and plots (default:
    all); work_precision = true: the report sweeps the case's work-precision
    diagram (default false); sensitivity = [design parameter paths]: the
    report's design section (docs/design.md)."""
    if not isinstance(r, dict):
        ck.bad("[report]", None, f"got {show(r)}", "a table such as { points = [\"B\"] }")
        return {}
    ck.keys("[report]", r, ("points", "work_precision", "sensitivity"))
    out = {}
    sens = r.get("sensitivity")
    if sens is not None:   # design parameter paths: checked against the whole case (kinem.case)
        # a path listed twice counts once, as it is kept once; a parameter may be written two ways (a name of
        # [parameters] and its path), so its texts are bounded here and its parameters counted against the case
        # (kinem.parameters.validated)
        if isinstance(sens, list) and sens and all(isinstance(x, str) for x in sens) \
                and len(set(sens)) <= 2 * MAX_SENSITIVITY:
            out["sensitivity"] = tuple(dict.fromkeys(sens))
        else:
            ck.bad("[report]", "sensitivity", f"got {show(sens)}", SENSITIVITY_EXPECTED)
    wp = r.get("work_precision")
    if wp is not None:
        if isinstance(wp, bool):
            out["work_precision"] = wp
        else:
            ck.bad("[report]", "work_precision", f"got {show(wp)}", "true or false")
    listed = r.get("points")
    if listed is None:
        return out
    if not isinstance(listed, list) or not listed or len(listed) > MAX_ITEMS \
            or not all(isinstance(n, str) for n in listed):
        ck.bad("[report]", "points", f"got {show(listed)}", "a non-empty list of names from [points]")
        return {}
    for n in listed:
        if ck.choice("[report]", "points", n, points, "point") is None:
            return out
    return dict(out, points=tuple(dict.fromkeys(listed)))


def tolerances(ck, t, prefix=""):
    """[tolerances]: design parameter path -> pm or { pm = ..., sigma = ... },
    kept as given (a dotted key written bare nests: it is flattened back);
    kinem.tolerance checks the paths and the values against the case."""
    where = "[tolerances]"
    if not isinstance(t, dict):
        ck.bad(where, None, f"got {show(t)}", 'a table such as { "constraints.A.si.0" = 0.0001 }')
        return {}
    out = {}
    for k, v in t.items():
        path = f"{prefix}{k}"
        if isinstance(v, dict) and "pm" not in v and "sigma" not in v:   # (no path ends in pm or sigma)
            out.update(tolerances(ck, v, path + "."))
        elif isinstance(v, dict):
            if ck.keys(f"{where}: key '{path}'", v, ("pm", "sigma"), ("pm",)):
                out[path] = frozen_map(v)
        else:
            out[path] = v
    return out
