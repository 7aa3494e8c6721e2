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
of two (no truncation error, rounding only: relative 1e-16), each the
cheapest exact way (kinem.tangents; the case moved by h from
kinem.moved, its tables' difference from kinem.moved_tables).
``kinem.tangents.tangents(model, paths)`` gives them in full. A model keeps each
parameter's tangent, Parameter and derivatives' names, and the core's
set-up for a list of parameters (Plan.sensitivity_setup), for its later
calls (``_KEPT``: per model a ``_Kept``, in it per list of paths a
``_Call``), so a warm call builds none of them again.

At an instant where Phi_q is singular (its pivot ratio below the solver's
floor, kinem.options.singular_pivot) the derivatives are infinite: they are
reported as inf, flagged in ``singular`` and named in ``message``.
"""
import math
import time
import weakref
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from . import native
from .casefile.checks import texts
from .errors import AnalysisError, InputError, KinemError
from .options import Options, singular_pivot
from .parameters import frame_tangent, resolve
from .result import OUTPUTS, Trajectory, _layout, frozen, stacked
from .branches import pins, violation
from .budget import Budget, check_held
from .march import banded, usable
from .solver import _checked_model, _checked_times, check_square, solve
from .tangents import tangent_parts


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


def differenced(model, p, step: float) -> tuple:
    """The moved models that central differences check p's exact
    sensitivity with (kinem compare --sensitivity, the report's design
    section): (h, {s: model's case at p + s h, compiled, for s = 1, -1, 2,
    -2}, None), h = step times p's scale (max(|p|, L) for a length, max(|p|,
    1) else); or (h, None, what is not a valid case) where a moved value is
    refused (a length or radius below 2h: no differences, not the user's
    input). p: a kinem.parameters.Parameter of model's case."""
    from .model import compile
    from .parameters import apply

    scale = max(abs(p.value), model.length) if p.unit == model.case.length_unit else max(abs(p.value), 1.0)
    h = step * scale
    moved = {}
    for s in (1, -1, 2, -2):
        try:
            moved[s] = compile(apply(model.case, {p.path: p.value + s * h}))
        except InputError as e:
            return h, None, f"p {'+-'[s < 0]} {abs(s) if abs(s) > 1 else ''}h = {p.value + s * h:.6g} is not a " \
                            f"valid case ({e.summary()})"
    return h, moved, None


def sensitivity(model, parameters, outputs=OUTPUTS, times=None, options: Options | None = None) -> Sensitivity:
    """Exact d/dp of every output column at every output instant, for each
    design parameter path in ``parameters`` (a path or a list of paths).
    Raises InputError for an unknown path, AnalysisError when the nominal
    solve fails."""
    _checked_model(model, "sensitivity")
    case = model.case
    options = model.options if options is None else options
    if isinstance(options, Options) and options.max_seconds is not None and options.started is None:
        options = replace(options, started=time.perf_counter())   # the time limit holds for the whole call
    paths = texts(parameters)
    if paths is None:
        raise InputError(f"{case.source}: sensitivity: parameters {parameters!r:.80}: expected a parameter path "
                         "or a list of parameter paths (kinem.parameters(case) lists them)")
    if not paths:
        raise InputError(f"{case.source}: sensitivity: no parameters; expected one or more parameter paths")
    kept = _kept(model)
    try:
        call = kept.calls[tuple(paths)]   # a warm call: resolved and checked before (the model does not change)
    except KeyError:
        listed = _resolved(model, paths)
        if model.m != model.n:
            raise KinemError(f"{case.source}: sensitivities need as many equations as coordinates "
                             f"({model.m} equations, {model.n} coordinates: redundant constraints)") from None
        if model.plan is None:
            raise KinemError(f"{case.source}: sensitivities need the compiled march's layout, which this model "
                             "has not") from None
        call = kept.calls[tuple(paths)] = kept.call(model, listed)
    plan, listed = model.plan, call.listed
    # the fused pass's (three levels) columns and the derivatives' names made before its march, as
    # solve's trajectory is (Python's caches are cold after a long core march)
    named = call.named(model, 3)
    K = len(model.times) if times is None else np.size(times)
    check_held(K * len(named[2]), case.source, f"sensitivity: {K:,} instants x {len(named[0])} columns x "
               f"{len(listed)} parameters", "fewer instants (--steps) or parameters")
    fused = _fused(model, call, outputs, times, options, named)
    if fused is None:   # the march does not take the model or every instant: solve, then the separate pass
        result = solve(model, outputs, times, options=options)
        if not result.success:
            raise AnalysisError(f"{case.source}: the nominal solve failed: {result.message}")
        X = [np.ascontiguousarray(x) for x in (result.q, result.qd, result.qdd) if x is not None]
        traj, named = result.trajectory, call.named(model, len(X))
        data, ratio = plan.sensitivity_kept(call.setup(model, len(X)), np.ascontiguousarray(traj.t), X)
        least = ratio.min() if len(ratio) else np.inf   # (NaN where a ratio is)
        derivatives, singular = Trajectory(traj.t, named[2], None, named[3], make=lambda: data), None
    else:
        traj, derivatives, data, ratio, least, singular = fused
    t, columns = traj.t, named[0]
    width = len(columns)
    for k, p in enumerate(listed if model.derived_frames else ()):   # no frame moves otherwise
        _derived_frames(case, p.path, columns, data[:, k * width:(k + 1) * width], traj)
    floor = singular_pivot(options.tolerance)
    message = "exact at every instant"
    if least >= floor:   # regular (a NaN ratio is singular: the least is NaN then)
        singular = np.zeros(len(ratio), bool) if singular is None else singular
    else:
        singular = ~(ratio >= floor)
        data[singular] = np.inf
        at = ", ".join(f"{x:.6g}" for x in t[singular][:5]) + (" ..." if singular.sum() > 5 else "")
        message = (f"Phi_q singular (pivot ratio below {floor:.2g}) at {int(singular.sum())} instant(s), t = {at}: "
                   "the derivatives there are infinite")
    return frozen(Sensitivity, {"parameters": listed, "trajectory": traj, "derivatives": derivatives,
                                "singular": singular, "conditioning": ratio, "message": message})


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


class _Kept:
    """What a model's calls work out from the model and their paths alone,
    kept for its later calls (as kinem.result._LAYOUTS keeps its columns'
    layout): each path's Parameter, each parameter's tangent of the tables
    with its named points' (read-only arrays), and per list of paths its
    ``_Call``."""
    __slots__ = ("parameters", "parts", "calls")

    def __init__(self):
        self.parameters = {}   # path -> its Parameter
        self.parts = {}        # path -> (its core tangent, its named points' dlocal)
        self.calls = {}        # a tuple of paths, as asked or as listed -> its _Call

    def call(self, model, listed) -> "_Call":
        """The _Call of the parameters ``listed`` (kinem.parameters.Parameter)."""
        key = tuple(p.path for p in listed)
        own = self.calls.get(key)
        if own is None:
            own = self.calls[key] = _Call(listed, _tangents(model, self.parts, listed))
        return own


class _Call:
    """One list of parameters' own: their Parameters (``listed``), what the
    core takes beside the instants (``tangents``: tangent_inputs'), and per
    number of levels, made at its first use, the derivatives' names
    (``named``) and the core's set-up (``setup``)."""
    __slots__ = ("listed", "tangents", "_named", "_setups")

    def __init__(self, listed, tangents):
        self.listed, self.tangents, self._named, self._setups = listed, tangents, {}, {}

    def named(self, model, levels) -> tuple:
        """(columns, column index, the derivatives' names, their _Places) of
        the trajectory's first ``levels``: ``d(COLUMN)/d(PATH)`` for every
        column and each parameter in turn."""
        own = self._named.get(levels)
        if own is None:
            columns, _, column = _layout(model, levels)
            paths = [p.path for p in self.listed]
            names = tuple(f"d({c})/d({p})" for p in paths for c in columns)
            own = self._named[levels] = (columns, column, names, _Places(columns, paths, column))
        return own

    def setup(self, model, levels):
        """The core's set-up for the trajectory's first ``levels`` (the
        fused pass's three, the separate pass's as many as its solve has;
        Plan.sensitivity_setup: the model from its tables, the parameters'
        seeded models, the probes), made once per plan (Plan.march_sensitivity,
        Plan.sensitivity_kept refuse another plan's)."""
        own = self._setups.get(levels)
        if own is None or own[0] is not model.plan:
            tables, core, pattern, (pc, local, dlocal) = self.tangents
            src = _layout(model, levels)[1]
            own = self._setups[levels] = (model.plan, model.plan.sensitivity_setup(tables, core, pattern,
                                                                                    (src, pc, local, dlocal)))
        return own[1]


_KEPT = weakref.WeakKeyDictionary()   # model -> its _Kept


def _kept(model) -> _Kept:
    kept = _KEPT.get(model)
    if kept is None:
        kept = _KEPT[model] = _Kept()
    return kept


def _resolved(model, paths) -> tuple:
    """kinem.parameters.resolve(model.case, paths), each path's Parameter
    found once per model."""
    known = _kept(model).parameters
    paths = list(dict.fromkeys(paths))
    try:
        return tuple([known[p] for p in paths])
    except (KeyError, TypeError):   # a path not resolved yet (or not a string: resolve words the error)
        pass
    listed = resolve(model.case, paths)
    known.update((p.path, p) for p in listed)
    return listed


def tangent_inputs(model, listed) -> tuple:
    """What the core's sensitivities take beside the instants: (the model's
    tables, each parameter's tangents, the Jacobian's pattern (rows, cols),
    the named points' columns, local coordinates and tangents), kept per
    model and list of parameters (a warm call builds nothing)."""
    return _kept(model).call(model, listed).tangents


def _tangents(model, parts, listed) -> tuple:
    """tangent_inputs' tuple, each parameter's tangent built once per model
    (``tangent_parts``; kept in ``parts``, its arrays read-only) and taken
    as it is by later lists that hold it."""
    base = model.tables
    missing = [p for p in dict.fromkeys(listed) if p.path not in parts]
    for p, ((families, functions, outlines), dlocal) in zip(missing, tangent_parts(model, missing) if missing else ()):
        core = ([(k, d) for k, _, _, d in families], functions[1], outlines[1])
        for table in [d for _, d in core[0]] + [core[1], core[2]]:
            for v in table.values():
                v.flags.writeable = False
        parts[p.path] = core, dlocal
    core = [parts[p.path][0] for p in listed]
    dlocal = np.array([parts[p.path][1] for p in listed], complex).reshape(len(listed), len(model.point_names))
    pattern = (np.asarray(model.jac_rows, np.int64), np.asarray(model.jac_cols, np.int64))
    points = np.asarray(model.point_cols, np.int64)
    for a, own in ((dlocal, None), (points, model.point_cols), (pattern[0], model.jac_rows),
                   (pattern[1], model.jac_cols)):
        if a is not own:   # (the model's own arrays stay as they are)
            a.flags.writeable = False
    return base[:3], core, pattern, (points, model.point_local, dlocal)


def _instant_inputs(model, tangents, result) -> tuple:
    """Plan.sensitivity's arguments from ``tangent_inputs`` and the nominal solve."""
    tables, core, (rows, cols), (pc, local, dlocal) = tangents
    X = [np.ascontiguousarray(x) for x in (result.q, result.qd, result.qdd) if x is not None]
    return (tables, core, np.ascontiguousarray(result.trajectory.t), X, rows, cols, _layout(model, len(X))[1],
            pc, local, dlocal)


def _fused(model, call, outputs, times, options, named):
    """(trajectory, derivatives, data, ratio, the least ratio, no instant
    singular): the march and the sensitivities of every instant from its
    own factorisation (Plan.march_sensitivity), for every output (the
    default) when the march takes the model (kinem.march) and every
    instant, its trajectory then solve's to the bit; None otherwise (the
    caller solves, then runs Plan.sensitivity). ``named``: ``_Call.named``'s of
    three levels; the derivatives' Trajectory reads ``data`` at its first
    use (made read-only then: the caller may still write it)."""
    options = model.options if options is None else options
    if not (type(outputs) is tuple and outputs == OUTPUTS) or not isinstance(options, Options):
        return None
    times = model.times if times is None else _checked_times(times)
    nt = len(times)
    if not usable(model, False, nt, options) or (model.blocks.count > 1 and not banded(model)):
        return None
    check_square(model)
    st = native.MarchState(model.q0)   # the estimates to assemble from, as solve's
    core, src = call.tangents[1], _layout(model, 3)[1]
    # the march's states and the derivatives in one block: glibc's malloc serves the next call's from
    # the heap this one frees, where two blocks could come fresh from the system at every call (in a
    # process holding other large arrays: about 50 page faults a call for the slider-crank's 501
    # instants, a fifth of its time; docs/sensitivity-cost.md "Cost: the call's Python part, session 21")
    size = 3 * nt * model.n
    block = np.empty(size + nt * len(core) * len(src))
    X, data = block[:size].reshape(3, nt, model.n), block[size:].reshape(nt, len(core) * len(src))
    figures, ints, ratio = np.zeros((2, nt)), np.zeros(nt + 2, np.int64), np.empty(nt)
    times = np.ascontiguousarray(times, float)
    left = math.inf if options.max_seconds is None else float(Budget(model, options).left())   # the call's time left
    settings = options.step_settings[True] + (left,)
    # made before the march, as solve's (Python's caches are cold after it); X never leaves: the
    # trajectory's columns are made from it (its _make), not views of it
    traj, pinned = stacked(model, times, X), pins(model)
    # (Trajectory(traj.t, names, None, places, make=...) without its __init__'s setting attribute by attribute;
    # traj.t is read-only already: kinem.result.stacked)
    derivatives = frozen(Trajectory, {"t": traj.t, "columns": named[2], "_index": named[3], "_data": None,
                                      "_make": lambda: data})
    singular = np.zeros(nt, bool)
    end, _, least = model.plan.march_sensitivity(times, st, settings, X, figures, ints,
                                                 call.setup(model, 3), data, ratio)
    if end < nt or pinned and violation(model, X[0, 0]):
        return None
    return traj, derivatives, data, ratio, least, singular


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
