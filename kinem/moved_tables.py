"""A parameter's tangent from its moved case's tables (kinem.tangents'
general way, S5): (B(x + h e_p) - B(x)) / h, the tables exactly affine in
the case's numbers and h a power of two, so the difference is their linear
part: only the function and outline tables where the moved case changes
only numbers inside them (``_entries``), only the families of the
constraints it changed (``_reached``), else every table rebuilt
(``_tables``, as the Model keeps them); and the named points' local
coordinates' tangent (``points_tangent``).
"""
import numpy as np

from .constraints import REGISTRY
from .errors import KinemError
from .functions import FunctionTable
from .model import _Context, families_of, separate_tables
from .moved import swapped
from .outline import OutlineTable
from .parameters import local_tangent


def _tables(case, length):
    """The tables of ``case`` as the Model keeps them (kinem.model.separate_tables)."""
    return separate_tables(families_of(case, length)[0])


def moved_tangent(case, length, base, p, moved, step):
    """``_tangent`` as the core takes it: only the families p moves, each
    with its place, ((families [(place, kind, table, tangent)], (functions,
    tangent), (outlines, tangent)), dlocal); an unmoved function or outline
    table has the tangent {}."""
    entries = _entries(case, moved, base)
    if entries is not None:   # only numbers inside functions or outlines: no family's table moves
        (functions, df), (outlines, do) = entries
        return ([], (base[1], _difference(base[1], functions, step, p.path) if df else {}),
                (base[2], _difference(base[2], outlines, step, p.path) if do else {})), points_tangent(case, p)
    reached = _reached(case, moved, length, base)
    if reached is None:
        tables, functions, outlines, _ = _tables(moved, length)
        families = [(k, kind, t0, _difference(t0, t1, step, p.path))
                    for k, ((kind, t0), (_, t1)) in enumerate(zip(base[0], tables))]
        df, do = _difference(base[1], functions, step, p.path), _difference(base[2], outlines, step, p.path)
        if not any(v.any() for v in (*df.values(), *do.values())):   # no function or outline moved
            families = [f for f in families if any(v.any() for v in f[3].values())]
        return (families, (base[1], df), (base[2], do)), points_tangent(case, p)
    tables, functions, outlines = reached   # only the families of the constraints moved in place (kinem.moved)
    families = [(k, *base[0][k], _linear(base[0][k][1], tables[k], step)) for k in sorted(tables)]
    return (families, (base[1], {} if functions is base[1] else _difference(base[1], functions, step, p.path)),
            (base[2], {} if outlines is base[2] else _difference(base[2], outlines, step, p.path))), points_tangent(case, p)


def _entries(case, moved, base):
    """((functions, moved), (outlines, moved)): the model's function and
    outline tables (``base``, _tables) with the functions and outlines that
    ``moved`` (a case from kinem.moved._replaced) changed in their places,
    ``moved`` whether any did (else the table is base's), when moved
    changes nothing but fields of constraints that are functions or
    outlines (kinem.moved._set_entry): the families' tables hold only their
    numbers, so none of them moves
    (tests/test_sensitivity.py compares with every table rebuilt). None
    otherwise, or when a changed function or outline is not in the tables
    as the constraint holds it."""
    swap = swapped(case, moved)
    if swap is None:
        return None
    out, found = [], set()
    for k, table in ((0, FunctionTable(False)), (1, OutlineTable(False))):
        listed = [x for numbered in base[3] for x in numbered[k]]
        hit = {id(x) for x in listed} & swap.keys()
        found |= hit
        if hit:
            for x in listed:
                table.index(swap.get(id(x), x))
        out.append((table.arrays() if hit else base[1 + k], bool(hit)))
    return tuple(out) if swap and found == swap.keys() else None


def _reached(case, moved, length, base):
    """({family number: its table}, functions, outlines) of the families
    holding a constraint that ``moved`` (a case from kinem.moved._replaced)
    changed, each built alone, its functions and outlines numbered where the
    model's ``base`` tables (_tables) number them, the others' kept; None when moved
    is not such a case, or a rebuilt family numbers functions, outlines or
    columns otherwise than in ``base``."""
    if len(moved.constraints) != len(case.constraints) or moved.bodies is not case.bodies:
        return None
    groups, changed = {}, set()
    for c0, c1 in zip(case.constraints, moved.constraints):
        family = REGISTRY[c1.type].family
        groups.setdefault(family, []).append(c1)
        if c0 is not c1:
            changed.add(family)
    functions, outlines = FunctionTable(False), OutlineTable(False)
    out, moved_functions, moved_outlines = {}, False, False
    for k, (family, cons) in enumerate(groups.items()):
        kept_functions, kept_outlines = base[3][k]
        if family not in changed:
            for f in kept_functions:
                functions.index(f)
            for o in kept_outlines:
                outlines.index(o)
            continue
        before = len(functions.functions), len(outlines.outlines)
        table = family(cons, _Context(moved, length)).table(functions, outlines)[1]
        if (len(functions.functions) - before[0], len(outlines.outlines) - before[1]) != (
                len(kept_functions), len(kept_outlines)) or any(
                v.dtype.kind in "iu" and not same(v, table[key]) for key, v in base[0][k][1].items()):
            return None
        out[k] = table
        moved_functions |= tuple(functions.functions[before[0]:]) != kept_functions
        moved_outlines |= tuple(outlines.outlines[before[1]:]) != kept_outlines
    return (out, functions.arrays() if moved_functions else base[1],   # unmoved: the model's own arrays
            outlines.arrays() if moved_outlines else base[2])


def same(a, b) -> bool:
    """Two integer columns equal (their bytes: the same code built both)."""
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def _linear(a: dict, b: dict, step: float) -> dict:
    """The linear part (b - a) / step of every real and complex column of
    a family whose integer columns ``_reached`` found unmoved."""
    return {key: (b[key] - v) / step for key, v in a.items() if v.dtype.kind not in "iu"}


def zeros_of(table: dict) -> dict:
    return {key: np.zeros_like(v) for key, v in table.items() if v.dtype.kind not in "iu"}


def points_tangent(case, p):
    """The tangent of the named points' local coordinates along p."""
    dlocal = np.zeros(len(case.points), complex)
    moved = local_tangent(case, p.path) if p.path.startswith(("points.", "parameters.")) else {}
    if moved:
        names = [q.name for q in case.points]
        for point, d in moved.items():
            dlocal[names.index(point)] += d
    return dlocal


def _difference(a: dict, b: dict, step: float, path: str) -> dict:
    """The linear part (b - a) / step of every real and complex column; the
    integer columns (indices, flags) must not move."""
    out = {}
    for key, v in a.items():
        w = b[key]
        if v.dtype.kind in "iu":
            if not np.array_equal(v, w):
                raise KinemError(f"sensitivity: parameter '{path}' changes the model's structure (column {key})")
            continue
        out[key] = np.ascontiguousarray((w - v) / step)
    return out
