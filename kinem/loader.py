"""A dict with a case file's structure into a frozen Case (format version 1:
docs/case-format.md): every section checked by kinem.casefile, the
[[constraints]] tables by kinem.constraints.read, every problem collected
into one InputError. kinem.case is the front door (files, text, values set);
kinem.parameters.validated adds the checks of the design parameter paths a
case names and the fast-driver warnings."""
import math

import numpy as np

from . import functions as fn, native
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
        text = _fast(case, c, speed, turns)
        if text is not None:
            out.append(text)
    return out


def _is_fast(speed, turns, steps):
    """Whether a driver turning at up to ``speed`` rad/s, ``turns`` turns over the output span of ``steps``
    intervals, is fast (fast_drivers' rule); numbers or arrays of them, elementwise."""
    return ((speed > 2 * math.pi * FAST_TURNS) & (turns >= 1)) | ((turns > MANY_TURNS) & (turns / steps > COARSE))


def _fast(case, c, speed, turns) -> str | None:
    """fast_drivers' warning of driver c turning at up to ``speed`` rad/s, ``turns`` turns over [0, end]; None
    when it is not fast."""
    if not _is_fast(speed, turns, case.steps):
        return None
    return (f"{case.source}: {c.where}: turns body '{c['body']}' at up to {speed:.4g} rad/s "
            f"({speed / (2 * math.pi):.3g} turns a second, {turns:.3g} turns in {case.end:g} s, {case.steps} output intervals); if its "
            f"d(t) is in degrees, that is {math.radians(speed):.4g} rad/s: convert it, or set "
            "units = { angle = \"deg\" } for the case's angles")


FAST_CHUNK = 4096   # variants' driving functions evaluated at a time (1,001 instants each: 33 MB an order)


def fast_variants(case, changed: dict, count: int):
    """fast_drivers for ``count`` variants of ``case`` whose drivers' numbers
    are ``changed`` ({a driver's index (1-based, its place in the file):
    {sub-path of its d (poly.1, harmonic.omega, table.value.2, table.t.0):
    (count,) values in radians}}), from the values alone (no case built):
    (whether each variant warns where the case itself does not, a bool
    array; (variant, its first such warning) for the first of them, or
    None). A driver's functions are evaluated as fast_drivers' are (the
    core's, at the same 1,001 instants), FAST_CHUNK variants at a time, and
    only where they may warn: a poly's or a harmonic's speed and turns are
    bounded from its numbers first (a variant below both thresholds is not
    evaluated); a variant whose numbers are the nominal's is the nominal."""
    own, new, first = set(fast_drivers(case)), np.zeros(count, bool), None
    t = np.linspace(0.0, case.end, 1001)
    ends = np.array([0.0, case.end])
    for c in case.constraints:
        subs = changed.get(c.index)
        if c.type != "driver" or c.get("coord") != "phi" or not subs:
            continue
        kind, data = _function_data(c["d"], subs, count)
        maybe = (data != _function_data(c["d"], {}, 1)[1]).any(axis=1) & _may_warn(case, kind, data)
        mine = any(w.startswith(f"{case.source}: {c.where}: ") for w in own)   # the case's own driver warns
        ks = np.flatnonzero(maybe)
        for lo in range(0, len(ks), FAST_CHUNK):
            chunk = ks[lo:lo + FAST_CHUNK]
            table = _table_of(kind, data[chunk])
            speed = np.abs(native.functions(table, t, 1)).max(axis=0)
            at = native.functions(table, ends, 0)
            turns = np.abs(at[1] - at[0]) / (2 * math.pi)
            fast = _is_fast(speed, turns, case.steps)
            for j in np.flatnonzero(fast).tolist():   # a text only where it may be the case's own, or first
                k = int(chunk[j])
                if mine or first is None or k < first[0]:
                    text = _fast(case, c, float(speed[j]), float(turns[j]))
                    if text in own:
                        continue
                    if first is None or k < first[0]:   # an earlier driver's, for the same variant, stands
                        first = (k, text)
                new[k] = True
    return new, first


def _may_warn(case, kind, data) -> np.ndarray:
    """Per row of ``data`` (kind's numbers: _function_data) whether fast_drivers may warn of that function:
    False where bounds of its speed (max |d'| over [0, end]) and turns (|d(end) - d(0)| / 2 pi) from its
    numbers lie below both thresholds (a table's: not bounded, True)."""
    end = case.end
    if kind == fn.POLY:
        k = np.arange(data.shape[1])
        mag = np.abs(data[:, 1:])
        speed = (mag * k[1:] * end ** (k[1:] - 1.0)).sum(axis=1)
        turns = (mag * end ** k[1:]).sum(axis=1) / (2 * math.pi)
    elif kind == fn.HARMONIC:
        speed = np.abs(data[:, 0] * data[:, 1])
        turns = 2 * np.abs(data[:, 0]) / (2 * math.pi)
    else:
        return np.ones(len(data), bool)
    speed, turns = speed * (1 + 1e-9) + 1e-300, turns * (1 + 1e-9) + 1e-300   # above their evaluation's rounding
    return _is_fast(speed, turns, case.steps)


def _function_data(f, subs, count):
    """(kind, (count, ...) the parameters of ``count`` copies of function f with ``subs`` set): a poly's
    coefficients, a harmonic's amplitude, omega, phase and offset, a table's times then values."""
    if isinstance(f, fn.Poly):
        kind, names, base = fn.POLY, [f"poly.{k}" for k in range(len(f.coeffs))], list(f.coeffs)
    elif isinstance(f, fn.Harmonic):
        kind, names = fn.HARMONIC, [f"harmonic.{k}" for k in ("amplitude", "omega", "phase", "offset")]
        base = [f.amplitude, f.omega, f.phase, f.offset]
    else:
        kind = fn.PIECES
        names = [f"table.t.{k}" for k in range(len(f.t))] + [f"table.value.{k}" for k in range(len(f.value))]
        base = list(f.t) + list(f.value)
    data = np.tile(np.array(base, float), (count, 1))
    for sub, v in subs.items():
        data[:, names.index("poly.0" if sub == "" else sub)] = v   # "": a constant d(t) given by a name
    return kind, data


def _table_of(kind, data) -> dict:
    """The core's function table (kinem.functions.table_arrays) of one function a row of ``data``."""
    if kind != fn.PIECES:
        return fn.table_arrays([kind] * len(data), data)
    m, rows = data.shape[1] // 2, []
    for row in data:   # a table's not-a-knot spline, each row's own
        try:
            rows.append(fn.pieces(fn.Table(tuple(row[:m]), tuple(row[m:]))))
        except ValueError:   # times a named dimension moved out of order: that variant is refused, not warned
            rows.append(fn.pieces(fn.Table((0.0, 1.0), (0.0, 0.0))))
    return fn.table_arrays([kind] * len(rows), rows)
