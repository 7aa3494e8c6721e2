"""Typed, frozen results: a Trajectory of named columns (time-major) and the
SolveResult that carries it with success, status and message."""
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

OUTPUTS = ("positions", "velocities", "accelerations")
BODY_COLUMNS = {"positions": ("x", "y", "phi"), "velocities": ("vx", "vy", "omega"),
                "accelerations": ("ax", "ay", "alpha")}
POINT_COLUMNS = {"positions": ("x", "y"), "velocities": ("vx", "vy"), "accelerations": ("ax", "ay")}
ARTIFICIAL_COLUMNS = {"positions": "theta", "velocities": "dtheta", "accelerations": "ddtheta"}


class Status(IntEnum):
    SUCCESS = 0
    NOT_CONVERGED = 1
    SINGULAR = 2


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Output instants ``t`` (n,) and ``data`` (n, columns), time-major; a
    column by name: ``traj["crank.phi"]``, ``traj.get("crank", "phi")``."""
    t: np.ndarray
    columns: tuple
    data: np.ndarray
    _index: dict = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "_index", {c: k for k, c in enumerate(self.columns)})
        self.t.flags.writeable = False
        self.data.flags.writeable = False

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.data[:, self._index[name]]
        except KeyError:
            raise KeyError(f"no column '{name}'; columns: {', '.join(self.columns[:12])}...") from None

    def __contains__(self, name) -> bool:
        return name in self._index

    def get(self, item: str, quantity: str) -> np.ndarray:
        """A body's, point's or artificial coordinate's quantity, e.g. ("slider", "vx")."""
        return self[f"{item}.{quantity}"]

    def __len__(self) -> int:
        return len(self.t)

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

    def __repr__(self) -> str:
        return (f"SolveResult(success={self.success}, status={self.status.name}, message={self.message!r}, "
                f"trajectory={self.trajectory!r}, wall_time={self.wall_time:.3g} s)")


def trajectory(model, t, Q, QD=None, QDD=None) -> Trajectory:
    """Named columns (docs/case-format.md, "Trajectory output") from raw coordinates."""
    stages = [(s, X) for s, X in zip(OUTPUTS, (Q, QD, QDD)) if X is not None]
    cols, names = [], []
    nb = len(model.body_names)
    for k, body in enumerate(model.body_names):
        for stage, X in stages:
            for j, quantity in enumerate(BODY_COLUMNS[stage]):
                names.append(f"{body}.{quantity}")
                cols.append(X[:, 3 * k + j])
    if model.point_names:
        pc = model.point_cols
        s = model.point_local[None, :] * np.exp(1j * Q[:, pc + 2])
        values = {"positions": Q[:, pc] + 1j * Q[:, pc + 1] + s}
        if QD is not None:
            w = QD[:, pc + 2]
            values["velocities"] = QD[:, pc] + 1j * QD[:, pc + 1] + 1j * s * w
            if QDD is not None:
                values["accelerations"] = QDD[:, pc] + 1j * QDD[:, pc + 1] + 1j * s * QDD[:, pc + 2] - s * w * w
        for p, point in enumerate(model.point_names):
            for stage, _ in stages:
                v = values[stage][:, p]
                qx, qy = POINT_COLUMNS[stage]
                names += [f"{point}.{qx}", f"{point}.{qy}"]
                cols += [v.real, v.imag]
    for a, label in enumerate(model.artificial):
        base = label.rsplit(".", 1)[0]
        for stage, X in stages:
            names.append(f"{base}.{ARTIFICIAL_COLUMNS[stage]}")
            cols.append(X[:, 3 * nb + a])
    data = np.column_stack(cols) if cols else np.empty((len(t), 0))
    return Trajectory(np.array(t, dtype=float), tuple(names), np.ascontiguousarray(data))
