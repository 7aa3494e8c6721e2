"""Design parameters: the numbers of a case that shape the mechanism, each
named by a dot path in the case file's own words (docs/case-format.md,
"Design parameters"):

    points.<point>.at.<k>                     a named point's local coordinate
    constraints.<name>.<key>                  a scalar key (a radius, a length, phi0)
    constraints.<name>.<key>.<k>              an entry of a vector key (si, qi, value, u)
    constraints.<name>.<key>.<sub>[.<k>]      inside a function or outline table
                                              (d.poly.1, outline.spline.s.3, outline.center.0)

A constraint is addressed by its name, an unnamed one by ``#<index>``
(1-based, its place in the file). A constraint key that names a point
(``si = "A"``) is that point's coordinate: ``points.A.at.<k>``, which moves
every constraint that reads it. A named point that no constraint reads, body
estimates, masses and contact-angle estimates (``theta``) are not design
parameters. A default a case file leaves out and the loader fills in (a
joint's ``phi0``, a ground's ``value``) is a parameter of its own, held at
its nominal value when another moves.

``parameters(case)`` lists them; ``resolve(case, paths)`` checks paths
(unknown: a did-you-mean; read by no constraint: refused, naming it);
``apply(case, {path: value})`` returns a new Case, validated as a case file
is. A later ``parameters.<name>`` (a named dimension) is one more root here:
``ROOTS``, ``_listing`` and ``_assign``.
"""
from dataclasses import dataclass

from . import functions as fn
from .casefile.checks import suggest
from .constraints import REGISTRY
from .errors import InputError
from .spec import Case

ROOTS = ("points", "constraints")


@dataclass(frozen=True)
class Parameter:
    """One design parameter: its path, nominal value, unit and what it is, in words."""
    path: str
    value: float
    unit: str
    what: str

    def as_dict(self) -> dict:
        return {"path": self.path, "value": self.value, "unit": self.unit, "what": self.what}


def constraint_id(c) -> str:
    """How a path names constraint c: its name, ``#<index>`` when the file gave none."""
    return f"#{c.index}" if c.name == f"{c.type}-{c.index}" else c.name


def parameters(case: Case) -> tuple[Parameter, ...]:
    """Every design parameter of the case, points first, then constraints in file order."""
    return tuple(p for p, _ in _listing(case))


def resolve(case: Case, paths) -> tuple[Parameter, ...]:
    """The parameters named by ``paths`` (in order, each once), or one
    InputError naming the case file and every bad path."""
    known = dict(_listing(case))
    by_path = {p.path: p for p in known}
    problems, out = [], []
    for path in dict.fromkeys(paths):
        if path in by_path:
            out.append(by_path[path])
        else:
            problems.append(f"{case.source}: parameter {path!r}: {_why_not(case, path, by_path)}")
    if problems:
        raise InputError(problems)
    return tuple(out)


def apply(case: Case, values, source: str | None = None) -> Case:
    """A new Case with ``values`` ({path: number}) set, validated as a case
    file is (a value out of its key's range is that key's InputError)."""
    variant = apply_many(case, [values], source)[0]
    if isinstance(variant, InputError):
        raise variant
    return variant


def apply_many(case: Case, designs, source: str | None = None) -> list:
    """``apply`` for many designs ({path: number} each) of one case, paths
    resolved once: per design its Case, or the InputError that refuses it."""
    import copy

    from .case import load_dict

    designs = [dict(v) for v in designs]
    resolve(case, {path for v in designs for path in v})
    data, out = case_dict(case), []
    for values in designs:
        d = copy.deepcopy(data)
        for path, v in values.items():
            _assign(d, case, path, v)
        try:
            out.append(load_dict(d, source=source or case.source))
        except InputError as e:
            out.append(e)
    return out


def _listing(case):
    """(Parameter, where): where says how to set it (_assign)."""
    read = {}   # point -> the constraints that read it
    for c in case.constraints:
        for point in c.refs.values():
            read.setdefault(point, []).append(constraint_id(c))
    length = case.length_unit
    for p in case.points:
        if p.name in read:
            for k, axis in enumerate(("xi", "eta")):
                yield Parameter(f"points.{p.name}.at.{k}", float(p.at[k]), length,
                                f"{axis} of point {p.name} on body {p.body} (read by {', '.join(read[p.name])})"), None
    for c in case.constraints:
        cid = constraint_id(c)
        for key in REGISTRY[c.type].keys:
            if key.name not in c.fields or key.name in c.refs:
                continue
            for sub, value, quantity in key.numbers(c.fields[key.name]):
                path = ".".join(x for x in ("constraints", cid, key.name, sub) if x)
                what = f"{c.type} {cid}: {key.name}" + (f".{sub}" if sub else "") + (f" ({key.doc})" if key.doc else "")
                yield Parameter(path, float(value), _unit(quantity, c, length), what), None


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
    c = _constraint(case, head[1]) if head[0] == "constraints" and len(parts) >= 3 else None
    if c is not None and parts[2] in c.refs:
        return f"key '{parts[2]}' names point '{c.refs[parts[2]]}': its parameters are points.{c.refs[parts[2]]}.at.0, .1"
    if c is not None and parts[2] in c.fields and not any(p.startswith(".".join(parts[:3]) + ".")
                                                          or p == ".".join(parts[:3]) for p in by_path):
        return f"key '{parts[2]}' of constraint {head[1]} does not shape the mechanism (an estimate or a choice)"
    guess = suggest(path, by_path)
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


def case_dict(case: Case) -> dict:
    """The case as the dict of its case file (kinem.load_dict's input): every
    value the loader filled in written out, a key that named a point names it
    again. load_dict(case_dict(case)) equals case (but for its source)."""
    from .casefile.sections import SOLVER_KEYS
    from .options import Options

    solver = Options.of(case)   # the [solver] section as the case gives it
    d = {"name": case.name, "description": case.description, "units": dict(case.units),
         "time": {"end": case.end, "steps": case.steps},
         "solver": {k: getattr(solver, k) for k in SOLVER_KEYS},
         "bodies": {b.name: _drop_none({"q": list(b.q), "mass": b.mass, "inertia": b.inertia}) for b in case.bodies},
         "points": {p.name: {"body": p.body, "at": list(p.at)} for p in case.points},
         "constraints": [_constraint_dict(c) for c in case.constraints],
         "engines": {name: {k: list(v) if isinstance(v, tuple) else v for k, v in s.items()}
                     for name, s in case.engines.items()},
         "report": {k: list(v) if isinstance(v, tuple) else v for k, v in case.report.items()}}
    if case.equivalent is not None:
        d["equivalent"] = {"group": case.equivalent.group, "points": list(case.equivalent.points)}
    if case.tolerances:
        d["tolerances"] = {k: dict(v) if hasattr(v, "items") else v for k, v in case.tolerances.items()}
    return d


def _drop_none(d):
    return {k: v for k, v in d.items() if v is not None}


def _constraint_dict(c) -> dict:
    out = {"type": c.type}
    if constraint_id(c) == c.name:
        out["name"] = c.name
    for k, v in c.fields.items():
        out[k] = c.refs[k] if k in c.refs else _value(v)
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
        spline = {"theta": list(v.theta), "s": list(v.s), "periodic": v.periodic}
        if not v.periodic:
            spline["bc"] = v.bc
        return {"spline": spline, "center": list(v.center)}
    if isinstance(v, tuple):
        return list(v)
    return v


__all__ = ["Parameter", "parameters", "resolve", "apply", "apply_many", "case_dict", "constraint_id", "ROOTS"]
