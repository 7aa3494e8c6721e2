"""What every engine adapter shares.

An adapter builds one mechanism in its engine from the compiled kinem Model
(never from TOML), starts it from the native solution at t = 0 (positions and
velocities), drives it with the case's drivers, samples it at the model's
output instants and returns an EngineRun whose trajectory has the same
column names as the native one (built with kinem.result.trajectory from raw
coordinates in the case's body frames).
"""
from dataclasses import dataclass, field

import numpy as np

from kinem.casefile.keys import LocalKey
from kinem.constraints import REGISTRY
from kinem.functions import FunctionSet
from kinem.result import Trajectory


@dataclass(frozen=True, eq=False)
class EngineRun:
    engine: str
    status: str                      # "ok" | "unsupported: <type and why>" | "failed: <why>"
    trajectory: Trajectory | None    # positions and velocities (same columns as native)
    q: np.ndarray | None             # (n_t, n) raw coordinates, case body frames
    qd: np.ndarray | None
    wall_time: float                 # seconds spent stepping the engine
    steps: int                       # engine steps taken
    substeps: int                    # engine steps per output interval
    settings: dict = field(default_factory=dict)
    version: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class Adapter:
    """Subclass per engine. ``supports`` maps each supported case-file type to
    how the engine represents it; ``reasons`` maps the others to why not."""
    name = ""
    supports: dict = {}
    reasons: dict = {}

    def version(self) -> str:
        raise NotImplementedError

    def defaults(self) -> dict:
        raise NotImplementedError

    def unsupported(self, model) -> str | None:
        """None when the engine can represent the model, else 'unsupported: ...'."""
        for c in model.case.constraints:
            if c.type not in self.supports:
                why = self.reasons.get(c.type, "no equivalent in this engine")
                return f"unsupported: {c.type} ('{c.name}'): {why}"
        return None

    def run(self, model, q0, qd0, settings=None) -> EngineRun:
        """Simulate over model.times from (q0, qd0); never raises for an engine
        failure (status 'failed: ...')."""
        raise NotImplementedError

    def settings(self, overrides=None) -> dict:
        s = dict(self.defaults())
        for k, v in (overrides or {}).items():
            if k not in s:
                from kinem.errors import InputError

                raise InputError(f"{self.name} setting '{k}': unknown; expected one of {', '.join(s)}")
            s[k] = v
        return s


# -- helpers shared by the adapters -------------------------------------------

@dataclass(frozen=True)
class Drive:
    """One driving constraint: q[col] (or a point coordinate, or
    phi_body - phi_relative) follows f(t)."""
    name: str
    body: str
    coord: str                     # x | y | phi
    point: tuple | None
    relative_to: str | None
    f: object                      # kinem.functions spec
    _set: FunctionSet = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "_set", FunctionSet([self.f]))  # built once: splines are not cheap

    def __call__(self, t: float, order: int = 0) -> float:
        return float(self._set(t, order)[0])


def drives(model) -> list:
    return [Drive(c.name, c["body"], c["coord"], c.get("point"), c.get("relative_to"), c["d"])
            for c in model.case.constraints if c.type == "driver"]


def grounded(model) -> set:
    """Bodies fixed by a 'ground' constraint."""
    return {c["body"] for c in model.case.constraints if c.type == "ground"}


def body_points(model) -> dict:
    """Every local point used on each body (constraints and named points)."""
    pts = {b: [] for b in model.body_names}
    for c in model.case.constraints:
        for key in REGISTRY[c.type].keys:
            if isinstance(key, LocalKey) and key.name in c.fields:
                pts[c[key.of]].append(tuple(c[key.name]))
    for p in model.case.points:
        pts[p.body].append(tuple(p.at))
    return pts


def mass_properties(model):
    """Mass and central inertia of each body, centre of mass at the body
    origin. A body's own ``mass``/``inertia`` in the case file win; the
    defaults are mass 1 and inertia m * max(mean |s'|^2, (0.05 L)^2) over the
    body's points, so that mass ratios stay 1:1 and inertias stay moderate
    whatever the units."""
    pts = body_points(model)
    floor = (0.05 * model.length) ** 2
    mass, inertia = [], []
    for b in model.case.bodies:
        m = b.mass if b.mass is not None else 1.0
        r2 = np.mean([x * x + y * y for x, y in pts[b.name]]) if pts[b.name] else 0.0
        mass.append(m)
        inertia.append(b.inertia if b.inertia is not None else m * max(r2, floor))
    return np.array(mass), np.array(inertia)
