"""What every engine adapter shares.

An adapter builds one mechanism in its engine from the compiled kinem Model
(never from TOML), starts it from the native solution at t = 0 (positions and
velocities), drives it with the case's drivers, samples it at the model's
output instants and returns an EngineRun whose trajectory has the same
column names as the native one (built with kinem.result.trajectory from raw
coordinates in the case's body frames).

The skeleton (``Adapter.run``) owns what is common: settings checked in one
place (``Adapter.settings``, against each adapter's ``checks``), the support
check, the substeps per output interval, the driving values at every step
(``drive_table``, through kinem.functions.FunctionSet), the timing (``wall_time``:
seconds in the engine's stepping calls; ``overhead``: the adapter's own Python
around them, building and sampling included) and the typed status. An engine
implements ``version``, ``defaults``/``checks`` and ``simulate``.
"""
import enum
import math
import time
from dataclasses import dataclass, field

import numpy as np

from kinem.casefile.keys import LocalKey
from kinem.constraints import REGISTRY
from kinem.errors import InputError
from kinem.functions import FunctionSet
from kinem.result import Trajectory


class Status(str, enum.Enum):
    """How an engine run ended. In JSON and text a run's status is one string,
    ``label``: "ok", "unsupported: <why>" or "failed: <why>" (every failure
    kind, so readers of reports need one prefix); the kind is ``outcome``."""
    OK = "ok"
    UNSUPPORTED = "unsupported"   # the engine cannot represent the model (or these settings of it)
    FAILED = "failed"             # the engine stopped: build error, solver failure
    DIVERGED = "diverged"         # the engine ran, the solution left the mechanism
    NONFINITE = "non-finite"      # NaN or infinite coordinates

    def label(self, detail: str = "") -> str:
        if self is Status.OK:
            return "ok"
        prefix = "unsupported" if self is Status.UNSUPPORTED else "failed"
        return f"{prefix}: {detail}" if detail else prefix

    @property
    def failure(self) -> bool:
        return self not in (Status.OK, Status.UNSUPPORTED)


class Failure(Exception):
    """Raised inside ``simulate`` to end a run with a status; ``partial``:
    (Q, QD) of the instants reached, or None."""

    def __init__(self, status: Status, detail: str, steps: int = 0, partial=None):
        super().__init__(detail)
        self.status, self.detail, self.steps, self.partial = status, detail, steps, partial


@dataclass(frozen=True, eq=False)
class EngineRun:
    engine: str
    status: Status
    detail: str                      # why (unsupported, failed); "" when ok
    trajectory: Trajectory | None    # positions and velocities (same columns as native)
    q: np.ndarray | None             # (n_t, n) raw coordinates, case body frames
    qd: np.ndarray | None
    wall_time: float = 0.0           # seconds in the engine's own stepping calls
    steps: int = 0                   # engine steps taken
    substeps: int = 1                # engine steps per output interval
    settings: dict = field(default_factory=dict)
    version: str = ""
    overhead: float = 0.0            # seconds of the adapter's own work: build, driving, sampling
    intervals: int = 0               # output intervals simulated

    @property
    def ok(self) -> bool:
        return self.status is Status.OK

    @property
    def label(self) -> str:
        return self.status.label(self.detail)

    @property
    def per_interval(self) -> float:
        """Stepping seconds per output interval."""
        return self.wall_time / self.intervals if self.intervals else float("nan")


# -- settings checks: each returns None when v is acceptable, else what was expected

def positive(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < math.inf
    return None if ok else "a positive number"


def finite(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    return None if ok else "a finite number"


def nonnegative(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < math.inf
    return None if ok else "a number >= 0"


def count(v):
    return None if isinstance(v, int) and not isinstance(v, bool) and v >= 1 else "a positive integer"


def count_or_none(v):
    return None if v is None or count(v) is None else "a positive integer or none"


def boolean(v):
    return None if isinstance(v, bool) else "true or false"


def choice(*options):
    def check(v):
        return None if v in options else "one of " + ", ".join(map(str, options))
    return check


def fraction(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 1
    return None if ok else "a number in [0, 1]"


def numbers(n, check=positive, optional=False):
    """A list of n numbers each passing ``check`` (or none, when optional)."""
    def checker(v):
        if optional and v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == n and all(check(x) is None for x in v)
        return None if ok else f"a list of {n} numbers, each {check(None)}" + (" (or none)" if optional else "")
    return checker


class Adapter:
    """Subclass per engine. ``supports`` maps each supported case-file type to
    how the engine represents it; ``reasons`` maps the others to why not;
    ``tolerance`` limits the figures of adapters.compare at the defaults;
    ``checks`` maps every setting to its check."""
    name = ""
    supports: dict = {}
    reasons: dict = {}
    tolerance: dict = {}
    checks: dict = {}
    knobs: dict = {}       # the engine's own accuracy knobs and the values adapters.tune sweeps

    def version(self) -> str:
        raise NotImplementedError

    def defaults(self) -> dict:
        raise NotImplementedError

    def unsupported(self, model) -> str | None:
        """None when the engine can represent the model, else why not."""
        for c in model.case.constraints:
            if c.type not in self.supports:
                why = self.reasons.get(c.type, "no equivalent in this engine")
                return f"{c.type} ('{c.name}'): {why}"
        return None

    def settings(self, overrides=None, where="") -> dict:
        """The defaults with ``overrides`` applied, every key and value checked:
        the one place settings are validated. ``where`` names their source
        (a case file's [engines.NAME] table, --set) in the InputError."""
        s = dict(self.defaults())
        at = f"{where}: " if where else ""
        for k, v in (overrides or {}).items():
            if k not in s:
                raise InputError(f"{at}{self.name} setting '{k}': unknown; expected one of {', '.join(s)}")
            s[k] = v
        for k, v in s.items():
            check = self.checks.get(k)
            why = check(v) if check else None
            if why:
                raise InputError(f"{at}{self.name} setting '{k}' = {v!r}: expected {why}")
        return s

    def steps_per_interval(self, s, interval):
        """Fills s["substeps"] (given, or the fewest with a step <= s["dt"])
        and s["dt"] (the step used: the interval / substeps)."""
        if s.get("substeps") is None:
            s["substeps"] = max(1, math.ceil(interval / s["dt"] * (1 - 1e-12)))
        s["dt"] = interval / s["substeps"]
        return s["substeps"]

    def run(self, model, q0, qd0, settings=None) -> EngineRun:
        """Simulates over model.times from (q0, qd0). Bad settings raise
        InputError; an engine failure never raises (its status says it)."""
        start = time.perf_counter()
        s = self.settings(settings)
        times = np.asarray(model.times, float)
        interval = float(times[1] - times[0]) if len(times) > 1 else float(model.case.end or 1.0)
        sub = self.steps_per_interval(s, interval)
        common = dict(engine=self.name, substeps=sub, settings=s, version=self.version(), intervals=len(times) - 1)

        def finish(status, detail="", Q=None, QD=None, wall=0.0, steps=0):
            from kinem.result import trajectory

            traj = None if Q is None or status is not Status.OK else trajectory(model, times[:len(Q)], Q, QD)
            return EngineRun(status=status, detail=detail, trajectory=traj, q=Q if traj is not None else None,
                             qd=QD if traj is not None else None, wall_time=wall, steps=steps,
                             overhead=max(time.perf_counter() - start - wall, 0.0), **common)

        why = self.unsupported_with(model, q0, s)
        if why:
            return finish(Status.UNSUPPORTED, why)
        q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
        try:
            Q, QD, wall, steps = self.simulate(model, q0, qd0, s, times)
        except Failure as e:
            return finish(e.status, " ".join(e.detail.split()), steps=e.steps)
        if not (np.isfinite(Q).all() and np.isfinite(QD).all()):
            return finish(Status.NONFINITE, "non-finite coordinates", wall=wall, steps=steps)
        return finish(Status.OK, "", Q, QD, wall, steps)

    def unsupported_with(self, model, q0, s) -> str | None:
        """``unsupported`` for these settings and start (an engine whose
        support depends on them overrides it)."""
        return self.unsupported(model)

    def simulate(self, model, q0, qd0, s, times):
        """(Q, QD, stepping seconds, steps) at the output instants ``times``
        with the checked settings s (substeps and dt resolved); raises
        Failure to stop with a status."""
        raise NotImplementedError

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


def drive_table(functions, t, order):
    """d^(order) of each driving function (kinem.functions specs) at the
    instants t: (len(t), len(functions)), one FunctionSet call."""
    if not len(functions):
        return np.zeros((len(t), 0))
    return np.asarray(FunctionSet(list(functions))(np.asarray(t, float), order)).reshape(len(t), len(functions))
