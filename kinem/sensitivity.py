"""Exact design sensitivities of a whole trajectory (docs/design.md,
"Design sensitivities"): d/dp of every output column (bodies, named points,
artificial coordinates; positions, velocities, accelerations) at every
output instant, for design parameters p named by their paths
(kinem.parameters).

The core differentiates the kinematic equations directly (Eqs. S1-S3, S6,
kinem/core/src/sensitivity.rs), in the march's own pass (``_fused``:
each accepted instant's sensitivities from the factorisation of Phi_q its
rates use; else a solve, then Plan.sensitivity factorising again),
evaluating the families' own kernels over dual numbers, four or eight
parameters per evaluation; the named points' columns come from the same
kernel as the trajectory's (kinem/core/src/columns.rs), in the same call.
What it needs from here is each parameter's tangent of the model's tables
(``core_inputs``): the tables are affine in the case's numbers (unit
directions and the roller's squared radius are taken in the core), so the
tangent is their exact linear part, (B(x + h e_p) - B(x)) / h with h a power
of two (no truncation error, rounding only: relative 1e-16), each family
built once for all the parameters that move it where it can be
(``_stacked``), a spline outline's values from one spline (``_spline_tangents``).
``tangents(model, paths)`` gives them in full. A model keeps each
parameter's tangent, Parameter and derivatives' names, and the core's
set-up for a list of parameters (Plan.sensitivity_setup), for its later
calls (``_KEPT``, as kinem.result keeps its columns' layout), so a warm
call builds none of them again.

At an instant where Phi_q is singular (its pivot ratio below the solver's
floor, kinem.options.singular_pivot) the derivatives are infinite: they are
reported as inf, flagged in ``singular`` and named in ``message``.
"""
import math
import time
import weakref
from collections.abc import Mapping
from dataclasses import dataclass, is_dataclass, replace

import numpy as np

from . import native
from .errors import AnalysisError, InputError, KinemError
from .constraints import REGISTRY
from .constraints.read import constraint_id
from .functions import FunctionTable, Harmonic, Poly
from .model import _Context, families_of, separate_tables
from .outline import Outline, OutlineTable
from .options import Options, singular_pivot
from .parameters import apply_many, driver_tangent, frame_tangent, local_tangent, resolve
from .result import OUTPUTS, Trajectory, _layout, trajectory
from .branches import violation
from .budget import Budget
from .march import banded, usable
from .solver import _checked_times, check_square, solve
from .spec import frozen_map


@dataclass(frozen=True, eq=False)
class Sensitivity:
    """d(column)/d(parameter) at every output instant: ``derivatives`` has
    the columns ``d(COLUMN)/d(PARAMETER)`` (every trajectory column for the
    first parameter, then the second, ...); ``sens["d(B.x)/d(points.A.at.0)"]``.
    ``singular`` flags the instants where Phi_q is singular (derivatives
    inf), ``conditioning`` is Phi_q's pivot ratio there."""
    parameters: tuple               # kinem.parameters.Parameter, in the order asked
    trajectory: Trajectory          # the nominal solution
    derivatives: Trajectory
    singular: np.ndarray
    conditioning: np.ndarray
    message: str

    def __getitem__(self, name: str) -> np.ndarray:
        return self.derivatives[name]

    def __contains__(self, name) -> bool:
        return name in self.derivatives

    def of(self, column: str, parameter: str) -> np.ndarray:
        return self.derivatives[name(column, parameter)]

    def to_pandas(self):
        return self.derivatives.to_pandas()

    def __repr__(self) -> str:
        return (f"Sensitivity({len(self.parameters)} parameters, {self.derivatives!r}, "
                f"{int(self.singular.sum())} singular instants)")


def name(column: str, parameter: str) -> str:
    return f"d({column})/d({parameter})"


def sensitivity(model, parameters, outputs=OUTPUTS, times=None, options: Options | None = None) -> Sensitivity:
    """Exact d/dp of every output column at every output instant, for each
    design parameter path in ``parameters`` (a path or a list of paths).
    Raises InputError for an unknown path, AnalysisError when the nominal
    solve fails."""
    case = model.case
    options = model.options if options is None else options
    if isinstance(options, Options) and options.max_seconds is not None and options.started is None:
        options = replace(options, started=time.perf_counter())   # the time limit holds for the whole call
    paths = [parameters] if isinstance(parameters, str) else list(parameters)
    if not paths:
        raise InputError(f"{case.source}: sensitivity: no parameters; expected one or more parameter paths")
    listed = _resolved(model, paths)
    if model.m != model.n:
        raise KinemError(f"{case.source}: sensitivities need as many equations as coordinates "
                         f"({model.m} equations, {model.n} coordinates: redundant constraints)")
    plan = model.plan
    if plan is None:
        raise KinemError(f"{case.source}: sensitivities need the compiled march's layout, which this model has not")
    tangents = tangent_inputs(model, listed)
    fused = _fused(model, tangents, outputs, times, options)
    if fused is None:   # the march does not take the model or every instant: solve, then the separate pass
        result = solve(model, outputs, times, options=options)
        if not result.success:
            raise AnalysisError(f"{case.source}: the nominal solve failed: {result.message}")
        X = [np.ascontiguousarray(x) for x in (result.q, result.qd, result.qdd) if x is not None]
        traj, levels = result.trajectory, len(X)
        setup = _setup(model, tangents, _layout(model, levels)[1])
        data, ratio = plan.sensitivity_kept(setup, np.ascontiguousarray(traj.t), X)
    else:
        traj, data, ratio, levels = fused
    t = traj.t
    columns, _, column = _layout(model, levels)
    width = len(columns)
    for k, p in enumerate(listed if any(b.derived for b in case.bodies) else ()):   # no frame moves otherwise
        _derived_frames(case, p.path, columns, data[:, k * width:(k + 1) * width], traj)
    floor = singular_pivot(options.tolerance)
    singular = ~(ratio >= floor)
    message = "exact at every instant"
    if singular.any():
        data[singular] = np.inf
        at = ", ".join(f"{x:.6g}" for x in t[singular][:5]) + (" ..." if singular.sum() > 5 else "")
        message = (f"Phi_q singular (pivot ratio below {floor:.2g}) at {int(singular.sum())} instant(s), t = {at}: "
                   "the derivatives there are infinite")
    names = _names(model, columns, listed)
    derivatives = Trajectory(t.copy(), names, data, _Places(columns, [p.path for p in listed], column))
    return Sensitivity(listed, traj, derivatives, singular, ratio, message)


class _Places(Mapping):
    """The derivatives' column index (Trajectory._index): ``d(C)/d(P)`` ->
    its place, k * width + j for parameter k and column j, from the
    columns' and the parameters' own places (not a dict of every name)."""

    def __init__(self, columns, paths, column=None):
        self.columns, self.paths = columns, paths
        self.column = {c: j for j, c in enumerate(columns)} if column is None else column   # (read only)
        self.parameter = {p: k for k, p in enumerate(paths)}

    def __getitem__(self, name):
        if isinstance(name, str) and name.startswith("d(") and name.endswith(")"):
            at = name.find(")/d(")
            while at >= 0:   # a column or a path holding ")/d(" itself: every split tried
                j, k = self.column.get(name[2:at]), self.parameter.get(name[at + 4:-1])
                if j is not None and k is not None:
                    return k * len(self.columns) + j
                at = name.find(")/d(", at + 1)
        raise KeyError(name)

    def __contains__(self, name) -> bool:
        try:
            self[name]
        except KeyError:
            return False
        return True

    def __iter__(self):
        return (f"d({c})/d({p})" for p in self.paths for c in self.columns)

    def __len__(self) -> int:
        return len(self.columns) * len(self.paths)


def core_inputs(model, listed, result) -> tuple:
    """The arguments of the core's Plan.sensitivity for the parameters
    ``listed`` (kinem.parameters.Parameter) at the instants of ``result``
    (the nominal solve): the model's tables, each parameter's tables'
    tangents (only the families it moves), t, the stages, the Jacobian's
    pattern, the trajectory's column sources and the named points' columns,
    local coordinates and tangents. benchmarks/sensitivity_bench.py times
    the core's part with them."""
    return _instant_inputs(model, tangent_inputs(model, listed), result)


# model -> ({path: its Parameter}, {path: (its core tangent, its points' dlocal)}, {(path,
# columns): its derivatives' names}, {paths: tangent_inputs' tuple}, {(id(that tuple),
# its levels): (it, the plan, the core's set-up for it: Plan.sensitivity_setup)}): what a call
# works out from the model and a path alone, kept for the model's next calls (as
# kinem.result._LAYOUTS keeps its columns), read-only
_KEPT = weakref.WeakKeyDictionary()


def _kept(model) -> tuple:
    kept = _KEPT.get(model)
    if kept is None:
        kept = _KEPT[model] = ({}, {}, {}, {}, {})
    return kept


def _names(model, columns, listed) -> tuple:
    """The derivatives' column names, ``d(COLUMN)/d(PATH)`` for every
    column and each parameter in turn, each parameter's made once per
    model and its columns."""
    kept = _kept(model)[2]
    out = []
    for p in listed:
        own = kept.get((p.path, columns))
        if own is None:
            end = f")/d({p.path})"
            own = kept[p.path, columns] = tuple(f"d({c}{end}" for c in columns)
        out += own
    return tuple(out)


def _resolved(model, paths) -> tuple:
    """kinem.parameters.resolve(model.case, paths), each path's Parameter
    found once per model."""
    known = _kept(model)[0]
    paths = list(dict.fromkeys(paths))
    if all(p in known for p in paths):
        return tuple(known[p] for p in paths)
    listed = resolve(model.case, paths)
    known.update((p.path, p) for p in listed)
    return listed


def tangent_inputs(model, listed) -> tuple:
    """What the core's sensitivities take beside the instants: (the model's
    tables, each parameter's tangents, the Jacobian's pattern (rows, cols),
    the named points' columns, local coordinates and tangents). Each
    parameter's tangent is built once per model (``_parts``; the arrays
    read-only) and taken as it is by its later calls; the whole tuple is
    kept per model and list of paths (a warm call builds nothing)."""
    paths = tuple(p.path for p in listed)
    whole = _kept(model)[3]
    if paths in whole:
        return whole[paths]
    base, kept = model.tables, _kept(model)[1]
    missing = [p for p in dict.fromkeys(listed) if p.path not in kept]
    for p, ((families, functions, outlines), dlocal) in zip(missing, _parts(model, missing) if missing else ()):
        core = ([(k, d) for k, _, _, d in families], functions[1], outlines[1])
        for table in [d for _, d in core[0]] + [core[1], core[2]]:
            for v in table.values():
                v.flags.writeable = False
        kept[p.path] = core, dlocal
    core = [kept[p.path][0] for p in listed]
    dlocal = np.array([kept[p.path][1] for p in listed], complex).reshape(len(listed), len(model.point_names))
    pattern = (np.asarray(model.jac_rows, np.int64), np.asarray(model.jac_cols, np.int64))
    points = np.asarray(model.point_cols, np.int64)
    for a, own in ((dlocal, None), (points, model.point_cols), (pattern[0], model.jac_rows),
                   (pattern[1], model.jac_cols)):
        if a is not own:   # (the model's own arrays stay as they are)
            a.flags.writeable = False
    out = whole[paths] = (base[:3], core, pattern, (points, model.point_local, dlocal))
    return out


def _parts(model, listed) -> list:
    """Per parameter of ``listed`` its tangent as ``_moved_tangent`` gives
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
    items = [(k, listed[k], moved, h) for k, (moved, h) in zip(rest, _moved(case, [listed[k] for k in rest]))]
    parts.update(_stacked(case, model.length, base, items))
    parts.update(_function_tangents(case, base, [i for i in items if i[0] not in parts]))
    for k, p, moved, h in items:
        if k not in parts:
            parts[k] = _moved_tangent(case, model.length, base, p, moved, h)
    return [parts[k] for k in range(len(listed))]


def _instant_inputs(model, tangents, result) -> tuple:
    """Plan.sensitivity's arguments from ``tangent_inputs`` and the nominal solve."""
    tables, core, (rows, cols), (pc, local, dlocal) = tangents
    X = [np.ascontiguousarray(x) for x in (result.q, result.qd, result.qdd) if x is not None]
    return (tables, core, np.ascontiguousarray(result.trajectory.t), X, rows, cols, _layout(model, len(X))[1],
            pc, local, dlocal)


def _fused(model, tangents, outputs, times, options):
    """(trajectory, data, ratio, levels): the march and the sensitivities of
    every instant from its own factorisation (Plan.march_sensitivity), for
    every output (the default) when the march takes the model (kinem.march)
    and every instant, its trajectory then solve's to the bit; None
    otherwise (the caller solves, then runs Plan.sensitivity)."""
    options = model.options if options is None else options
    if not (type(outputs) is tuple and outputs == OUTPUTS) or not isinstance(options, Options):
        return None
    times = model.times if times is None else _checked_times(times)
    nt = len(times)
    if not usable(model, False, nt, options) or (model.blocks.count > 1 and not banded(model)):
        return None
    check_square(model)
    st = native.MarchState(model.q0)   # the estimates to assemble from, as solve's
    core, src = tangents[1], _layout(model, 3)[1]
    X, figures, ints = np.empty((3, nt, model.n)), np.zeros((2, nt)), np.zeros(nt + 2, np.int64)
    data, ratio = np.empty((nt, len(core) * len(src))), np.empty(nt)
    times = np.ascontiguousarray(times, float)
    settings = options.step_settings[True] + (float(Budget(model, options).left()),)
    end, _ = model.plan.march_sensitivity(times, st, settings, X, figures, ints, _setup(model, tangents, src),
                                          data, ratio)
    if end < nt or violation(model, X[0, 0]):
        return None
    X.flags.writeable = False   # (its views, made after, are read-only too: as solve's)
    return trajectory(model, times, X[0], X[1], X[2]), data, ratio, 3


def _setup(model, tangents, src):
    """The core's set-up for ``tangents`` (tangent_inputs') and the columns
    ``src`` of the trajectory's first levels (kinem.result._layout's: the
    fused pass's three, the separate pass's as many as its solve has;
    Plan.sensitivity_setup: the model from its tables, the parameters'
    seeded models, the probes), made once per model, tangents and levels
    and kept for its later calls (Plan.march_sensitivity,
    Plan.sensitivity_kept)."""
    kept, plan = _kept(model)[4], model.plan
    key = (id(tangents), len(src))
    own = kept.get(key)
    if own is None or own[0] is not tangents or own[1] is not plan:
        tables, core, pattern, (pc, local, dlocal) = tangents
        own = kept[key] = (tangents, plan, plan.sensitivity_setup(tables, core, pattern, (src, pc, local, dlocal)))
    return own[2]


def _derived_frames(case, path, columns, block, traj):
    """The columns of a body whose frame derives from drawn points that p
    moves (kinem.parameters.frame_tangent): the tangent, taken with the
    frames held, plus the frame's own move, r' = r + A(phi) s0 and
    phi' = phi + alpha, differentiated at s0 = 0, alpha = 0 (with their
    velocities and accelerations): the columns of the moved drawing."""
    moved = frame_tangent(case, path)
    index = {c: k for k, c in enumerate(columns)} if moved else {}
    for body, (ds0, dalpha) in moved.items():
        turn = np.exp(1j * traj[f"{body}.phi"]) * ds0
        terms = {"x": turn.real, "y": turn.imag, "phi": dalpha}
        if f"{body}.omega" in traj:
            w = traj[f"{body}.omega"]
            terms.update(vx=(1j * w * turn).real, vy=(1j * w * turn).imag)
            if f"{body}.alpha" in traj:
                a = (1j * traj[f"{body}.alpha"] - w ** 2) * turn
                terms.update(ax=a.real, ay=a.imag)
        for key, v in terms.items():
            if f"{body}.{key}" in index:
                block[:, index[f"{body}.{key}"]] += v


def _tables(case, length):
    """The tables of ``case`` as the Model keeps them (kinem.model.separate_tables)."""
    return separate_tables(families_of(case, length)[0])


def _moved(case, listed):
    """(the case with p moved by h, h) for each parameter p: h a power of
    two near |p| / 2 (-h where +h is not a valid case), each case set in
    place where it can be, else validated (``cases_of``)."""
    if not listed:
        return []
    steps = [_step(p.value) for p in listed]
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
            out[k] = (apply_many(case, [design(p, -h, turned[k])], pinned=True)[0], -h)
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
    built = iter(apply_many(case, slow, pinned=pinned) if slow else ())
    return [m if m is not None else next(built) for m in moved]


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


def _tangent(case, length, base, p, moved, step):
    """The tangent of the tables along parameter p (their linear part: the
    tables are affine in the case's numbers; ``moved``: the case with p
    moved by ``step``) and of the named points' local coordinates:
    ((families [(kind, table, tangent)], (functions, tangent), (outlines,
    tangent)), dlocal), every family and every column (zero where p does
    not move it)."""
    return _full(base, _moved_tangent(case, length, base, p, moved, step))


def _full(base, part):
    """A ``_moved_tangent`` in ``_tangent``'s format: every family, function and outline column, zero where unmoved."""
    (families, functions, outlines), dlocal = part
    tangent = {k: d for k, _, _, d in families}
    return ([(kind, t0, {**_zero(t0), **tangent.get(k, {})}) for k, (kind, t0) in enumerate(base[0])],
            (functions[0], functions[1] or _zero(functions[0])), (outlines[0], outlines[1] or _zero(outlines[0]))), dlocal


def tangents(model, paths, base=None) -> list:
    """Per design parameter path, the tangent of the model's tables along it
    in the format of ``_tangent`` (the tables are affine in the case's
    numbers: a design's tables are the nominal ones plus the sum over p of
    (value - nominal) x tangent_p), built as the sensitivities' (``_parts``);
    ``base``: the model's tables (Model.tables), as the tangents take them."""
    return [_full(base or model.tables, part) for part in _parts(model, resolve(model.case, list(paths)))]


def _moved_tangent(case, length, base, p, moved, step):
    """``_tangent`` as the core takes it: only the families p moves, each
    with its place, ((families [(place, kind, table, tangent)], (functions,
    tangent), (outlines, tangent)), dlocal); an unmoved function or outline
    table has the tangent {}."""
    entries = _entries(case, moved, base)
    if entries is not None:   # only numbers inside functions or outlines: no family's table moves
        (functions, df), (outlines, do) = entries
        return ([], (base[1], _difference(base[1], functions, step, p.path) if df else {}),
                (base[2], _difference(base[2], outlines, step, p.path) if do else {})), _dlocal(case, p)
    reached = _reached(case, moved, length, base)
    if reached is None:
        tables, functions, outlines, _ = _tables(moved, length)
        families = [(k, kind, t0, _difference(t0, t1, step, p.path))
                    for k, ((kind, t0), (_, t1)) in enumerate(zip(base[0], tables))]
        df, do = _difference(base[1], functions, step, p.path), _difference(base[2], outlines, step, p.path)
        if not any(v.any() for v in (*df.values(), *do.values())):   # no function or outline moved
            families = [f for f in families if any(v.any() for v in f[3].values())]
        return (families, (base[1], df), (base[2], do)), _dlocal(case, p)
    tables, functions, outlines = reached   # only the families of the constraints moved in place (_replaced)
    families = [(k, *base[0][k], _linear(base[0][k][1], tables[k], step)) for k in sorted(tables)]
    return (families, (base[1], {} if functions is base[1] else _difference(base[1], functions, step, p.path)),
            (base[2], {} if outlines is base[2] else _difference(base[2], outlines, step, p.path))), _dlocal(case, p)


def _spline_tangents(case, listed, base) -> dict:
    """{k: ``_moved_tangent``} for the parameters listed[k] that are a value
    s_j of a spline outline (``constraints.C.KEY.spline.s.j``; not the
    last of a periodic one, which the first sets): the outline's pieces are
    linear in s, so the tangent is the pieces of the spline through the
    unit vector e_j (e_0 + e_last for a periodic outline's first) in that
    outline's coefficients (OutlineTable's layout: pieces first[o] ..
    last[o], 4 coefficients each), every j of one outline from one
    CubicSpline. No family's table moves (as ``_entries``)."""
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
        zero = zero or _zero(base[2])   # the unmoved columns' zeros, shared (read only)
        for col, (k, _) in enumerate(ks):
            tangent = {**zero, "coef": np.zeros_like(zero["coef"])}
            for place in places:
                tangent["coef"][4 * first[place]:4 * (last[place] + 1)] = c[:, :, col].T.ravel()
            out[k] = ([], (base[1], {}), (base[2], tangent)), _dlocal(case, listed[k])
    return out


def _direct(model, items) -> dict:
    """{k: ``_moved_tangent``} for the parameters of items [(k, p)] whose
    tangent is one number of the function or outline tables, taken as it
    is (S5's difference is a unit there, nothing else moves): a ground's
    ``value.k`` or an absolute constraint's ``value`` (the constant
    function Poly((value,)) its row numbered), a driving function's
    ``poly.k`` or ``harmonic.NAME`` (the function the constraint holds, at
    every place the table numbers it: ((v + h) - v) / h with _moved's h,
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
            out[k] = ([], (functions, {"data": d}), (outlines, {})), _dlocal(case, p)
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
            h = _step(p.value)
            d = np.zeros_like(data)
            d[[start[i] + j for i in places]] = ((p.value + h) - p.value) / h   # the moved function's difference
            out[k] = ([], (functions, {"data": d}), (outlines, {})), _dlocal(case, p)
            continue
        places = [i for i, x in enumerate(numbered) if x is o]
        if not isinstance(o, Outline) or not places:
            continue
        tangent = _zero(outlines)
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
        out[k] = ([], (functions, {}), (outlines, tangent)), _dlocal(case, p)
    return out


def _landed(model, items) -> dict:
    """{k: ``_moved_tangent``} for the parameters of items [(k, p)] that are
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
    _moved's h (``_step``), the family's other columns left out (zero):
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
        h = _step(p.value)
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


def _step(value) -> float:
    """The step _moved takes p by: a power of two near |p| / 2 (0.5 at 0),
    2^(floor(log2 |p|) - 1) with the exponent read exactly (math.frexp)."""
    return math.ldexp(1.0, math.frexp(value)[1] - 2) if value else 0.5


# a harmonic function's numbers in the function table (kinem.functions.FunctionTable.arrays)
_HARMONIC = {"amplitude": 0, "omega": 1, "phase": 2, "offset": 3}


def _stacked(case, length, base, items) -> dict:
    """{k: ``_moved_tangent``} for the parameters of items [(k, p, moved
    case, h)] whose moved case (set in place) changes only constraints of
    families that number no function or outline: each such family built
    once, over its constraints followed by every parameter's changed ones
    (each column then holds the nominal's rows, r per constraint, and after
    them the changed constraints' rows in turn, which the nominal's own
    rows and the changed ones' integer columns, those of the constraints
    they replace, confirm; else it is left to ``_moved_tangent``), a
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
                and _same(table[key][:len(v)], v) for key, v in t0.items()):
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
                if not _same(new, v[nominal_rows]):
                    break
                continue
            moves[key] = np.zeros((len(indices),) + v.shape, v.dtype)
            moves[key][of, nominal_rows] = (new - v[nominal_rows]) / (h if v.ndim == 1 else h.reshape(-1, *[1] * (v.ndim - 1)))
        else:
            for i, k in enumerate(ks):
                tangents.setdefault(k, {})[place] = {key: d[i] for key, d in moves.items()}
    return {k: (([(place, *base[0][place], d) for place, d in sorted(tangents[k].items())], (base[1], {}),
                 (base[2], {})), _dlocal(case, p))
            for k, p, _, _ in items if k in changed and len(tangents.get(k, ())) == len(changed[k])}


def _swap(case, moved):
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


def _function_tangents(case, base, items) -> dict:
    """{k: ``_moved_tangent``} for the items [(k, p, moved case, h)] whose
    moved case changes only driving functions (as ``_entries``): every
    moved function numbered once after the model's in one FunctionTable
    (function f's numbers are data[start[f]:start[f + 1]],
    kinem/core/src/functions.rs), a parameter's tangent the difference of
    its functions' numbers and theirs over h."""
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
        swap = _swap(case, moved)
        if swap and swap.keys() <= where.keys():
            picked.append((k, p, h, [(i, table.index(new)) for old, new in swap.items() for i in where[old]]))
    if not picked:
        return {}
    arrays, data0 = table.arrays(), base[1]["data"]
    kind, start, data = arrays["kind"], arrays["start"], arrays["data"]
    if not _same(data[:len(data0)], data0):
        return {}
    out = {}
    for k, p, h, numbers in picked:
        d = np.zeros_like(data0)
        if all(kind[i] == kind[j] and start[i + 1] - start[i] == start[j + 1] - start[j] for i, j in numbers):
            for i, j in numbers:
                d[start[i]:start[i + 1]] = (data[start[j]:start[j + 1]] - data0[start[i]:start[i + 1]]) / h
            out[k] = (([], (base[1], {"data": d}), (base[2], {})), _dlocal(case, p))
    return out


def _entries(case, moved, base):
    """((functions, moved), (outlines, moved)): the model's function and
    outline tables (``base``, _tables) with the functions and outlines that
    ``moved`` (a case from _replaced) changed in their places, ``moved``
    whether any did (else the table is base's), when moved changes nothing
    but fields of constraints that are functions or outlines (_set_entry):
    the families' tables hold only their numbers, so none of them moves
    (tests/test_sensitivity.py compares with every table rebuilt). None
    otherwise, or when a changed function or outline is not in the tables
    as the constraint holds it."""
    swap = _swap(case, moved)
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
    holding a constraint that ``moved`` (a case from _replaced) changed,
    each built alone, its functions and outlines numbered where the model's
    ``base`` tables (_tables) number them, the others' kept; None when moved
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
                v.dtype.kind in "iu" and not _same(v, table[key]) for key, v in base[0][k][1].items()):
            return None
        out[k] = table
        moved_functions |= tuple(functions.functions[before[0]:]) != kept_functions
        moved_outlines |= tuple(outlines.outlines[before[1]:]) != kept_outlines
    return (out, functions.arrays() if moved_functions else base[1],   # unmoved: the model's own arrays
            outlines.arrays() if moved_outlines else base[2])


def _same(a, b) -> bool:
    """Two integer columns equal (their bytes: the same code built both)."""
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def _linear(a: dict, b: dict, step: float) -> dict:
    """The linear part (b - a) / step of every real and complex column of
    a family whose integer columns ``_reached`` found unmoved."""
    return {key: (b[key] - v) / step for key, v in a.items() if v.dtype.kind not in "iu"}


def _zero(table: dict) -> dict:
    return {key: np.zeros_like(v) for key, v in table.items() if v.dtype.kind not in "iu"}


def _dlocal(case, p):
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
