"""A dict with a case file's structure into a frozen Case (format version 1:
docs/case-format.md): every section checked by kinem.casefile, the
[[constraints]] tables by kinem.constraints.read, every problem collected
into one InputError. kinem.case is the front door (files, text, values set);
kinem.parameters.validated adds the checks of the design parameter paths a
case names and the fast-driver warnings."""
import math

import numpy as np

from . import functions as fn
from .casefile import sections
from .casefile.checks import HIDDEN, MAX_NAME, MAX_TEXT, NAME_RE, PLAIN, Checker
from .casefile.drawn import place
from .constraints import REGISTRY
from .constraints.read import constraint_id, constraints
from .errors import InputError
from .spec import Case, frozen_map

TOP_KEYS = ("name", "description", "parameters", "units", "time", "solver", "bodies", "points", "constraints", "engines",
            "equivalent", "report", "tolerances")


def build(data, source: str, as_written: bool = True) -> Case:
    """The Case of a dict with the case file's structure, every section
    checked. ``as_written``: a name of [parameters] that no number uses is
    refused, as an unknown key is; False for a case written again from a Case
    (kinem.parameters.case_dict: a name set apart from its numbers' paths,
    or used by time.dt alone, is written without its uses)."""
    ck = Checker(source)
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a table at the top level")
    ck.keys("top level", data, TOP_KEYS, ("name", "time", "bodies", "constraints"))
    name = ck.string("top level", "name", data.get("name", "case"), NAME_RE,
                     f"an identifier of 1 to {MAX_NAME} characters a-z, 0-9, '_' and '-'")
    description = ck.string("top level", "description", data.get("description", ""),
                            expected=f"a string of at most {MAX_TEXT} characters")
    hidden = HIDDEN.search(description) if description else None
    if hidden:   # as a name's or a unit's: what is printed shows what is written (tab and newline are prose)
        ck.bad("top level", "description", f"U+{ord(hidden.group()):04X} at character {hidden.start() + 1}", PLAIN)
        description = None
    params = sections.parameters(ck, data.get("parameters", {}))
    units = sections.units(ck, data.get("units", {}))
    end, steps = sections.time(ck, data.get("time"))
    solver = sections.solver(ck, data.get("solver", {}))
    bodies = sections.bodies(ck, data.get("bodies"))
    points, drawn = sections.points(ck, data.get("points", {}), bodies)
    bodies, points = place(ck, bodies, points, drawn, list(data["points"]) if isinstance(data.get("points"), dict) else [])
    cons = constraints(ck, data.get("constraints"), bodies, points, end)
    engines = sections.engines(ck, data.get("engines", {}))
    equivalent = sections.equivalent(ck, data["equivalent"], points) if "equivalent" in data else None
    report = sections.report(ck, data.get("report", {}), points)
    tolerances = sections.tolerances(ck, data.get("tolerances", {}))
    if as_written and not ck.problems:   # moving it would move nothing (derivatives 0, every variant the nominal)
        for unused in (n for n in params if n not in ck.named):
            ck.bad("[parameters]", unused, "used by no number of the case",
                   f"a number that names it (e.g. length = \"{unused}\") or no such entry")
    ck.raise_if_any()
    return Case(name=name, bodies=tuple(bodies.values()), points=tuple(points.values()),
                constraints=tuple(cons), end=end or 1.0, steps=steps, description=description,
                units=frozen_map(units), engines=frozen_map(engines), source=source,
                equivalent=equivalent, report=frozen_map(report), parameters=frozen_map(params),
                tolerances=frozen_map(tolerances), uses=frozen_map(uses(data, params, cons)), **solver)


def uses(data, params, cons) -> dict:
    """name -> the paths (kinem.parameters' words: points.A.at.0,
    constraints.B.si.1, bodies.crank.q.2, time.end) of the numbers of the
    file that name a [parameters] entry."""
    out = {}

    def walk(path, v):
        if isinstance(v, str) and v in params:
            out.setdefault(v, []).append(".".join(path))
        elif isinstance(v, dict):
            for k, x in v.items():
                walk(path + [str(k)], x)
        elif isinstance(v, list):
            for k, x in enumerate(v):
                walk(path + [str(k)], x)

    if not params:
        return {}
    for section, keys in (("time", ("end", "dt")), ("bodies", ("q", "mass", "inertia")), ("points", ("at",))):
        table = data.get(section)
        items = [(None, table)] if section == "time" else list(table.items()) if isinstance(table, dict) else []
        for name, t in items:
            for k in keys if isinstance(t, dict) else ():
                if k in t:
                    walk([section] + ([name] if name else []) + [k], t[k])
    by_index = {c.index: c for c in cons}
    for index, table in enumerate(data.get("constraints") or [], 1):
        if index not in by_index or not isinstance(table, dict):
            continue
        c = by_index[index]
        numeric = {k.name for k in REGISTRY[c.type].keys if type(k).__name__ in ("NumberKey", "PositiveKey")}
        for k, v in table.items():
            if k not in ("type", "name") and (not isinstance(v, str) or k in numeric) and k not in c.refs:
                walk(["constraints", constraint_id(c), k], v)
    return {k: tuple(v) for k, v in out.items()}


FAST_TURNS = 50        # turns a second: a crank faster than this looks like degrees per second given as rad/s
MANY_TURNS = 100       # turns over the output span, likewise, when the output instants are too few to follow them
COARSE = 0.25          # turns per output interval: more, and the output does not show the turning


def fast_drivers(case) -> list:
    """A warning for each driver of an angle that turns (a turn or more over
    [0, end]: not a fast small oscillation) faster than FAST_TURNS a second, or more than MANY_TURNS times over [0, end] at more than COARSE
    turns per output interval (a long run sampled to follow it is meant): a
    speed given in degrees per second where radians per second are read
    (units = { angle = "deg" } reads them as degrees)."""
    out = []
    t = np.linspace(0.0, case.end, 1001)
    for c in case.constraints:
        if c.type != "driver" or c.get("coord") != "phi":
            continue
        f = fn.FunctionSet([c["d"]])
        speed = float(np.abs(f(t, 1)).max())
        turns = float(abs(f(case.end)[0] - f(0.0)[0])) / (2 * math.pi)
        if (speed > 2 * math.pi * FAST_TURNS and turns >= 1) or (turns > MANY_TURNS and turns / case.steps > COARSE):
            out.append(f"{case.source}: {c.where}: turns body '{c['body']}' at up to {speed:.4g} rad/s "
                       f"({speed / (2 * math.pi):.3g} turns a second, {turns:.3g} turns in {case.end:g} s, {case.steps} output intervals); if its "
                       f"d(t) is in degrees, that is {math.radians(speed):.4g} rad/s: convert it, or set "
                       "units = { angle = \"deg\" } for the case's angles")
    return out
