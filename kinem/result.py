"""Typed, frozen results: a Trajectory of named columns (time-major) and the
SolveResult that carries it with success, status and message."""
from dataclasses import dataclass, field, fields
from enum import IntEnum
import weakref

import numpy as np

from . import native


OUTPUTS = ("positions", "velocities", "accelerations")
BODY_COLUMNS = {"positions": ("x", "y", "phi"), "velocities": ("vx", "vy", "omega"),
                "accelerations": ("ax", "ay", "alpha")}
POINT_COLUMNS = {"positions": ("x", "y"), "velocities": ("vx", "vy"), "accelerations": ("ax", "ay")}
ARTIFICIAL_COLUMNS = {"positions": "theta", "velocities": "dtheta", "accelerations": "ddtheta"}


def stages_for(columns) -> tuple:
    """The fewest of OUTPUTS (positions, then velocities, accelerations)
    whose columns hold every one of ``columns`` (trajectory column names)."""
    stage = {q: s for s, o in enumerate(OUTPUTS) for q in (*BODY_COLUMNS[o], *POINT_COLUMNS[o], ARTIFICIAL_COLUMNS[o])}
    return OUTPUTS[:1 + max(stage[c.rsplit(".", 1)[1]] for c in columns)]


class Status(IntEnum):
    SUCCESS = 0
    NOT_CONVERGED = 1
    SINGULAR = 2
    WRONG_BRANCH = 3     # assembled on a branch the case's pins exclude (kinem.branches)
    OUT_OF_TIME = 4      # the run's time limit reached (Options.max_seconds): kinem.errors.OutOfTimeError

    def __str__(self) -> str:   # printed by name (JSON and comparisons keep the number)
        return self.name

    def __format__(self, spec) -> str:
        return format(self.name, spec)


# Jupyter's rich display of a Trajectory and a SolveResult: set by kinem.notebook,
# which may draw (the drawing is above the solver core, which imports this module).
HTML = {}


def missing_column(name, columns) -> str:
    """"no column 'p.x'" with the nearest names (did you mean) or the first columns."""
    import difflib

    close = difflib.get_close_matches(str(name), list(columns), n=3, cutoff=0.6) if isinstance(name, str) else []
    if close:
        return f"no column {name!r}; did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
    head = ", ".join(columns[:12]) + (f" ... ({len(columns)} columns)" if len(columns) > 12 else "")
    return f"no column {name!r}; columns: {head}"


@dataclass(frozen=True, eq=False, init=False)
class Trajectory:
    """Output instants ``t`` (n,) and ``data`` (n, columns), time-major; a
    column by name: ``traj["crank.phi"]``, ``traj.get("crank", "phi")``.
    ``data`` may be given as a function that makes it (``make``): it is
    then made at its first use, once (a solve's columns cost nothing until
    read)."""
    t: np.ndarray
    columns: tuple
    _index: dict | None = field(default=None, repr=False)  # column -> position (None: made here)

    def __init__(self, t, columns, data=None, _index=None, *, make=None):
        set_ = object.__setattr__
        set_(self, "t", t)
        set_(self, "columns", columns)
        set_(self, "_index", {c: k for k, c in enumerate(columns)} if _index is None else _index)
        set_(self, "_make", make)
        set_(self, "_data", None)
        t.setflags(write=False)   # (setflags: half the flags setter's cost)
        if make is None:
            data.setflags(write=False)
            set_(self, "_data", data)

    @property
    def data(self) -> np.ndarray:
        """The table (instants, columns), read-only."""
        if self._data is None:
            d = self._make()
            d.setflags(write=False)
            object.__setattr__(self, "_data", d)
            object.__setattr__(self, "_make", None)
        return self._data

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.data[:, self._index[name]]
        except (KeyError, TypeError):   # (TypeError: a name that is no key, a list)
            from .errors import UnknownColumn

            raise UnknownColumn(missing_column(name, self.columns)) from None

    def __contains__(self, name) -> bool:
        return name in self._index

    def get(self, item: str, quantity: str) -> np.ndarray:
        """A body's, point's or artificial coordinate's quantity, e.g. ("slider", "vx")."""
        return self[f"{item}.{quantity}"]

    def __len__(self) -> int:
        return len(self.t)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        """``np.asarray(traj)``: the table as the CSV has it, (instants, 1 +
        columns), t first and then ``columns`` (always a new array)."""
        if copy is False:
            raise ValueError("a Trajectory's array is always a new one (t beside data): copy=False is impossible")
        table = np.column_stack([self.t, self.data]) if len(self.columns) else self.t[:, None].copy()
        return table if dtype is None else table.astype(dtype, copy=False)

    def to_pandas(self):
        """A pandas DataFrame: one column per name, indexed by t (pandas is
        optional: a KinemError names it when it is not installed)."""
        try:
            import pandas as pd
        except ImportError:
            from .errors import KinemError

            raise KinemError("Trajectory.to_pandas needs pandas, which is not installed: pip install pandas") from None
        return pd.DataFrame(np.array(self.data), columns=list(self.columns), index=pd.Index(np.array(self.t), name="t"))

    def _repr_html_(self):
        return HTML["trajectory"](self) if "trajectory" in HTML else None

    def __repr__(self) -> str:
        span = f", t {self.t[0]:.6g} to {self.t[-1]:.6g}" if len(self.t) else ""
        names = ", ".join(self.columns[:4]) + (", ..." if len(self.columns) > 4 else "")
        return f"Trajectory({len(self.t)} instants{span}, {len(self.columns)} columns: {names})"


@dataclass(frozen=True, eq=False)
class SolveResult:
    success: bool
    status: Status
    message: str
    trajectory: Trajectory           # the instants solved (all of them on success)
    q: np.ndarray                    # (n_t, n) coordinates
    qd: np.ndarray | None            # velocities, when computed
    qdd: np.ndarray | None           # accelerations, when computed
    iterations: np.ndarray           # Newton iterations per instant
    residual: np.ndarray             # final scaled residual per instant
    conditioning: np.ndarray         # pivot ratio of the dimensionless Jacobian per instant (docs/solver.md)
    substeps: int                    # steps taken beyond one per output interval
    events: tuple                    # (t, text): singular configurations passed on the way
    trace: tuple                     # solve(trace=True): (t, what, iteration, residual, detail) records
    jacobian_evaluations: int
    factorizations: int
    wall_time: float                 # seconds in the analysis loop
    t_fail: float | None = None
    failed_constraint: str | None = None
    margin_moves: tuple = ()         # outputs "margins": per instant, the coordinates the smallest singular vector moves
    attempts: int = 0                # step attempts counted against Options.max_substeps (kinem.budget)
    model: object = field(default=None, repr=False)   # the Model solved (kept alive: kinem.animate draws it)

    @classmethod
    def of(cls, values: dict | None = None, /, **fields) -> "SolveResult":
        """A result from every field's value (``solve``'s), as a dict
        (taken, not copied) or as keywords: the same object as
        ``SolveResult(**values)`` without the frozen dataclass's per-field
        setattr (2.5 us of a 2-instant solve's 25) nor, given a dict, the
        keywords' packing (0.9 us)."""
        if values is None:
            values = fields
        elif fields:
            raise TypeError("SolveResult.of: a dict or keywords, not both")
        if values.keys() != _RESULT_FIELDS:
            raise TypeError(f"SolveResult.of: fields {sorted(values.keys() ^ _RESULT_FIELDS)} missing or unknown")
        return frozen(cls, values)

    def _repr_html_(self):
        return HTML["result"](self) if "result" in HTML else None

    def __repr__(self) -> str:
        return (f"SolveResult(success={self.success}, status={self.status.name}, message={self.message!r}, "
                f"trajectory={self.trajectory!r}, wall_time={self.wall_time:.3g} s)")


_RESULT_FIELDS = {f.name for f in fields(SolveResult)}
_LAYOUTS = weakref.WeakKeyDictionary()  # model -> {number of stages: ``_layout``}


def _layout(model, stages: int):
    """The column names of the first ``stages`` of OUTPUTS, the column of
    each in the sources [X_0 .. X_{S-1}, Re P_0, Im P_0, Re P_1, ...] (X_s:
    the coordinates of stage s (n), P_s: its points (p)), and the names'
    positions by name."""
    per = _LAYOUTS.get(model)
    if per is None:
        per = _LAYOUTS[model] = {}
    elif stages in per:
        return per[stages]
    names, src = [], []
    n, nb, npt = model.n, len(model.body_names), len(model.point_names)
    for k, body in enumerate(model.body_names):
        for s, stage in enumerate(OUTPUTS[:stages]):
            for j, quantity in enumerate(BODY_COLUMNS[stage]):
                names.append(f"{body}.{quantity}")
                src.append(s * n + 3 * k + j)
    for p, point in enumerate(model.point_names):
        for s, stage in enumerate(OUTPUTS[:stages]):
            qx, qy = POINT_COLUMNS[stage]
            names += [f"{point}.{qx}", f"{point}.{qy}"]
            src += [stages * n + 2 * s * npt + p, stages * n + (2 * s + 1) * npt + p]
    for a, label in enumerate(model.artificial):
        base = label.rsplit(".", 1)[0]
        for s, stage in enumerate(OUTPUTS[:stages]):
            names.append(f"{base}.{ARTIFICIAL_COLUMNS[stage]}")
            src.append(s * n + 3 * nb + a)
    out = per[stages] = (tuple(names), np.array(src, np.int64), {c: k for k, c in enumerate(names)})
    return out


def trajectory(model, t, Q, QD=None, QDD=None) -> Trajectory:
    """Named columns (docs/case-format.md, "Trajectory output") from raw
    coordinates, in one compiled pass."""
    return stacked(model, t, [x for x in (Q, QD, QDD) if x is not None])


def stacked(model, t, X) -> Trajectory:
    """``trajectory`` of the stages Q (, QD, QDD) in X (their sequence, or
    an array (stages, instants, n)), read when its columns are first asked
    for. The model's own instants (read-only) are its t, not a copy."""
    names, src, index = _layout(model, len(X))
    if t is not model.times:
        t = np.array(t, dtype=float)
        t.setflags(write=False)
    if not len(t):
        return Trajectory(t, names, np.empty((0, len(names))), index)
    # Trajectory(t, names, None, index, make=...) without its __init__'s attribute by attribute setting
    return frozen(Trajectory, {"t": t, "columns": names, "_index": index, "_data": None, "_make": lambda: native.columns(
        [np.ascontiguousarray(x, float) for x in X], src, model.point_cols, model.point_local)})


def frozen(cls, values: dict):
    """An instance of the frozen dataclass ``cls`` from every field's value
    (a dict, taken, not copied): its __init__'s object.__setattr__ per field
    left out (about 0.15 us a field, on every solve)."""
    r = object.__new__(cls)
    object.__setattr__(r, "__dict__", values)
    return r
