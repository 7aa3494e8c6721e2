"""What the gate needs to see every change: a case's fingerprint (a hash of
the loaded case without its solver settings, which are kept beside it) and a
run's compact trajectory (positions, velocities and accelerations of every
body coordinate and named point at a fixed subset of instants, at full
precision), judged scale-free (docs/engines.md: positions / L, angles in rad,
velocities / V, angular velocities / (V / L), accelerations / (V^2 / L),
angular accelerations / (V^2 / L^2), V the run's peak speed)."""
import dataclasses
import hashlib
import json
from collections.abc import Mapping

import numpy as np

TRAJECTORY_INSTANTS = 11     # first and last included, spread evenly
NOT_HASHED = ("source", "description", "report",    # where the file is, its prose, what the page draws
              "parameters",   # the named dimensions' values are hashed where they are used
              "tolerances")   # what kinem tolerance samples (the runs are the nominal's)
DERIVED = ("carries",   # a body's drawn points: hashed in the constraints and points that use them
           "refs")      # a constraint's point names: their values are in its fields
# The native solver's settings: an edit of these alone is compared (at the
# baseline's tolerance), not called stale.
SOLVER = ("tolerance", "max_iterations", "linear_solver", "jacobian_reuse", "block")
# Each column's quantity by its suffix: the figure of adapters.compare it is judged as.
KINDS = {"x": "position", "y": "position", "phi": "angle", "vx": "velocity", "vy": "velocity",
         "omega": "angular_velocity", "ax": "acceleration", "ay": "acceleration", "alpha": "angular_acceleration"}
UNITS = {"position": "L", "angle": "rad", "velocity": "V", "angular_velocity": "V/L",
         "acceleration": "V^2/L", "angular_acceleration": "V^2/L^2"}


def _canonical(x):
    """JSON-ready and exact: floats as their hex form, dataclasses by field."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {"__type__": type(x).__name__,
                **{f.name: _canonical(getattr(x, f.name)) for f in dataclasses.fields(x) if f.name not in DERIVED}}
    if isinstance(x, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(x.items(), key=lambda kv: str(kv[0]))}
    if isinstance(x, (list, tuple)):
        return [_canonical(v) for v in x]
    if isinstance(x, np.ndarray):
        return [_canonical(v) for v in x.tolist()]
    if isinstance(x, np.generic):
        return _canonical(x.item())
    if isinstance(x, float):
        return x.hex()
    if x is None or isinstance(x, (bool, int, str)):
        return x
    raise TypeError(f"cannot fingerprint a {type(x).__name__}")


def fingerprint(case) -> str:
    """SHA-256 (hex, first 16 digits) of the loaded case: everything that
    changes the runs (bodies, points, constraints, time, solver, engine
    settings, equivalence); not its file path, description or [report] table,
    [tolerances], nor the native solver's settings (``solver_settings``)."""
    fields = {f.name: getattr(case, f.name) for f in dataclasses.fields(case)
              if f.name not in NOT_HASHED + SOLVER}
    text = json.dumps(_canonical(fields), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def solver_settings(case) -> dict:
    """The native solver's settings of a case (compared, not hashed)."""
    return {k: getattr(case, k) for k in SOLVER}


def columns(model) -> list:
    """Every body's x, y, phi and rates, every named point's x, y and rates."""
    return ([f"{b}.{c}" for b in model.body_names for c in ("x", "y", "phi", "vx", "vy", "omega", "ax", "ay", "alpha")]
            + [f"{p}.{c}" for p in model.point_names for c in ("x", "y", "vx", "vy", "ax", "ay")])


def kind(column) -> str:
    return KINDS[column.rsplit(".", 1)[1]]


def instants(n) -> list:
    return np.unique(np.round(np.linspace(0, n - 1, min(n, TRAJECTORY_INSTANTS))).astype(int)).tolist()


def compact(model, traj) -> dict:
    """{"t": [...], "columns": {name: [...]}} at ``instants``, every column of
    ``columns`` the trajectory has (an engine: no accelerations); floats at
    full precision (JSON writes their shortest exact form)."""
    idx = instants(len(traj))
    return {"t": [float(traj.t[k]) for k in idx],
            "columns": {c: [float(traj[c][k]) for k in idx] for c in columns(model) if c in traj}}


def scaled(column, d, length, speed):
    """Differences d of one column, scale-free (angles wrapped)."""
    k = kind(column)
    d = np.asarray(d, float)
    if k == "angle":
        return np.abs((d + np.pi) % (2 * np.pi) - np.pi)
    scale = {"position": length, "velocity": speed, "angular_velocity": speed / length,
             "acceleration": speed ** 2 / length, "angular_acceleration": speed ** 2 / length ** 2}[k]
    return np.abs(d) / scale


def moved(old, new, length, speed, limits) -> tuple | None:
    """The largest move between two compact trajectories of the same case,
    relative to its limit: (column, move, unit, t, limit), scale-free
    (``scaled``); limits {kind: limit} (a kind without a limit is not
    judged); None when nothing moved beyond them. The instants and the
    columns must match (the baseline is checked before: results.check_trajectory)."""
    worst, ratio = None, 1.0
    for name, a in old["columns"].items():
        limit = limits.get(kind(name))
        if limit is None or name not in new["columns"]:
            continue
        d = scaled(name, np.asarray(new["columns"][name], float) - np.asarray(a, float), length, speed)
        k = int(np.argmax(d))
        if d[k] > ratio * limit:
            worst, ratio = (name, float(d[k]), UNITS[kind(name)], old["t"][k], limit), d[k] / limit
    return worst
