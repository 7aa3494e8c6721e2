"""Many variants of one mechanism solved together (issue 31, "Variants as
lanes"; docs/solver.md, "Variants of one mechanism"):
``kinem.solve(model, parameters={"constraints.A.si.0": values, ...})``.

The model's tables are affine in the case's numbers (kinem.tangents), so
a variant's are the nominal's plus sum_p (v_p - nominal_p) tangent_p: the
tables and their tangents go to the core once (kinem.native.Plan.variants),
which forms each variant's model itself, marches the variants on its thread
pool, each from the nominal's state at the first instant (so that it stays
on the nominal's branch) and converging, failing and stopping on its own,
and writes only the asked columns into one (variants, instants, columns)
array. Values are checked only where a case file needs a positive number
(a link's length, a gear's or a roller's radius: the variant is refused as
bad input), not otherwise validated as a case file is.

A variant the march does not take to the end (an instant that needs
sub-steps, a limit position) is solved again alone by the ordinary
``solve`` of its own case (kinem.tracking sub-steps it), from the same
state: ``resolved`` marks it, ``status`` keeps the march's verdict. A
variant whose det(Phi_q) sign at the first instant differs from the
nominal's is flagged in ``flipped``.

Parameters whose tables are not affine in them (a drawn body's frame that
moves with the parameter, and the drivers that turn with it), and models or
options the march does not take (kinem.march.usable: redundant equations,
Jacobian reuse, an explicit sparse LU), are solved through the merged path
instead (kinem.batch.solve_merged: chunks of merged cases, each variant from
the nominal's first state, a chunk that fails halved until each failing
variant is solved alone); ``merged`` says so.
"""
import time
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from . import native
from .casefile.checks import floats
from .errors import AnalysisError, InputError
from .options import Options
from .result import OUTPUTS, _layout, stages_for

MAX_VARIANTS = 1_000_000
CHUNK = 128   # variants solved as one merged case on the merged path


@dataclass(frozen=True, eq=False)
class Variants:
    """The variants' solutions: ``data`` (variants, instants, columns), NaN
    from a variant's first instant not solved on; per variant ``success``,
    ``status`` (kinem.native.Why: the march's verdict; BAD_INPUT: refused before it), ``failed_at`` (the
    first instant the march did not take; len(t): none), ``resolved`` (solved
    alone after the march stopped), ``flipped`` (det sign at the first
    instant not the nominal's), ``start`` (its state at the first instant)
    and ``messages`` ("" when solved)."""
    parameters: tuple
    values: np.ndarray
    t: np.ndarray
    columns: tuple
    data: np.ndarray
    success: np.ndarray
    status: tuple
    failed_at: np.ndarray
    resolved: np.ndarray
    flipped: np.ndarray
    start: np.ndarray
    messages: tuple
    merged: bool

    def __post_init__(self):
        for v in vars(self).values():   # frozen arrays too
            if isinstance(v, np.ndarray):
                v.flags.writeable = False

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, column) -> np.ndarray:
        """A column over (variants, instants)."""
        if column not in self.columns:
            from .errors import UnknownColumn
            from .result import missing_column

            raise UnknownColumn(missing_column(column, self.columns))
        return self.data[:, :, self.columns.index(column)]

    def __repr__(self) -> str:
        return (f"Variants({len(self)} variants of {', '.join(self.parameters)}, {len(self.t)} instants, "
                f"{len(self.columns)} columns, {int((~self.success).sum())} failed)")


def solve_variants(model, parameters: dict, outputs=OUTPUTS, times=None, options: Options | None = None,
                   trace=False, q0=None, lanes=True, warn=False) -> Variants:
    """The variants {path or [parameters] name: N values} of ``model``
    solved together; ``outputs``: stages (as ``solve``'s) or column names.
    A trace and q0 are refused (every variant starts from the nominal's
    assembly). ``lanes``: the core marches 8 variants at a time as lanes
    where the model suits (False: one by one; the same figures). ``warn``:
    one KinemWarning (kinem.solve's, to its caller) counting the variants
    whose driver turns fast where the case's does not, as kinem.sweep's
    (kinem.parameters.fast_variants; the sweep and tolerance bands warn, or
    not, of their own)."""
    from .batch import solve_merged
    from .march import usable
    from .parameters import resolve, to_paths
    from .solver import _checked_times, solve

    case = model.case
    if trace or q0 is not None:
        raise InputError(f"{case.source}: solve: parameters= with trace or q0; expected neither (every variant "
                         "starts from the nominal's assembly)")
    paths, values = _values(case, parameters, to_paths)
    listed = resolve(case, paths)
    nominal = np.array([p.value for p in listed])
    times = model.times if times is None else _checked_times(times)
    options = model.options if options is None else options
    if not isinstance(options, Options):   # as one solve's (kinem.solver.solve)
        raise InputError(f"solve: options {type(options).__name__}: expected a kinem.Options")
    if options.started is None:   # the time limit counts for the whole batch
        options = replace(options, started=time.perf_counter())
    columns, stages = _asked(model, outputs)
    from .budget import check_held

    check_held(len(values) * len(times) * len(columns), case.source, f"solve: {len(values):,} variants x "
               f"{len(times):,} instants x {len(columns)} columns", "fewer variants, outputs or instants")
    stage_names = OUTPUTS[:stages]
    first = solve(model, outputs=stage_names, times=times[:1], options=replace(options, max_seconds=None))
    if not first.success:
        raise AnalysisError(f"{case.source}: variants: the nominal does not assemble: {first.message}")
    q0 = np.ascontiguousarray(first.q[0])
    refused = _refused(case, listed, values)   # bad input: never solved, said so below (lanes: marched as the nominal)
    if warn:
        _warn_fast(case, listed, values, refused)
    if not all(affine(case, p.path) for p in listed) or not usable(model, False, len(times), options):
        return _merged(model, listed, values, columns, times, q0, options, refused)
    K, N = len(times), len(values)
    marched = values.copy()
    marched[list(refused)] = nominal
    data, start = np.empty((N, K, len(columns))), np.empty((N, model.n))
    end, why, det = np.empty(N, np.int64), np.empty(N, np.uint8), np.empty(N, np.int8)
    names, src, _ = _layout(model, stages)
    at = {c: j for j, c in enumerate(names)}
    base, tangents = _tangents(model, listed)
    dlocal = np.array([d for _, d in tangents], complex).reshape(len(listed), len(model.point_names))
    from .budget import Budget

    # the core's step settings without the rates flag (Plan.variants takes the stages), then the time left
    settings = options.step_settings[False][:4] + (float(Budget(model, options).left()),)
    asked = (stages, src[[at[c] for c in columns]], model.point_cols.astype(np.int64),
             np.ascontiguousarray(model.point_local, complex), dlocal)
    model.plan.variants([(kind, t) for kind, t in base[0]], base[1], base[2],
                        [([d for _, _, d in fams], f[1], o[1]) for (fams, f, o), _ in tangents],
                        asked, np.ascontiguousarray(marched - nominal), np.ascontiguousarray(times, float), q0,
                        settings, (data, start, end, why, det), lanes)
    status = [native.Why(int(w)) for w in why]
    d0 = _det(model, q0, times[0])
    flipped = (det != 0) & (det != d0)
    success, resolved, messages = end == K, np.zeros(N, bool), [""] * N
    again = [k for k in np.flatnonzero(~success) if status[k] not in (native.Why.OUT_OF_TIME, native.Why.INTERRUPTED)
             and k not in refused]
    nominal = dict(zip(model.coordinate_names, q0))
    for k, case_k in zip(again, _cases(case, listed, values[again])):
        done, = solve_merged([case_k], columns, start=nominal, times=times, options=options)   # alone
        if done.data is not None:
            data[k], start[k], success[k], resolved[k] = done.data, done.q, True, True
        else:
            messages[k] = done.why
    for k, why in refused.items():
        data[k], success[k], resolved[k], messages[k] = np.nan, False, False, why
        status[k] = native.Why.BAD_INPUT
    for k in np.flatnonzero(~success):
        messages[k] = messages[k] or f"stopped at t = {times[end[k]]:.6g} (instant {end[k]}): {status[k].message}"
    return Variants(tuple(p.path for p in listed), values, np.array(times, float), columns, data, success,
                    tuple(status), end, resolved, flipped, start, tuple(messages), False)


def _warn_fast(case, listed, values, refused):
    """kinem.sweep's line for the variants whose drivers turn fast where the case's own do not (a rate in
    degrees?): one for all, the first quoted (numbered as ``data``'s first axis), to kinem.solve's caller."""
    import warnings

    from .errors import KinemWarning
    from .parameters import fast_line, fast_variants

    new, first = fast_variants(case, listed, values, refused)
    if first is not None:
        warnings.warn(fast_line("solve", int(new.sum()), len(values), first), KinemWarning, stacklevel=4)


def _refused(case, listed, values) -> dict:
    """{variant: why} for the variants that set a positive length or radius
    (a PositiveKey: a link's length, a gear's or a roller's radius) to zero
    or less, or any number beyond MAX_MAGNITUDE: bad input, as a case file
    with it would be."""
    from .casefile.checks import MAX_MAGNITUDE
    from .casefile.keys import PositiveKey
    from .constraints import REGISTRY
    from .constraints.read import constraint_id

    out = {}
    for j, p in enumerate(listed):
        for k in np.flatnonzero(np.abs(values[:, j]) > MAX_MAGNITUDE):
            out.setdefault(int(k), f"bad input: {case.source}: {p.path} = {values[k, j]:g}: expected a number of "
                                   f"magnitude at most {MAX_MAGNITUDE:g}")
        parts = p.path.split(".")
        c = next((c for c in case.constraints if constraint_id(c) == parts[1]), None) if len(parts) == 3 else None
        if c is None or not any(isinstance(k, PositiveKey) and k.name == parts[2] for k in REGISTRY[c.type].keys):
            continue
        for k in np.flatnonzero(~(values[:, j] > 0)):
            out.setdefault(int(k), f"bad input: {case.source}: {p.path} = {values[k, j]:g}: expected a positive number")
    return out


def affine(case, path) -> bool:
    """Whether the model's tables are affine in the parameter at ``path``
    with the nominal's body frames: not when it moves a drawn body's frame
    (kinem.parameters.frame_tangent), which the merged path then solves."""
    from .parameters import frame_tangent

    return not frame_tangent(case, path)


def _tangents(model, listed):
    """(the model's tables, per parameter their tangent: kinem.tangents.tangents)."""
    from .tangents import tangents

    return model.tables, tangents(model, [p.path for p in listed], model.tables)


def _values(case, parameters, to_paths):
    """(paths, values (N, P)) from {path or name: N numbers}, or InputError."""
    if not isinstance(parameters, dict) or not parameters:
        raise InputError(f"{case.source}: solve: parameters {parameters!r:.80}: expected a dict {{path: values}} "
                         "with one or more design parameter paths (kinem.parameters(case) lists them)")
    paths, columns = to_paths(case, list(parameters), case.source), []
    for key, v in parameters.items():
        a = floats(v)
        if a is not None and a.ndim == 0 and np.isfinite(a):   # one value: say how to give it
            n = next((len(b) for b in map(floats, parameters.values()) if b is not None and b.ndim == 1), 0)
            raise InputError(f"{case.source}: solve: parameter {key!r}: got one number, {float(a)!r}; expected an "
                             + (f"array of {n} numbers, one per variant as the others" if n else
                                f"array of N numbers, one per variant (e.g. [{float(a)!r}])")
                             + f"; for one value, kinem.load(path, parameters={{{key!r}: {float(a)!r}}})")
        if a is None or a.ndim != 1 or not len(a) or not np.isfinite(a).all():
            raise InputError(f"{case.source}: solve: parameter {key!r}: expected a 1-D sequence of one or more "
                             "finite numbers")
        columns.append(a)
    lengths = {len(a) for a in columns}
    if len(lengths) > 1:
        given = ", ".join(f"{k!r}: {len(a)}" for k, a in zip(parameters, columns))
        raise InputError(f"{case.source}: solve: parameters of different lengths ({given}); expected one value "
                         "per variant for every parameter")
    if len(columns[0]) > MAX_VARIANTS:
        raise InputError(f"{case.source}: solve: {len(columns[0])} variants; expected at most {MAX_VARIANTS}")
    return paths, np.ascontiguousarray(np.column_stack(columns))


def _asked(model, outputs):
    """(the asked column names, the stages they need): ``outputs`` stages
    (every column of them) or column names."""
    from .casefile.checks import suggest

    if not isinstance(outputs, (str, Iterable)) or isinstance(outputs, (bytes, bytearray)):
        raise InputError(f"{model.case.source}: solve: outputs {outputs!r:.80}: expected stages (positions, "
                         "velocities, accelerations) or trajectory column names such as B.x")
    outputs = (outputs,) if isinstance(outputs, str) else tuple(outputs)
    if outputs and all(o in OUTPUTS for o in outputs):
        stages = max(OUTPUTS.index(o) for o in outputs) + 1
        return _layout(model, stages)[0], stages
    names = _layout(model, 3)[0]
    for c in outputs:
        if not isinstance(c, str) or c not in names:
            guess = suggest(c, names) if isinstance(c, str) else None
            raise InputError(f"{model.case.source}: solve: outputs: no column {c!r}" + (
                f"; did you mean '{guess}'?" if guess else "; expected stages (positions, velocities, "
                "accelerations) or trajectory column names such as B.x"))
    if not outputs:
        raise InputError(f"{model.case.source}: solve: outputs: none given; expected stages or column names")
    columns = tuple(dict.fromkeys(outputs))
    return columns, OUTPUTS.index(stages_for(columns)[-1]) + 1


def _cases(case, listed, values):
    """Each variant's own Case (kinem.moved.cases_of), or the InputError that refuses it."""
    from .moved import cases_of

    return cases_of(case, [{p.path: float(v) for p, v in zip(listed, row)} for row in values])


def _merged(model, listed, values, columns, times, q0, options, refused) -> Variants:
    """The variants solved as merged cases (kinem.batch.solve_merged), CHUNK
    at a time, each from the nominal's first state q0; those ``refused``
    ({variant: why}: bad input) never solved."""
    from .batch import solve_merged
    from .model import compile

    N, K = len(values), len(times)
    data, start = np.full((N, K, len(columns)), np.nan), np.full((N, model.n), np.nan)
    success, messages = np.zeros(N, bool), [""] * N
    cases = _cases(model.case, listed, values)
    for k, why in refused.items():
        cases[k] = InputError(why)
    nominal = dict(zip(model.coordinate_names, q0))
    for first in range(0, N, CHUNK):
        chunk = range(first, min(N, first + CHUNK))
        for k, done in zip(chunk, solve_merged([cases[k] for k in chunk], columns, start=nominal, times=times,
                                               options=options)):
            messages[k] = refused.get(k) or done.why
            if done.data is not None:
                data[k], start[k], success[k] = done.data, done.q, True
    d0 = _det(model, q0, times[0])
    flipped = np.array([bool(success[k] and d0 and _det(compile(cases[k]), start[k], times[0]) != d0)
                        for k in range(N)], bool)
    status = tuple(native.Why.ACCEPTED if ok else native.Why.BAD_INPUT if isinstance(c, InputError)
                   else native.Why.NOT_CONVERGED for ok, c in zip(success, cases))
    return Variants(tuple(p.path for p in listed), values, np.array(times, float), columns, data, success, status,
                    np.where(success, K, 0), np.zeros(N, bool), flipped, start, tuple(messages), True)


def _det(model, q, t) -> int:
    """det(Phi_q)'s sign at (q, t) (0: the model has no compiled plan)."""
    return model.plan.factor(model.jac_values(q, float(t))).det_sign if model.plan is not None else 0
