"""What the gate needs to see every change: a case's fingerprint (a hash of
the loaded case) and a run's compact trajectory (every body coordinate and
named point at a fixed subset of instants, at full precision)."""
import dataclasses
import hashlib
import json
from collections.abc import Mapping

import numpy as np

TRAJECTORY_INSTANTS = 11     # first and last included, spread evenly
NOT_HASHED = ("source", "description", "report",    # where the file is, its prose, what the page draws,
              "tolerances",                           # what kinem tolerance samples (the runs are the nominal's)
              "refs")                                 # a constraint's point names: their values are in its fields


def _canonical(x):
    """JSON-ready and exact: floats as their hex form, dataclasses by field."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {"__type__": type(x).__name__,
                **{f.name: _canonical(getattr(x, f.name)) for f in dataclasses.fields(x) if f.name not in NOT_HASHED}}
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
    settings, equivalence); not its file path, description, [report] table
    or [tolerances]."""
    fields = {f.name: getattr(case, f.name) for f in dataclasses.fields(case) if f.name not in NOT_HASHED}
    text = json.dumps(_canonical(fields), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def columns(model) -> list:
    """Every body's x, y, phi and every named point's x, y."""
    return ([f"{b}.{c}" for b in model.body_names for c in ("x", "y", "phi")]
            + [f"{p}.{c}" for p in model.point_names for c in ("x", "y")])


def instants(n) -> list:
    return np.unique(np.round(np.linspace(0, n - 1, min(n, TRAJECTORY_INSTANTS))).astype(int)).tolist()


def compact(model, traj) -> dict:
    """{"t": [...], "columns": {name: [...]}} at ``instants``; floats at full
    precision (JSON writes their shortest exact form)."""
    idx = instants(len(traj))
    return {"t": [float(traj.t[k]) for k in idx],
            "columns": {c: [float(traj[c][k]) for k in idx] for c in columns(model)}}


def moved(old, new, length, limits) -> tuple | None:
    """The largest move between two compact trajectories of the same case
    against its limit: (column, move, unit, t, limit) with positions in L
    and angles in rad (wrapped), limits {"L": .., "rad": ..}; None when
    nothing moved beyond them. A column or instant one lacks is an infinite move."""
    if old["t"] != new["t"] or set(old["columns"]) != set(new["columns"]):
        gone = sorted(set(old["columns"]) ^ set(new["columns"]))
        return (gone[0] if gone else "t", float("inf"), "L", None, limits["L"])
    worst, ratio = None, 1.0
    for name, a in old["columns"].items():
        d = np.asarray(new["columns"][name], float) - np.asarray(a, float)
        unit = "rad" if name.endswith(".phi") else "L"
        d = np.abs((d + np.pi) % (2 * np.pi) - np.pi) if unit == "rad" else np.abs(d) / length
        k = int(np.argmax(d))
        if d[k] > ratio * limits[unit]:
            worst, ratio = (name, float(d[k]), unit, old["t"][k], limits[unit]), d[k] / limits[unit]
    return worst
