"""Cases with design parameters moved (the tangents' steps, kinem.tangents;
kinem.variants' and kinem.tolerance's designs): each design's Case with its
numbers set in place where it can be (``in_place``, ``_set``: a point's or
a constraint's number, one inside a function or outline table), without
re-validating it, else built and validated by kinem.parameters.apply_many
(``cases_of``); a parameter's step h, a power of two (``step_for``); and
which functions and outlines such a case holds in place of the case's
(``swapped``).
"""
import math
from dataclasses import is_dataclass, replace

from .constraints.read import constraint_id
from .errors import InputError
from .parameters import apply_many, driver_tangent, frame_tangent, resolve
from .spec import frozen_map


def moved_cases(case, listed):
    """(the case with p moved by h, h) for each parameter p: h a power of
    two near |p| / 2 (-h where +h is not a valid case), each case set in
    place where it can be, else validated (``cases_of``)."""
    if not listed:
        return []
    steps = [step_for(p.value) for p in listed]
    # drivers of drawn frames that p turns (none where p moves no frame: kinem.parameters.driver_tangent)
    turned = [driver_tangent(case, p.path) if frame_tangent(case, p.path) else {} for p in listed]
    wanted = {q for t in turned for q in t}
    values = {q.path: q.value for q in resolve(case, wanted)} if wanted else {}

    def design(p, h, turn):
        return {p.path: p.value + h, **{q: values[q] + h * rate for q, rate in turn.items()}}

    out = list(zip(cases_of(case, [design(p, h, t) for p, h, t in zip(listed, steps, turned)], pinned=True), steps))
    for k, (moved, h) in enumerate(out):
        if isinstance(moved, InputError):
            p = listed[k]
            out[k] = (quiet(apply_many, case, [design(p, -h, turned[k])], pinned=True)[0], -h)
            if isinstance(out[k][0], InputError):
                raise InputError(f"{case.source}: parameter '{p.path}': no valid case within {h:g} of its value")
    return out


def cases_of(case, designs, pinned=False) -> list:
    """Per design ({path: value}) its Case: set in place where ``in_place``
    can, else built and validated by kinem.parameters.apply_many (``pinned``
    as there); or the InputError that refuses it."""
    lookup = _lookup(case) if case.units.get("angle") != "deg" and not any(b.carries for b in case.bodies) else None
    moved = [_all_set(case, values, lookup) if lookup else None for values in designs]
    slow = [values for values, m in zip(designs, moved) if m is None]
    built = iter(quiet(apply_many, case, slow, pinned=pinned) if slow else ())
    return [m if m is not None else next(built) for m in moved]


def quiet(fn, *args, **kwargs):
    """fn(...) without KinemWarnings: a moved case's (a fast driver) are its case's, given once when it was
    loaded (they reached the command line as Python's two-line warnings: tolerance of a fast driver)."""
    import warnings

    from .errors import KinemWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", KinemWarning)
        return fn(*args, **kwargs)


def in_place(case, values):
    """The case with every number {path: value} set in place (no
    validation; see ``_set``), or None where one cannot be: angles in
    degrees (the paths' values are then converted on loading), drawn
    bodies, or a path ``_set`` does not take; then
    kinem.parameters.apply_many builds it."""
    return None if case.units.get("angle") == "deg" else _all_set(case, values)


def _replaced(case, path, value):
    """The case with the number at ``path`` set to ``value`` in place, or None."""
    return _all_set(case, {path: value})


def _all_set(case, values, lookup=None):
    if lookup is None and any(b.carries for b in case.bodies):
        return None
    lookup = lookup or _lookup(case)
    points, constraints = list(case.points), list(case.constraints)
    if not all(_set(points, constraints, path, value, lookup) for path, value in values.items()):
        return None
    return _with(case, points=tuple(points), constraints=tuple(constraints))


def _with(obj, **fields):
    """dataclasses.replace of a frozen dataclass of kinem.spec (none has a
    __post_init__) without its per-field work: a case has some twenty."""
    new = object.__new__(type(obj))
    new.__dict__.update(obj.__dict__)
    new.__dict__.update(fields)
    return new


def _lookup(case) -> tuple:
    """What ``_set`` looks up in a case's lists: (constraint id -> its place,
    point -> its place, point -> the places of the constraints that read it)."""
    ids, readers = {}, {}
    for i, c in enumerate(case.constraints):
        ids.setdefault(constraint_id(c), i)
        for point in dict.fromkeys(c.refs.values()):
            readers.setdefault(point, []).append(i)
    return ids, {q.name: j for j, q in enumerate(case.points)}, readers


def _set(points, constraints, path, value, lookup) -> bool:
    """Sets the number at ``path`` to ``value`` in the lists of a case's
    points and constraints without re-validating it; False (lists
    untouched) for any other path: ``points.P.at.k`` (the point and every
    constraint key that names it), ``constraints.C.KEY.k`` of a vector key
    that names no point or ``constraints.C.KEY`` of a scalar key. The
    tables read these numbers as given and are affine in them (h keeps the
    number's sign), so the tangent is the one a validated case gives
    (tests/test_sensitivity.py compares them). ``lookup``: the case's ``_lookup``."""
    ids, at, readers = lookup
    parts = path.split(".")
    i = ids.get(parts[1]) if parts[0] == "constraints" and len(parts) >= 3 else None
    if len(parts) == 3 and i is not None:
        c = constraints[i]
        if isinstance(c.fields.get(parts[2]), float) and parts[2] not in c.refs:
            constraints[i] = _with(c, fields=frozen_map({**c.fields, parts[2]: float(value)}))
            return True
        return False
    if len(parts) >= 5 and i is not None:
        return _set_entry(constraints, i, parts, value)
    if len(parts) != 4 or not parts[3].isdigit():
        return False
    k = int(parts[3])

    def moved(v):
        v = list(v)
        v[k] = value
        return tuple(v)

    if parts[0] == "points" and parts[1] in at:
        j = at[parts[1]]
        if len(points[j].at) <= k:
            return False
        moved_at = moved(points[j].at)
        points[j] = _with(points[j], at=moved_at)
        for i in readers.get(parts[1], ()):
            c = constraints[i]
            constraints[i] = _with(c, fields=frozen_map(
                {**c.fields, **{key: moved_at for key, q in c.refs.items() if q == parts[1]}}))
        return True
    if i is None:
        return False
    c = constraints[i]
    v = c.fields.get(parts[2])
    if parts[2] in c.refs or not isinstance(v, tuple) or len(v) <= k:
        return False
    constraints[i] = _with(c, fields=frozen_map({**c.fields, parts[2]: moved(v)}))
    return True


# the field of a function's or an outline's number (kinem.casefile.keys: numbers): sub-path head -> field
_ENTRIES = {"poly": "coeffs", "table": "value", "spline": "s", "center": "center"}


def _set_entry(constraints, i, parts, value) -> bool:
    """_set for a number inside a function or an outline table of
    constraints[i]: ``constraints.C.KEY.poly.k``, ``.harmonic.NAME``,
    ``.table.value.k``, ``.circle.radius``, ``.spline.s.k``, ``.center.k``
    (a periodic outline's first radius is its last too), or False."""
    sub = parts[3:]
    for c in constraints[i:i + 1]:
        v = c.fields.get(parts[2])
        if parts[2] in c.refs or not is_dataclass(v):
            return False
        if sub[0] in ("harmonic", "circle") and len(sub) == 2 and isinstance(getattr(v, sub[1], None), float):
            moved = replace(v, **{sub[1]: float(value)})
        else:
            key = _ENTRIES.get(sub[0])
            if (sub[0], sub[1:2]) in (("table", ["value"]), ("spline", ["s"])):
                sub = sub[1:]
            if key is None or len(sub) != 2 or not sub[1].isdigit() or not isinstance(getattr(v, key, None), tuple):
                return False
            k, entries = int(sub[1]), list(getattr(v, key))
            if k >= len(entries):
                return False
            entries[k] = float(value)
            if key == "s" and k == 0 and getattr(v, "periodic", False):
                entries[-1] = float(value)
            moved = replace(v, **{key: tuple(entries)})
        constraints[i] = _with(c, fields=frozen_map({**c.fields, parts[2]: moved}))
        return True
    return False


def step_for(value) -> float:
    """The step moved_cases takes p by: a power of two near |p| / 2 (0.5 at 0),
    2^(floor(log2 |p|) - 1) with the exponent read exactly (math.frexp)."""
    return math.ldexp(1.0, math.frexp(value)[1] - 2) if value else 0.5


def swapped(case, moved):
    """{id(old): new} of the functions and outlines that ``moved`` (a case
    from _replaced) holds in place of the case's, when it changes nothing
    else (_set_entry); else None."""
    if (isinstance(moved, InputError) or len(moved.constraints) != len(case.constraints)
            or moved.bodies is not case.bodies or any(a is not b for a, b in zip(case.points, moved.points))):
        return None
    swap = {}
    for c0, c1 in zip(case.constraints, moved.constraints):
        if c0 is c1:
            continue
        for key, v in c1.fields.items():
            old = c0.fields.get(key)
            if old is not v:
                if not (is_dataclass(v) and is_dataclass(old)) or isinstance(v, type):
                    return None
                swap[id(old)] = v
    return swap
