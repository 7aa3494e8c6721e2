"""The tangents of the model's tables along design parameters
(kinem.sensitivity's and kinem.variants' input; docs/design.md, "Design
sensitivities"): the tables are affine in the case's numbers, so a
parameter's tangent is their exact linear part, each the cheapest exact
way (``tangent_parts``): a spline outline's values from one spline
(``_spline_tangents``), a unit of the function or outline table taken
directly (``_direct``), a point that lands as it is in its families'
tables (``_landed``), a family built once for all the parameters that move
it (``_stacked``), the moved driving functions numbered once
(``_function_tangents``); else the moved case's tables' difference
(kinem.moved_tables.moved_tangent). ``tangents(model, paths)`` gives them
in full (every family and column).
"""
import numpy as np

from .constraints import REGISTRY
from .constraints.read import constraint_id
from .errors import InputError
from .functions import FunctionTable, Harmonic, Poly
from .model import _Context
from .moved import moved_cases, step_for, swapped
from .moved_tables import moved_tangent, points_tangent, same, zeros_of
from .outline import Outline, OutlineTable
from .parameters import local_tangent, resolve


def tangent_parts(model, listed) -> list:
    """Per parameter of ``listed`` its tangent as ``moved_tangent`` gives
    it (only the families it moves), each the cheapest exact way: a spline
    outline's values from one spline, a unit of the function or outline
    table taken directly, a family built once for all the parameters that
    move it, the moved driving functions numbered once; else its own moved
    case's families rebuilt."""
    case, base = model.case, model.tables
    parts = _spline_tangents(case, listed, base)
    parts.update(_direct(model, [(k, p) for k, p in enumerate(listed) if k not in parts]))
    parts.update(_landed(model, [(k, p) for k, p in enumerate(listed) if k not in parts]))
    rest = [k for k in range(len(listed)) if k not in parts]
    items = [(k, listed[k], moved, h) for k, (moved, h) in zip(rest, moved_cases(case, [listed[k] for k in rest]))]
    parts.update(_stacked(case, model.length, base, items))
    parts.update(_function_tangents(case, base, [i for i in items if i[0] not in parts]))
    for k, p, moved, h in items:
        if k not in parts:
            parts[k] = moved_tangent(case, model.length, base, p, moved, h)
    return [parts[k] for k in range(len(listed))]


def _tangent(case, length, base, p, moved, step):
    """The tangent of the tables along parameter p (their linear part: the
    tables are affine in the case's numbers; ``moved``: the case with p
    moved by ``step``) and of the named points' local coordinates:
    ((families [(kind, table, tangent)], (functions, tangent), (outlines,
    tangent)), dlocal), every family and every column (zero where p does
    not move it)."""
    return _full(base, moved_tangent(case, length, base, p, moved, step))


def _full(base, part):
    """A ``moved_tangent`` in ``_tangent``'s format: every family, function and outline column, zero where unmoved."""
    (families, functions, outlines), dlocal = part
    tangent = {k: d for k, _, _, d in families}
    return ([(kind, t0, {**zeros_of(t0), **tangent.get(k, {})}) for k, (kind, t0) in enumerate(base[0])],
            (functions[0], functions[1] or zeros_of(functions[0])),
            (outlines[0], outlines[1] or zeros_of(outlines[0]))), dlocal


def tangents(model, paths, base=None) -> list:
    """Per design parameter path, the tangent of the model's tables along it
    in the format of ``_tangent`` (the tables are affine in the case's
    numbers: a design's tables are the nominal ones plus the sum over p of
    (value - nominal) x tangent_p), built as the sensitivities' (``tangent_parts``);
    ``base``: the model's tables (Model.tables), as the tangents take them."""
    return [_full(base or model.tables, part) for part in tangent_parts(model, resolve(model.case, list(paths)))]


def _spline_tangents(case, listed, base) -> dict:
    """{k: ``moved_tangent``} for the parameters listed[k] that are a value
    s_j of a spline outline (``constraints.C.KEY.spline.s.j``; not the
    last of a periodic one, which the first sets): the outline's pieces are
    linear in s, so the tangent is the pieces of the spline through the
    unit vector e_j (e_0 + e_last for a periodic outline's first) in that
    outline's coefficients (OutlineTable's layout: pieces first[o] ..
    last[o], 4 coefficients each), every j of one outline from one
    CubicSpline. No family's table moves (as kinem.moved_tables._entries)."""
    if not any(".spline.s." in p.path for p in listed):
        return {}
    from scipy.interpolate import CubicSpline

    numbered = [o for f in base[3] for o in f[1]]
    first, last = base[2]["first"], base[2]["last"]
    by_outline = {}
    for k, p in enumerate(listed):
        parts = p.path.split(".")
        if len(parts) != 6 or parts[0] != "constraints" or parts[3:5] != ["spline", "s"] or not parts[5].isdigit():
            continue
        c = next((c for c in case.constraints if constraint_id(c) == parts[1]), None)
        o, j = c.fields.get(parts[2]) if c is not None else None, int(parts[5])
        if (isinstance(o, Outline) and o.kind == "spline" and j < len(o.s) - o.periodic
                and any(x is o for x in numbered)):
            by_outline.setdefault(id(o), (o, []))[1].append((k, j))
    out, zero = {}, None
    for o, ks in by_outline.values():
        unit = np.zeros((len(o.s), len(ks)))
        for col, (_, j) in enumerate(ks):
            unit[j, col] = 1.0
            if o.periodic and j == 0:
                unit[-1, col] = 1.0
        c = CubicSpline(np.array(o.theta), unit, bc_type=o.bc).c    # (4, pieces, len(ks))
        places = [i for i, x in enumerate(numbered) if x is o]
        zero = zero or zeros_of(base[2])   # the unmoved columns' zeros, shared (read only)
        for col, (k, _) in enumerate(ks):
            tangent = {**zero, "coef": np.zeros_like(zero["coef"])}
            for place in places:
                tangent["coef"][4 * first[place]:4 * (last[place] + 1)] = c[:, :, col].T.ravel()
            out[k] = ([], (base[1], {}), (base[2], tangent)), points_tangent(case, listed[k])
    return out


def _direct(model, items) -> dict:
    """{k: ``moved_tangent``} for the parameters of items [(k, p)] whose
    tangent is one number of the function or outline tables, taken as it
    is (S5's difference is a unit there, nothing else moves): a ground's
    ``value.k`` or an absolute constraint's ``value`` (the constant
    function Poly((value,)) its row numbered), a driving function's
    ``poly.k`` or ``harmonic.NAME`` (the function the constraint holds, at
    every place the table numbers it: ((v + h) - v) / h with moved_cases' h,
    the moved function's difference), an outline's ``center.k``
    (its centre: 1 or i) and a circle's ``circle.radius`` (its one piece's
    constant coefficient), where the tables hold the nominal value there.
    Not in a case in degrees (its angles' values are converted) nor one
    with drawn bodies (the ground's value places a drawn frame too)."""
    case, base = model.case, model.tables
    if case.units.get("angle") == "deg" or any(b.carries for b in case.bodies):
        return {}
    functions, outlines = base[1], base[2]
    numbered = [o for f in base[3] for o in f[1]]
    kinds, by_id, function_list = [type(f) for f in model.families], None, None
    out = {}
    for k, p in items:
        parts = p.path.split(".")
        if parts[0] != "constraints" or len(parts) < 3:
            continue
        by_id = by_id or {constraint_id(c): c for c in reversed(case.constraints)}   # the first of an id
        c = by_id.get(parts[1])
        if c is None:
            continue
        if (c.type, parts[2:3], len(parts)) in (("ground", ["value"], 4), ("absolute", ["value"], 3)):
            place = kinds.index(REGISTRY[c.type].family)
            first = model.offsets[place]
            rows = [r - first for r in range(first, first + model.families[place].n_rows) if model.row_owner[r] == c.name]
            f = base[0][place][1]["f"][rows[int(parts[3]) if len(parts) == 4 else 0]]
            start = functions["start"][f]
            if functions["start"][f + 1] - start != 1 or functions["data"][start] != p.value:
                continue
            d = np.zeros_like(functions["data"])
            d[start] = 1.0
            out[k] = ([], (functions, {"data": d}), (outlines, {})), points_tangent(case, p)
            continue
        o = c.fields.get(parts[2])
        if len(parts) == 5 and (type(o), parts[3]) in ((Poly, "poly"), (Harmonic, "harmonic")):
            function_list = function_list or [x for f in base[3] for x in f[0]]
            j = (int(parts[4]) if parts[4].isdigit() else -1) if parts[3] == "poly" else _HARMONIC.get(parts[4], -1)
            places = [i for i, x in enumerate(function_list) if x is o]
            start, data = functions["start"], functions["data"]
            width = len(o.coeffs) if parts[3] == "poly" else len(_HARMONIC)
            if (not places or not 0 <= j < width or any(start[i + 1] - start[i] != width for i in places)
                    or any(data[start[i] + j] != p.value for i in places)):
                continue
            h = step_for(p.value)
            d = np.zeros_like(data)
            d[[start[i] + j for i in places]] = ((p.value + h) - p.value) / h   # the moved function's difference
            out[k] = ([], (functions, {"data": d}), (outlines, {})), points_tangent(case, p)
            continue
        places = [i for i, x in enumerate(numbered) if x is o]
        if not isinstance(o, Outline) or not places:
            continue
        tangent = zeros_of(outlines)
        if parts[3:5] in (["center", "0"], ["center", "1"]) and len(parts) == 5:
            if any(outlines["center"][i] != complex(*o.center) for i in places):
                continue
            tangent["center"][places] = 1.0 if parts[4] == "0" else 1j
        elif parts[3:] == ["circle", "radius"] and o.kind == "circle":
            at = [4 * outlines["first"][i] + 3 for i in places]
            if any(outlines["coef"][j] != o.radius for j in at):
                continue
            tangent["coef"][at] = 1.0
        else:
            continue
        out[k] = ([], (functions, {}), (outlines, tangent)), points_tangent(case, p)
    return out


def _landed(model, items) -> dict:
    """{k: ``moved_tangent``} for the parameters of items [(k, p)] that are
    a coordinate of a point that lands as it is in its families' tables
    (Family.lands: a revolute's and a distance's si, sj, a follower's
    point, a translational joint's points) or in a difference of two
    (Family.spans: a line's direction): a constraint's key
    ``constraints.C.KEY.k`` (or a scalar ``constraints.C.KEY`` landing in a
    real column: a translational joint's phi0) or a point
    ``points.P.at.k`` whose every reader
    reads it through such keys. Its tangent is, at each such constraint's
    entry of the columns, what the moved case's difference gives, ((v + h)
    - v) / h, or that of a - b with a or b moved (times i for k = 1), with
    moved_cases' h (``step_for``), the family's other columns left out (zero):
    the moved case's families rebuilt, without building them. Not in a case
    in degrees nor one with drawn bodies (as ``_direct``)."""
    case, base = model.case, model.tables
    if not items or case.units.get("angle") == "deg" or any(b.carries for b in case.bodies):
        return {}
    place_of = {type(f): k for k, f in reversed(list(enumerate(model.families)))}
    where, count, ids, readers = [], {}, {}, {}   # per constraint (place, index in its family)
    for i, c in enumerate(case.constraints):
        place = place_of[REGISTRY[c.type].family]
        where.append((place, count.get(place, 0)))
        count[place] = count.get(place, 0) + 1
        ids.setdefault(constraint_id(c), i)
        for key, point in c.refs.items():
            readers.setdefault(point, []).append((i, key))
    names = {q.name: j for j, q in enumerate(case.points)}
    out, nominal_columns = {}, {}   # (place, column) -> the nominal column as a list (read once)
    for k, p in items:
        parts = p.path.split(".")
        if len(parts) == 3 and parts[0] == "constraints" and parts[1] in ids:   # a scalar key: as a point's x
            parts.append("0")
        if len(parts) != 4 or parts[3] not in ("0", "1"):
            continue
        if parts[0] == "points":
            reads = readers.get(parts[1], ())
            if len({i for i, _ in reads}) != len(reads):   # a constraint reading it twice: left to _stacked
                continue
        elif parts[0] == "constraints" and parts[1] in ids:
            i = ids[parts[1]]
            reads = () if parts[2] in case.constraints[i].refs else ((i, parts[2]),)
        else:
            continue
        h = step_for(p.value)
        unit = ((p.value + h) - p.value) / h * (1.0 if parts[3] == "0" else 1j)
        tangent = {}
        axis = int(parts[3])
        for i, key in reads:
            (place, j), fields = where[i], case.constraints[i].fields
            family = model.families[place]
            moves = [(family.lands[key], None)] if key in family.lands else []
            moves += [(column, ab) for column, ab in family.spans.items() if key in ab]
            v = fields.get(key)
            scalar = type(v) is float and len(p.path.split(".")) == 3
            if scalar:
                v = (v,)
            if not moves or not isinstance(v, tuple) or v[axis] != p.value or (scalar and any(ab for _, ab in moves)):
                break
            for column, ab in moves:
                t0 = nominal_columns.get((place, column))
                if t0 is None and column in base[0][place][1]:
                    t0 = nominal_columns[place, column] = base[0][place][1][column].tolist()
                a, b = (v, None) if ab is None else (fields.get(ab[0]), fields.get(ab[1]))
                if t0 is None or len(t0) != count[place] or not isinstance(a, tuple) or not (
                        t0[j] == (a[0] if scalar else complex(*a) if ab is None else complex(a[0] - b[0], a[1] - b[1]))):
                    break
                if ab is None:
                    x = unit
                else:   # the moved difference's, as the family forms it: a - b with a or b moved by h
                    nominal = a[axis] - b[axis]
                    moved = (a[axis] + h if ab[0] == key else a[axis]) - (b[axis] + h if ab[1] == key else b[axis])
                    x = (moved - nominal) / h * (1.0 if axis == 0 else 1j)
                d = tangent.setdefault(place, {}).get(column)
                if d is None:
                    d = tangent[place][column] = np.zeros_like(base[0][place][1][column])
                d[j] = x
            else:
                continue
            break
        else:
            if tangent:
                dlocal = np.zeros(len(names), complex)
                if parts[0] == "points":
                    for point, d in local_tangent(case, p.path).items():
                        dlocal[names[point]] += d
                out[k] = ([(place, *base[0][place], d) for place, d in sorted(tangent.items())], (base[1], {}),
                          (base[2], {})), dlocal
    return out


# a harmonic function's numbers in the function table (kinem.functions.FunctionTable.arrays)
_HARMONIC = {"amplitude": 0, "omega": 1, "phase": 2, "offset": 3}


def _stacked(case, length, base, items) -> dict:
    """{k: ``moved_tangent``} for the parameters of items [(k, p, moved
    case, h)] whose moved case (set in place) changes only constraints of
    families that number no function or outline: each such family built
    once, over its constraints followed by every parameter's changed ones
    (each column then holds the nominal's rows, r per constraint, and after
    them the changed constraints' rows in turn, which the nominal's own
    rows and the changed ones' integer columns, those of the constraints
    they replace, confirm; else it is left to ``moved_tangent``), a
    parameter's tangent the difference of its constraints' rows and the
    nominal's over h, zero in the others'."""
    if not items:
        return {}
    order, where, count = {}, [], {}   # family -> its place; per constraint (family, index in it)
    for c in case.constraints:
        family = REGISTRY[c.type].family
        order.setdefault(family, len(order))
        where.append((family, count.get(family, 0)))
        count[family] = count.get(family, 0) + 1
    wanted, changed = {}, {}   # family -> [(k, h, [(index in it, moved constraint)])]; k -> families
    for k, p, moved, h in items:
        if (isinstance(moved, InputError) or len(moved.constraints) != len(case.constraints)
                or moved.bodies is not case.bodies):
            continue
        moves = {}
        for (family, j), c0, c1 in zip(where, case.constraints, moved.constraints):
            if c0 is not c1:
                moves.setdefault(family, []).append((j, c1))
        if not moves or any(base[3][order[f]] != ((), ()) for f in moves):
            continue
        changed[k] = set(moves)
        for family, cons in moves.items():
            wanted.setdefault(family, []).append((k, h, cons))
    tangents = {}
    for family, moved_lists in wanted.items():
        place = order[family]
        t0, n = base[0][place][1], count[family]
        nominal = [c for c, (f, _) in zip(case.constraints, where) if f is family]
        ks, hs, indices = [k for k, _, _ in moved_lists], [h for _, h, _ in moved_lists], [
            [j for j, _ in cons] for _, _, cons in moved_lists]
        functions, outlines, ctx = FunctionTable(False), OutlineTable(False), _Context(case, length)
        table = family(nominal + [c for _, _, cons in moved_lists for _, c in cons], ctx).table(functions, outlines)[1]
        rows = {key: len(v) // n for key, v in t0.items()}   # per constraint
        if functions.functions or outlines.outlines or ctx.artificial or table.keys() != t0.keys() or not all(
                len(v) == rows[key] * n and len(table[key]) == len(v) + rows[key] * sum(map(len, indices))
                and same(table[key][:len(v)], v) for key, v in t0.items()):
            continue
        which = np.array([j for js in indices for j in js])   # each changed constraint's index in the family
        owner = np.repeat(np.arange(len(indices)), list(map(len, indices)))   # its parameter
        steps = np.array([h for h, js in zip(hs, indices) for _ in js])
        moves, spread = {}, {1: (which, owner, steps)}   # rows per constraint -> (rows, their parameter, its h)
        for key, v in t0.items():
            r = rows[key]
            if r not in spread:
                spread[r] = ((which[:, None] * r + np.arange(r)).ravel(), np.repeat(owner, r), np.repeat(steps, r))
            nominal_rows, of, h = spread[r]
            new = table[key][len(v):]
            if v.dtype.kind in "iu":
                if not same(new, v[nominal_rows]):
                    break
                continue
            moves[key] = np.zeros((len(indices),) + v.shape, v.dtype)
            moves[key][of, nominal_rows] = (new - v[nominal_rows]) / (h if v.ndim == 1 else h.reshape(-1, *[1] * (v.ndim - 1)))
        else:
            for i, k in enumerate(ks):
                tangents.setdefault(k, {})[place] = {key: d[i] for key, d in moves.items()}
    return {k: (([(place, *base[0][place], d) for place, d in sorted(tangents[k].items())], (base[1], {}),
                 (base[2], {})), points_tangent(case, p))
            for k, p, _, _ in items if k in changed and len(tangents.get(k, ())) == len(changed[k])}


def _function_tangents(case, base, items) -> dict:
    """{k: ``moved_tangent``} for the items [(k, p, moved case, h)] whose
    moved case changes only driving functions (as
    kinem.moved_tables._entries): every moved function numbered once after
    the model's in one FunctionTable (function f's numbers are
    data[start[f]:start[f + 1]], kinem/core/src/functions.rs), a
    parameter's tangent the difference of its functions' numbers and
    theirs over h."""
    if not items:
        return {}
    listed = [x for numbered in base[3] for x in numbered[0]]
    where = {}
    for i, x in enumerate(listed):
        where.setdefault(id(x), []).append(i)
    table, picked = FunctionTable(False), []
    for x in listed:
        table.index(x)
    for k, p, moved, h in items:
        swap = swapped(case, moved)
        if swap and swap.keys() <= where.keys():
            picked.append((k, p, h, [(i, table.index(new)) for old, new in swap.items() for i in where[old]]))
    if not picked:
        return {}
    arrays, data0 = table.arrays(), base[1]["data"]
    kind, start, data = arrays["kind"], arrays["start"], arrays["data"]
    if not same(data[:len(data0)], data0):
        return {}
    out = {}
    for k, p, h, numbers in picked:
        d = np.zeros_like(data0)
        if all(kind[i] == kind[j] and start[i + 1] - start[i] == start[j + 1] - start[j] for i, j in numbers):
            for i, j in numbers:
                d[start[i]:start[i + 1]] = (data[start[j]:start[j + 1]] - data0[start[i]:start[i + 1]]) / h
            out[k] = (([], (base[1], {"data": d}), (base[2], {})), points_tangent(case, p))
    return out
