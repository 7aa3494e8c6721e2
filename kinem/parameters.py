"""Design parameters: the numbers of a case that shape the mechanism, each
named by a dot path in the case file's own words (docs/case-format.md,
"Design parameters"):

    parameters.<name>                         a named dimension of [parameters]
    points.<point>.at.<k>                     a named point's coordinate: local, or
                                              as drawn in the global frame (frame = "global")
    constraints.<name>.<key>                  a scalar key (a radius, a length, phi0)
    constraints.<name>.<key>.<k>              an entry of a vector key (si, qi, value, u)
    constraints.<name>.<key>.<sub>[.<k>]      inside a function or outline table
                                              (d.poly.1, outline.spline.s.3, outline.center.0)

A constraint is addressed by its name, an unnamed one by ``#<index>``
(1-based, its place in the file). A constraint key that names a point
(``si = "A"``) is that point's coordinate: ``points.A.at.<k>``, which moves
every constraint that reads it; a point drawn in the global frame moves on
every body that carries it. A named point that no constraint reads, body
estimates, masses and contact-angle estimates (``theta``) are not design
parameters. A default a case file leaves out and the loader fills in (a
joint's ``phi0``, a ground's ``value``) is a parameter of its own, held at
its nominal value when another moves. Values are in the file's units: with
``units = { angle = "deg" }`` an angle is in degrees.

A named dimension ``parameters.<name>`` moves every number of the file
that names it (``Case.uses``, recorded by the loader); setting one of those
numbers by its own path detaches it from the name.

``parameters(case)`` lists them; ``resolve(case, paths)`` checks paths
(unknown: a did-you-mean; read by no constraint: refused, naming it);
``apply(case, {path: value})`` returns a new Case, validated as a case file
is: the one place where ``--set``, sweeps, ``load(parameters=...)``,
sensitivities and tolerance bands set values (a bare ``NAME`` is
``parameters.NAME``). ``validated(data, source)`` is that validation
(kinem.loader's Case, then the paths the case names: [tolerances] by
``tolerances_of``, [report] sensitivity), which kinem.case, above, uses too.
"""
import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import functions as fn
from .casefile.checks import MAX_MAGNITUDE, TOML_NUMBERS, number, show, suggest
from .casefile.sections import MAX_SENSITIVITY, SENSITIVITY_EXPECTED
from .constraints import REGISTRY
from .constraints.read import constraint_id
from .errors import InputError, KinemWarning
from .loader import build, fast_drivers
from .spec import Case

ROOTS = ("parameters", "points", "constraints")
DEGREE = math.pi / 180


@dataclass(frozen=True)
class Parameter:
    """One design parameter: its path, nominal value, unit and what it is, in words."""
    path: str
    value: float
    unit: str
    what: str

    def as_dict(self) -> dict:
        return {"path": self.path, "value": self.value, "unit": self.unit, "what": self.what}


def parameters(case) -> tuple[Parameter, ...]:
    """Every design parameter of the case (a Case, or the one a compiled
    Model was made from): named dimensions, points, then constraints in
    file order."""
    if not isinstance(case, Case):
        if not isinstance(getattr(case, "case", None), Case):
            raise InputError(f"parameters: {type(case).__name__}: expected a case (kinem.load) or a model "
                             "(kinem.compile)")
        case = case.case
    return tuple(p for p, _ in _listing(case))


def resolve(case: Case, paths, where: str | None = None) -> tuple[Parameter, ...]:
    """The parameters named by ``paths`` (in order, each once), or one
    InputError naming the case file, ``where`` in it the paths are (a
    section: "[tolerances]") and every bad path."""
    paths, near = list(dict.fromkeys(_canonical(case, p) for p in paths)), {}
    found = [_find(case, path, near) for path in paths]
    if None not in found:
        return tuple(found)
    by_path = {p.path: p for p, _ in _listing(case)}
    problems, out = [], []
    for path in paths:
        if path in by_path:
            out.append(by_path[path])
        else:
            place = f"{where}: " if where else ""
            problems.append(f"{case.source}: {place}parameter {path!r}: {_why_not(case, path, by_path)}")
    if problems:
        raise InputError(problems)
    return tuple(out)


def validated(data, source: str, stacklevel: int = 1, as_written: bool = True, warned=None) -> Case:
    """A dict with a case file's structure as a Case (kinem.loader.build),
    with the design parameter paths it names checked ([tolerances]: paths and
    sizes; [report] sensitivity) and a warning for each fast driver
    (kinem.loader.fast_drivers): kinem.load_dict without values set.
    ``stacklevel``: the warnings', counted from the caller; ``as_written``:
    kinem.loader.build's (False for a case_dict's variants); ``warned``: a
    list that receives the warnings' texts (one tuple) instead of warnings."""
    case = build(data, source, as_written)
    if case.tolerances:   # their paths and sizes need the whole case
        tolerances_of(case)
    if "sensitivity" in case.report:   # counted as parameters: 'crank' and 'parameters.crank' are one
        listed = resolve(case, case.report["sensitivity"], "[report] sensitivity")
        if len(listed) > MAX_SENSITIVITY:
            raise InputError(f"{case.source}: [report]: key 'sensitivity': {len(listed)} design parameters; "
                             f"expected {SENSITIVITY_EXPECTED}")
    texts = fast_drivers(case)
    if warned is not None:
        warned.append(tuple(texts))
        return case
    for text in texts:
        warnings.warn(text, KinemWarning, stacklevel=stacklevel + 1)
    return case


def fast_line(who: str, count: int, total: int, first) -> str:
    """The one warning line for the variants whose drivers turn fast where the case's own do not (kinem.sweep's,
    kinem.solve's of variants): ``count`` of ``total``, ``first`` (variant, its first such warning's text)."""
    return (f"{who}: {count:,} of {total:,} variants warn where the case itself does not; first, variant "
            f"{first[0]}: {first[1]}")


def fast_variants(case, listed, values, skip=()):
    """Of the variants (rows of ``values``, one column per Parameter of
    ``listed``), those whose drivers turn fast (kinem.loader.fast_drivers)
    where the case itself does not: (a bool array, (variant, its first such
    warning's text) of the first of them, or None); evaluated from the
    values (kinem.loader.fast_variants), no variant's case built. Only a
    driver's own numbers (constraints.<driver>.d.*, or a named dimension one
    of them uses) change how fast it turns: without them, nothing to
    evaluate. ``skip``: variants not looked at (refused as bad input)."""
    from .loader import fast_variants as evaluate

    changed = {}
    degrees = case.units.get("angle") == "deg"
    for j, p in enumerate(listed):
        parts = p.path.split(".")
        uses = case.uses.get(parts[1], ()) if parts[0] == "parameters" else (p.path,)
        for use in uses:
            head = use.split(".")
            c = _constraint(case, head[1]) if head[0] == "constraints" and head[2:3] == ["d"] else None
            if c is None or c.type != "driver" or c.get("coord") != "phi":
                continue
            sub = ".".join(head[3:])
            changed.setdefault(c.index, {})[sub] = values[:, j] * (DEGREE if degrees and not sub.startswith("table.t.")
                                                                    else 1.0)
    new = np.zeros(len(values), bool)
    if not changed:
        return new, None
    keep = np.ones(len(values), bool)
    keep[list(skip)] = False
    ks = np.flatnonzero(keep)
    found, first = evaluate(case, {c: {s: v[ks] for s, v in subs.items()} for c, subs in changed.items()}, len(ks))
    new[ks] = found
    return new, None if first is None else (int(ks[first[0]]), first[1])


@dataclass(frozen=True)
class Tolerance:
    """One parameter's tolerance: plus/minus ``pm``; ``sigma`` for a normal
    distribution in Monte Carlo (None: uniform in +-pm)."""
    path: str
    pm: float
    sigma: float | None = None


def tolerances_of(case, given=None) -> tuple:
    """The Tolerances of a case's [tolerances] section (or ``given``: {path:
    pm or {pm, sigma}}), checked: known paths, pm > 0, 0 < sigma, a length
    tolerance below the mechanism's size."""
    if given is not None and not hasattr(given, "items"):
        raise InputError(f"{case.source}: tolerances {given!r:.80}: expected a dict {{path: pm or {{pm, sigma}}}}")
    items = list((case.tolerances if given is None else given).items())   # a bare name of [parameters] too
    raw = dict(zip(to_paths(case, [k for k, _ in items], f"{case.source}: [tolerances]"), [v for _, v in items]))
    if not raw:
        raise InputError(f"{case.source}: no tolerances; expected a [tolerances] section "
                         '(e.g. "constraints.A.si.0" = 0.0001) or tolerances={path: pm}')
    listed = {p.path: p for p in resolve(case, raw, "[tolerances]")}
    from .model import characteristic_length

    size = characteristic_length(case)
    out, problems = [], []
    for path, v in raw.items():
        pm, sigma = (v.get("pm"), v.get("sigma")) if hasattr(v, "items") else (v, None)
        where = f"{case.source}: [tolerances]: key '{path}'"
        unknown = [k for k in v if k not in ("pm", "sigma")] if hasattr(v, "items") else []
        if unknown:   # a misspelt sigma would make the samples uniform unseen (the case file's check, for a dict)
            guess = suggest(unknown[0], ("pm", "sigma")) if isinstance(unknown[0], str) else None
            problems.append(f"{where}: key {show(unknown[0])}: unknown key; "
                            + (f"did you mean '{guess}'?" if guess else "expected pm and sigma"))
            continue
        pm, given_sigma, sigma = _real(pm), sigma, _real(sigma)
        if pm is None or not 0 < pm <= MAX_MAGNITUDE:   # a case file's numbers' bound: beyond, the bands overflow
            problems.append(f"{where}: got {show(v)}; expected a positive number (at most {MAX_MAGNITUDE:g}) or "
                            "{ pm = ..., sigma = ... }")
            continue
        if given_sigma is not None and (sigma is None or not 0 < sigma <= MAX_MAGNITUDE):
            problems.append(f"{where}: sigma {show(given_sigma)}; expected a positive number (at most "
                            f"{MAX_MAGNITUDE:g})")
            continue
        p = listed[path]
        if p.unit == case.length_unit and pm >= size:
            problems.append(f"{where}: +-{pm:g} {p.unit} is not smaller than the mechanism "
                            f"(its size {size:g} {p.unit}); expected a manufacturing tolerance, far below a link")
            continue
        if p.unit in HALF_TURN and pm >= HALF_TURN[p.unit]:   # +-half a turn covers every angle: not a tolerance
            problems.append(f"{where}: +-{pm:g} {p.unit} is not smaller than half a turn ({HALF_TURN[p.unit]:g} "
                            f"{p.unit}); expected a manufacturing tolerance of an angle, far below a turn")
            continue
        out.append(Tolerance(path, pm, sigma))
    if problems:
        raise InputError(problems)
    return tuple(out)


HALF_TURN = {"rad": math.pi, "deg": 180.0}   # an angle's tolerance is below it (a length's below the mechanism)


def _real(v) -> float | None:
    """v as a float: a number (not a bool) a float holds; else None (a
    whole number beyond a float's range, a text, a table)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        return float(v)
    except OverflowError:
        return None


def apply(case: Case, values, source: str | None = None) -> Case:
    """A new Case with ``values`` ({path or named dimension: number, or its
    text}) set, validated as a case file is (a value out of its key's range
    is that key's InputError)."""
    if not hasattr(values, "items"):
        raise InputError(f"{source or case.source}: parameters {values!r:.80}: expected a dict {{name or design "
                         "parameter path: value}}")
    variant = apply_many(case, [values], source)[0]
    if isinstance(variant, InputError):
        raise variant
    return variant


def apply_many(case: Case, designs, source: str | None = None, pinned: bool = False, warned=None) -> list:
    """``apply`` for many designs ({path: number} each) of one case, paths
    resolved once: per design its Case, or the InputError that refuses it.
    ``pinned``: every body keeps its frame (a drawn body too: the moved
    drawing's local coordinates are then affine in the drawn ones);
    ``warned``: a list that receives each design's warnings as a tuple of
    texts (empty for a refused design), in the designs' order, instead of
    warnings (kinem.sweep: which variants warned)."""
    import copy

    source = source or case.source
    designs = [dict(values) for values in designs]   # a name and its path in one design: refused (to_paths)
    designs = [dict(zip(to_paths(case, list(values), source), (_number(k, v, source) for k, v in values.items())))
               for values in designs]
    resolve(case, {path for v in designs for path in v})
    data, out = case_dict(case, pinned), []
    for values in designs:
        d = copy.deepcopy(data)
        for path, v in values.items():
            _assign(d, case, path, v)
        try:
            out.append(validated(d, source, as_written=False, warned=warned))
        except InputError as e:
            out.append(e)
            if warned is not None:
                warned.append(())
    return out


def _canonical(case, key):
    """A bare name of the case's [parameters] as its path, parameters.NAME; any other key as given."""
    return f"parameters.{key}" if isinstance(key, str) and "." not in key and key in case.parameters else key


def to_path(case, key, source) -> str:
    """A design parameter path; a bare name of [parameters] is parameters.NAME."""
    if not isinstance(key, str):
        raise InputError(f"{source}: parameter {key!r}: expected a name or a design parameter path")
    if "." in (path := _canonical(case, key)):
        return path
    guess = suggest(key, list(case.parameters) + [p.path for p in parameters(case)])
    raise InputError(f"{source}: unknown parameter {key!r}" + (f"; did you mean '{guess}'?" if guess else
                     "; expected a name of the case's [parameters] or a design parameter path "
                     "(kinem info CASE --parameters lists them)"))


def to_paths(case, keys, source) -> list:
    """``to_path`` of each key; two keys that name one parameter (a bare name and its path), or a name of
    [parameters] and a path of a number it gives (the path's value would stand, the name's be ignored there),
    are an InputError."""
    paths, first = [], {}
    for key in keys:
        path = to_path(case, key, source)
        if path in first:
            raise InputError(f"{source}: '{first[path]}' and '{key}' are one parameter ({path}); expected it once")
        first[path] = key
        paths.append(path)
    for path in paths:
        name = path[len("parameters."):] if path.startswith("parameters.") else None
        both = [u for u in case.uses.get(name, ()) if u in first] if name is not None else []
        if both:
            raise InputError(f"{source}: '{first[path]}' and '{first[both[0]]}' set one number: {name} of "
                             f"[parameters] gives {both[0]}; expected one of them")
    return paths


def _number(key, value, source):
    """A value as TOML would read it (command-line text converted), checked to be a number."""
    value = number(value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{source}: parameter {key!r}: got {value!r}; expected a number"
                         + (f" as a case file writes it ({TOML_NUMBERS})" if isinstance(value, str) else ""))
    return value


def local_tangent(case, path) -> dict:
    """point -> d(its local coordinates xi + i eta)/d(parameter at ``path``):
    a point's own coordinate, a drawn point's through its body's frame
    (pinned), a named dimension's through every point that uses it."""
    parts = path.split(".")
    if parts[0] == "parameters":
        out = {}
        for use in case.uses.get(parts[1], ()):
            if use.startswith("points."):
                for n, d in local_tangent(case, use).items():
                    out[n] = out.get(n, 0) + d
        return out
    if parts[0] != "points":
        return {}
    p = next(q for q in case.points if q.name == parts[1])
    if p.drawn is None:
        return {p.name: 1.0 if parts[3] == "0" else 1j}
    phi = next(b.q[2] for b in case.bodies if b.name == p.body)
    c, s = math.cos(phi), math.sin(phi)
    return {p.name: complex(c, -s) if parts[3] == "0" else complex(s, c)}


def frame_tangent(case, path) -> dict:
    """body -> (ds0, dalpha): how the frame a body derives from its drawn
    points (no q: origin at its first point, x axis towards the next one
    drawn elsewhere; kinem.casefile.drawn) moves in the body along the
    parameter at ``path``: its origin's local coordinates ds0 (xi + i eta,
    in the nominal frame) and its angle dalpha. Bodies whose frame does not
    move are left out."""
    moved = _drawn_tangent(case, path)
    if not moved:
        return {}
    drawn = {p.name: p.drawn for p in case.points if p.drawn is not None}
    out = {}
    for b in case.bodies:
        names = [n for n, _ in b.carries if n in drawn]
        if not b.derived or not names:
            continue
        c, s = math.cos(b.q[2]), math.sin(b.q[2])

        def local(d):   # A(phi0)^T d, d = dx + i dy
            return complex(c * d.real + s * d.imag, -s * d.real + c * d.imag)

        d0 = local(moved.get(names[0], 0j))
        axis = next((n for n in names[1:] if drawn[n] != drawn[names[0]]), None)
        dalpha = 0.0
        if axis is not None:
            length = math.hypot(drawn[axis][0] - drawn[names[0]][0], drawn[axis][1] - drawn[names[0]][1])
            dalpha = (local(moved.get(axis, 0j)).imag - d0.imag) / length
        if d0 or dalpha:
            out[b.name] = (d0, dalpha)
    return out


def driver_tangent(case, path) -> dict:
    """design parameter path -> its rate along the parameter at ``path``:
    a driver (or absolute constraint) of the angle of a body whose derived
    frame turns with the parameter (frame_tangent) drives that frame's
    direction, so its values turn with it: with the frames held, its
    values move by -dalpha (in the file's angle unit); so does a
    translational joint's phi0 that the file gives (one the loader filled
    in from the drawn frames follows them already). A gear's phi0 is not
    followed."""
    turns = {b: da for b, (_, da) in frame_tangent(case, path).items() if da}
    scale = 1 / DEGREE if case.units.get("angle") == "deg" else 1.0
    out = {}
    for c in case.constraints:
        if c.type == "translational" and "phi0" not in c.filled and {c["i"], c["j"]} & set(turns):
            out[f"constraints.{constraint_id(c)}.phi0"] = -(turns.get(c["i"], 0.0) - turns.get(c["j"], 0.0)) * scale
        if c.get("coord") != "phi" or c.get("body") not in turns or c.type not in ("driver", "absolute"):
            continue
        cid, rate = constraint_id(c), -turns[c["body"]] * scale
        if c.type == "absolute" and "value" in c.filled:   # the frame's own estimate: held as the frame turns
            continue
        if c.type == "absolute":
            out[f"constraints.{cid}.value"] = rate
        elif isinstance(c["d"], fn.Poly):
            out[f"constraints.{cid}.d.poly.0"] = rate
        elif isinstance(c["d"], fn.Harmonic):
            out[f"constraints.{cid}.d.harmonic.offset"] = rate
        else:
            out.update({f"constraints.{cid}.d.table.value.{k}": rate for k in range(len(c["d"].value))})
    return out


def _drawn_tangent(case, path) -> dict:
    """drawn point -> d(its drawn x + i y)/d(parameter at ``path``)."""
    parts = path.split(".")
    if parts[0] == "parameters":
        out = {}
        for use in case.uses.get(parts[1], ()):
            for n, d in _drawn_tangent(case, use).items():
                out[n] = out.get(n, 0j) + d
        return out
    if parts[0] != "points" or len(parts) != 4:
        return {}
    p = next((q for q in case.points if q.name == parts[1]), None)
    if p is None or p.drawn is None:
        return {}
    return {p.name: 1 + 0j if parts[3] == "0" else 1j}


def _listing(case):
    """(Parameter, None) of every design parameter."""
    read = {}   # point -> the constraints that read it
    for c in case.constraints:
        for point in c.refs.values():
            read.setdefault(point, {})[constraint_id(c)] = None
    points = [q for p in case.points if p.name in read for q in _of_point(case, p, read[p.name])]
    cons = [q for c in case.constraints for key in REGISTRY[c.type].keys for q in _of_key(case, c, key)]
    known = {p.path: p for p in points + cons}
    for name in case.parameters:
        if (named := _named(case, name, known.get)) is not None:
            yield named, None
    for p in points + cons:
        yield p, None


def _find(case, path, near=None):
    """The parameter at ``path`` from the one point, constraint key or named
    dimension it names (as ``_listing`` lists it), without listing the
    others; None when it is none. ``near``: a dict keeping, for one call's
    paths, the parameters of each point and key already listed (and under
    "#", the constraints by their ids)."""
    near = {} if near is None else near
    parts = path.split(".") if isinstance(path, str) else []
    if parts[:1] == ["parameters"] and len(parts) == 2 and parts[1] in case.parameters:
        return _named(case, parts[1], lambda use: _find(case, use, near))
    head = tuple(parts[:3])
    found = near.get(head)
    if found is None:
        found = near[head] = {q.path: q for q in _near(case, parts, near)}
    return found.get(path)


def _near(case, parts, near) -> list:
    """The parameters of the point or constraint key that ``parts`` (a path split) names."""
    if parts[:1] == ["points"] and len(parts) == 4:
        p = next((q for q in case.points if q.name == parts[1]), None)
        read = dict.fromkeys(constraint_id(c) for c in case.constraints if parts[1] in c.refs.values())
        return _of_point(case, p, read) if p is not None and read else []
    if parts[:1] == ["constraints"] and len(parts) >= 3:
        if "#" not in near:
            near["#"] = {constraint_id(c): c for c in case.constraints}
        c = near["#"].get(parts[1])
        key = next((k for k in REGISTRY[c.type].keys if k.name == parts[2]), None) if c is not None else None
        return _of_key(case, c, key) if key is not None else []
    return []


def _of_point(case, p, read) -> list:
    """The parameters of point p, read by the constraints ``read`` (their ids)."""
    out = []
    for k, axis in enumerate(("x", "y") if p.drawn else ("xi", "eta")):
        if p.drawn:
            on = [b.name for b in case.bodies if p.name in dict(b.carries)]
            what = (f"{axis} of point {p.name} drawn in the global frame, on {', '.join(on)} "
                    f"(read by {', '.join(read)})")
            out.append(Parameter(f"points.{p.name}.at.{k}", float(p.drawn[k]), case.length_unit, what))
        else:
            out.append(Parameter(f"points.{p.name}.at.{k}", float(p.at[k]), case.length_unit,
                                 f"{axis} of point {p.name} on body {p.body} (read by {', '.join(read)})"))
    return out


def _of_key(case, c, key) -> list:
    """The parameters of constraint c's key (none for a key naming a point or not given)."""
    if key.name not in c.fields or key.name in c.refs:
        return []
    cid, doc = constraint_id(c), f" ({key.doc})" if key.doc else ""
    head = f"constraints.{cid}.{key.name}"
    return [Parameter(f"{head}.{sub}" if sub else head, value, unit,
                      f"{c.type} {cid}: {key.name}.{sub}{doc}" if sub else f"{c.type} {cid}: {key.name}{doc}")
            for sub, value, unit in _numbers(case, c, key)]


def _named(case, name, known) -> Parameter | None:
    """The named dimension ``parameters.<name>``; ``known``: path -> its Parameter or None. None when
    every number that uses it is read by no constraint (a body's estimate or mass, the time span: not
    design parameters, and so not the name), or no number uses it (a variant whose numbers it gave are set
    apart, --set of their paths: setting it would move nothing)."""
    used = case.uses.get(name, ())
    read = [q for q in map(known, used) if q is not None]
    if not read:
        return None
    what = f"named dimension {name} of [parameters], used by {', '.join(used)}"
    return Parameter(f"parameters.{name}", float(case.parameters[name]), read[0].unit, what)


def _numbers(case, c, key):
    """(sub-path, value, unit) of key's numbers in constraint c, in the file's
    units: an angle of a case in degrees is in degrees."""
    degrees, length = case.units.get("angle") == "deg", case.length_unit
    for sub, value, quantity in key.numbers(c.fields[key.name]):
        unit = _unit(quantity, c, length)
        if degrees and unit.startswith("rad"):
            value, unit = value / DEGREE, "deg" + unit[3:]
        yield sub, float(value), unit


def _unit(quantity, c, length) -> str:
    """The unit of a quantity (kinem.casefile.keys.Key.numbers) in constraint c."""
    if quantity == "coordinate":
        quantity = "angle" if c.get("coord") == "phi" else "length"
    if quantity.startswith("rate"):
        k = int(quantity[4:])
        base = "rad" if c.get("coord", "x") == "phi" else length
        return base + (f"/s^{k}" if k > 1 else "/s" if k == 1 else "")
    return {"length": length, "angle": "rad", "frequency": "rad/s", "direction": ""}[quantity]


def _why_not(case, path, by_path) -> str:
    """Why ``path`` is not a parameter of ``case``, in one clause."""
    parts = path.split(".") if isinstance(path, str) else []
    head = parts[:2] + [""]
    if head[0] == "points" and f"points.{head[1]}.at.0" in by_path:
        return f"unknown parameter; point '{head[1]}' has points.{head[1]}.at.0 and points.{head[1]}.at.1"
    if head[0] == "points" and head[1] in {p.name for p in case.points}:
        return (f"point '{head[1]}' is read by no constraint (an output point): not a design parameter; "
                "expected a point that a constraint names")
    if head[0] == "bodies":
        return "body estimates, masses and inertias are read by no constraint: not design parameters"
    if head[0] == "parameters" and len(parts) == 2 and head[1] in case.parameters and not case.uses.get(head[1]):
        return (f"named dimension {head[1]} is used by no number of the case (the numbers it gave are set apart: "
                "their paths set): not a design parameter; expected a name that a constraint's or a point's number "
                "uses")
    if head[0] == "parameters" and len(parts) == 2 and head[1] in case.parameters:
        return (f"named dimension {head[1]} is used only by {', '.join(case.uses[head[1]])}, which no constraint "
                "reads: not a design parameter; expected a name that a constraint's or a point's number uses")
    c = _constraint(case, head[1]) if head[0] == "constraints" and len(parts) >= 3 else None
    if c is not None and head[1] != constraint_id(c):   # #N of a named constraint: its paths use the name
        return (f"constraint {head[1]} is named '{c.name}': its paths begin constraints.{c.name}; did you mean "
                f"'constraints.{c.name}.{'.'.join(parts[2:])}'?")
    if c is not None and parts[2] in c.refs:
        return f"key '{parts[2]}' names point '{c.refs[parts[2]]}': its parameters are points.{c.refs[parts[2]]}.at.0, .1"
    if c is not None and parts[2] in c.fields and not any(p.startswith(".".join(parts[:3]) + ".")
                                                          or p == ".".join(parts[:3]) for p in by_path):
        return f"key '{parts[2]}' of constraint {head[1]} does not shape the mechanism (an estimate or a choice)"
    guess = suggest(path, list(by_path) + ([] if "." in path else list(case.parameters)))   # a bare name too
    if guess is not None:
        return f"unknown parameter; did you mean {guess!r}?"
    return "unknown parameter; expected a design parameter path (kinem info CASE --parameters lists them)"


def _constraint(case, cid):
    for c in case.constraints:
        if cid in (c.name, f"#{c.index}"):
            return c
    return None


def _assign(data, case, path, value):
    """Set the number at ``path`` (a resolved parameter) in case_dict's ``data``."""
    parts = path.split(".")
    if parts[0] == "parameters":
        data["parameters"][parts[1]] = value
        return
    if parts[0] == "points":
        data["points"][parts[1]]["at"][int(parts[3])] = value
        return
    table = data["constraints"][_constraint(case, parts[1]).index - 1]
    keys = parts[2:]
    holder = _dig(table, keys[:-1])
    if isinstance(holder, list):
        holder[int(keys[-1])] = value
        if keys[-2:] == ["s", "0"] and _dig(table, keys[:-2]).get("periodic"):
            holder[-1] = value   # a periodic table's last radius is its first
    else:
        holder[keys[-1]] = value


def _dig(table, keys):
    for k in keys:
        table = table[int(k)] if isinstance(table, list) else table[k]
    return table


def case_dict(case: Case, pinned: bool = False) -> dict:
    """The case as the dict of its case file (kinem.load_dict's input): every
    value the loader filled in written out, in the file's units (degrees
    where units = { angle = "deg" }), a key that named a point names it
    again, a point drawn in the global frame drawn again (its bodies with
    their points lists; q only where the file gave it, or every body's with
    ``pinned``; a value the loader filled in from a drawn frame left to be
    filled in again), a number that named a [parameters] entry names it again.
    load_dict(case_dict(case)) equals case (but for its source, and to
    rounding for angles in degrees)."""
    from .casefile.sections import SOLVER_KEYS
    from .options import Options

    solver = Options.of(case)   # the [solver] section as the case gives it
    degrees = case.units.get("angle") == "deg"
    derived = {b.name for b in case.bodies if b.derived}
    d = {"name": case.name, "description": case.description, "units": dict(case.units),
         "time": {"end": case.end, "steps": case.steps},
         "solver": {k: getattr(solver, k) for k in SOLVER_KEYS},
         "bodies": {b.name: _body_dict(b, degrees, pinned) for b in case.bodies},
         "points": {p.name: {"body": p.body, "at": list(p.at)} if p.drawn is None
                    else {"body": p.body, "at": list(p.drawn), "frame": "global"} for p in case.points},
         "constraints": [_constraint_dict(case, c, set() if pinned else derived) for c in case.constraints],
         "engines": {name: {k: list(v) if isinstance(v, tuple) else v for k, v in s.items()}
                     for name, s in case.engines.items()},
         "report": {k: list(v) if isinstance(v, tuple) else v for k, v in case.report.items()}}
    if case.equivalent is not None:
        d["equivalent"] = {"group": case.equivalent.group, "points": list(case.equivalent.points)}
    if case.tolerances:
        d["tolerances"] = {k: dict(v) if hasattr(v, "items") else v for k, v in case.tolerances.items()}
    if case.parameters:
        d["parameters"] = dict(case.parameters)
        for name, paths in case.uses.items():
            for path in paths:
                _name_at(d, case, path, name)
    return d


def _body_dict(b, degrees, pinned):
    q = list(b.q[:2]) + [b.q[2] / DEGREE if degrees else b.q[2]]
    out = {"q": q, "mass": b.mass, "inertia": b.inertia,
           "points": [n for n, _ in b.carries] if b.carries else None}
    if b.derived and not pinned:
        del out["q"]
    return _drop_none(out)


def _name_at(d, case, path, name):
    """Write ``name`` at ``path`` of case_dict's ``d`` (a number that named it in the file)."""
    parts = path.split(".")
    if path == "time.dt":
        return   # written as its steps
    if parts[0] == "constraints":
        holder = d["constraints"][_constraint(case, parts[1]).index - 1]
        parts = parts[2:]
    else:
        holder = d
    if parts[:1] == ["bodies"] and "q" not in d["bodies"].get(parts[1], {}):
        return   # a derived frame's estimate: not written
    holder = _dig(holder, parts[:-1])
    holder[int(parts[-1]) if isinstance(holder, list) else parts[-1]] = name


def _drop_none(d):
    return {k: v for k, v in d.items() if v is not None}


def _constraint_dict(case, c, derived) -> dict:
    """Constraint c as the file writes it; a value the loader filled in from
    the estimates is left out where it reads a ``derived`` frame (the
    frames of a moved drawing fill it in again, as the file edited would)."""
    out = {"type": c.type}
    if constraint_id(c) == c.name:
        out["name"] = c.name
    refill = bool(c.filled) and any(c.fields.get(k.name) in derived for k in REGISTRY[c.type].keys
                                    if type(k).__name__ == "BodyKey")
    for k, v in c.fields.items():
        if refill and k in c.filled:
            continue
        out[k] = c.refs[k] if k in c.refs else _value(v)
    if case.units.get("angle") == "deg":   # the file's degrees again
        for key in REGISTRY[c.type].keys:
            if key.name not in out or key.name in c.refs:
                continue
            if not key.numbers(c.fields[key.name]) and key.angle:   # an estimate (theta)
                out[key.name] = c.fields[key.name] / DEGREE
            for sub, value, _ in _numbers(case, c, key):
                if sub == "":
                    out[key.name] = value
                else:
                    keys = sub.split(".")
                    holder = _dig(out[key.name], keys[:-1])
                    holder[int(keys[-1]) if isinstance(holder, list) else keys[-1]] = value
    return out


def _value(v):
    """A constraint field's value as the case file writes it."""
    if isinstance(v, fn.Poly):
        return {"poly": list(v.coeffs)}
    if isinstance(v, fn.Harmonic):
        return {"harmonic": {"amplitude": v.amplitude, "omega": v.omega, "phase": v.phase, "offset": v.offset}}
    if isinstance(v, fn.Table):
        return {"table": {"t": list(v.t), "value": list(v.value)}}
    if hasattr(v, "kind") and hasattr(v, "center"):   # an Outline
        if v.kind == "circle":
            return {"circle": {"radius": v.radius}, "center": list(v.center)}
        spline = {"theta": list(v.theta), "s": list(v.s), "periodic": v.periodic, "degrees": False}   # radians
        if not v.periodic:
            spline["bc"] = v.bc
        return {"spline": spline, "center": list(v.center)}
    if isinstance(v, tuple):
        return list(v)
    return v


__all__ = ["Parameter", "parameters", "resolve", "apply", "apply_many", "case_dict", "constraint_id", "local_tangent",
           "frame_tangent", "driver_tangent", "to_path", "ROOTS"]
