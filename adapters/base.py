"""What every engine adapter shares.

An adapter builds one mechanism in its engine from the compiled kinem Model
(never from TOML), starts it from the model's assembly at the first output
instant (``start``: positions and velocities; never from a native
trajectory), drives it with the case's drivers, samples it at the model's
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
import contextlib
import contextvars
import enum
import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from kinem.budget import out_of_time
from kinem.casefile.checks import show
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
    OUT_OF_TIME = "out of time"   # the run's time limit is reached (OutOfTime: compare and animate --max-seconds)

    def label(self, detail: str = "") -> str:
        if self is Status.OK:
            return "ok"
        prefix = "unsupported" if self is Status.UNSUPPORTED else "failed"
        return f"{prefix}: {detail}" if detail else prefix

    @property
    def failure(self) -> bool:
        return self not in (Status.OK, Status.UNSUPPORTED)


class Reason(str):
    """Why an engine cannot represent a model: the text shown to people
    ("cam-flat ('cam'): no ..."), with its parts kept typed: ``kind`` (the
    constraint type, "" when the reason is not one type's) and ``why`` (the
    text without the constraint's own name), so that the report groups the
    cases that share a reason without reading its text back."""
    kind: str
    name: str   # the constraint's
    why: str

    def __new__(cls, kind: str, name: str, why: str):
        text = f"{kind} ('{name}'): {why}" if kind else why
        r = super().__new__(cls, text)
        r.kind, r.name, r.why = kind, name, why
        return r

    def __reduce__(self):
        """Pickles as its parts (runs come back from worker processes)."""
        return Reason, (self.kind, self.name, self.why)


class Failure(Exception):
    """Raised inside ``simulate`` to end a run with a status; ``partial``:
    (Q, QD) of the instants reached, or None; ``wall``: stepping seconds spent."""

    def __init__(self, status: Status, detail: str, steps: int = 0, partial=None, wall: float = 0.0):
        super().__init__(detail)
        self.status, self.detail, self.steps, self.partial, self.wall = status, detail, steps, partial, wall


class OutOfTime(Failure):
    """The run's time limit (``Adapter.run``'s ``limit``) is reached: the
    run ends, never refined nor retried, and no earlier attempt stands; its
    status is Status.OUT_OF_TIME (the cause kept, never read from a clock)."""


# The time limit of the run in this thread (Adapter.run's ``limit``): (seconds, its time.time() deadline), or None.
_LIMIT = contextvars.ContextVar("adapters_limit", default=None)


def in_time(t, steps=0, wall=0.0):
    """OutOfTime at t (the steps and stepping seconds so far) when the run's
    time limit is reached; the engines' step loops call it between output
    intervals (kinem.budget's words: compare's native solves)."""
    limit = _LIMIT.get()
    if limit is not None and time.time() > limit[1]:
        raise OutOfTime(Status.OUT_OF_TIME, f"{out_of_time(limit[0])} at t = {t:.6g}", steps, wall=wall)


@contextlib.contextmanager
def limited(limit):
    """``in_time``'s limit for what runs within: (seconds, its time.time() deadline), or None (Adapter.run's,
    and the native row's closed form in adapters.compare)."""
    token = _LIMIT.set(limit)
    try:
        yield
    finally:
        _LIMIT.reset(token)


def deadline():
    """The run's time limit as a time.time() instant (inf: none), for an engine that checks it on its own."""
    limit = _LIMIT.get()
    return math.inf if limit is None else limit[1]


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
    notes: tuple = ()                # what the adapter decided on its own: a retry after divergence
    estimate: dict = field(default_factory=dict)   # the engine's own error figures (self_check), no native
    capped: bool = False             # the self-check still exceeded the tolerance at the cost cap

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

# the largest float: a whole number beyond it (10**400 in a case's TOML) is no float
# (math.isfinite and division raise on it); compared exactly, it is out of range
MOST = sys.float_info.max
MAX_COUNT = 2**31 - 1   # counts (iterations, substeps): C ints in the engines


def positive(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v <= MOST
    return None if ok else "a positive number"


def finite(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and -MOST <= v <= MOST
    return None if ok else "a finite number"


def nonnegative(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= MOST
    return None if ok else "a number >= 0"


def count(v):
    return None if isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_COUNT else "a positive integer"


def step_or_auto(v):
    return None if v == "auto" or positive(v) is None else "a positive number or 'auto'"


def positive_or_none(v):
    return None if v is None or positive(v) is None else "a positive number or none"


def count_or_auto(v):
    return None if v == "auto" or count(v) is None else "a positive integer or 'auto'"


def count_or_none(v):
    return None if v is None or count(v) is None else "a positive integer or none"


WHOLE = (count, count_or_auto, count_or_none)   # the checks of counts: a whole float given for one is read as an int


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
    order: int | dict = 0  # error order in the step: > 0 refines dt = "auto" by self_check (``refine``);
                           # a dict: each self_check figure's own order (a figure not in it is not refined on)

    def version(self) -> str:
        raise NotImplementedError

    def defaults(self) -> dict:
        raise NotImplementedError

    def unsupported(self, model) -> Reason | None:
        """None when the engine can represent the model, else why not."""
        for c in model.case.constraints:
            if c.type not in self.supports:
                return Reason(c.type, c.name, self.reasons.get(c.type, "no equivalent in this engine"))
        return None

    def settings(self, overrides=None, where="", table=False) -> dict:
        """The defaults with ``overrides`` applied, every key and value checked:
        the one place settings are validated. ``where`` names their source
        (--set, or with ``table`` a case file's "CASE: [engines.NAME]", whose
        problems then read as the loader's: "key 'dt': got -1; expected ...")
        in the InputError."""
        s = dict(self.defaults())
        at = f"{where}: " if where else ""
        for k, v in (overrides or {}).items():
            if k not in s:
                raise InputError(f"{at}key '{k}': unknown key; expected one of {', '.join(s)}" if table else
                                 f"{at}{self.name} setting '{k}': unknown; expected one of {', '.join(s)}")
            s[k] = v
        for k, v in s.items():
            check = self.checks.get(k)
            if check in WHOLE and isinstance(v, float) and v.is_integer() and abs(v) <= MAX_COUNT:
                s[k] = v = int(v)   # a count written 1e3 (--set's JSON, a case file's TOML): as --steps reads it
            why = check(v) if check else None
            if why:
                raise InputError(f"{at}key '{k}': got {show(v)}; expected {why}" if table else
                                 f"{at}{self.name} setting '{k}' = {v!r}: expected {why}")
        return s

    def steps_per_interval(self, s, interval, intervals=1):
        """Fills s["substeps"] (given, or the fewest with a step <= s["dt"])
        and s["dt"] (the step used: the interval / substeps). InputError
        when the settings ask for more than MAX_SUBSTEPS steps per output
        interval and more than MAX_RUN_STEPS over the run's ``intervals``
        (a run no engine finishes: its step tables alone would not fit in
        memory); "auto" stays within MAX_SUBSTEPS."""
        key = "substeps" if s.get("substeps") is not None else "dt"
        if s.get("substeps") is None:
            n = interval / s["dt"] * (1 - 1e-12)
            s["substeps"] = max(1, math.ceil(n)) if n < MAX_RUN_STEPS + 1 else n
        if s["substeps"] > MAX_SUBSTEPS and s["substeps"] * intervals > MAX_RUN_STEPS:
            raise InputError(f"{self.name} setting '{key}' = {s[key]!r}: {s['substeps']:.3g} steps per output "
                             f"interval of {interval:.6g} s over {intervals} intervals; expected at most "
                             f"{MAX_RUN_STEPS:.0e} engine steps in a run (or {MAX_SUBSTEPS} per interval)")
        s["dt"] = interval / s["substeps"]
        return s["substeps"]

    def resolve(self, model, s, q0=None, qd0=None):
        """Fills the step of the checked settings s for the model and returns
        the steps per output interval. dt = "auto": rate_step / the
        mechanism's rate scale at its start (``start_rate`` of (q0, qd0):
        no native trajectory; recorded as s["rate_scale"]), refined after
        the first attempt by the rates of the engine's own run
        (``refine``); then ``steps_per_interval``. An engine with other
        "auto" settings resolves them here too."""
        times = np.asarray(model.times, float)
        interval = float(times[1] - times[0]) if len(times) > 1 else float(model.case.end or 1.0)
        if s.get("dt") == "auto" and s.get("substeps") is None:
            s["rate_scale"] = scale = start_rate(model, q0, qd0)
            s["dt"] = min(interval, s["rate_step"] / scale) if scale > 0 else interval
        return self.steps_per_interval(s, interval, max(len(times) - 1, 1))

    def step(self, model, settings=None, q0=None, qd0=None) -> float:
        """The engine step (s) that ``settings`` (defaults when None) give
        for the model's first attempt (dt = "auto" from the start's rates)."""
        s = self.settings(settings)
        if q0 is None:
            q0, qd0 = start(model)
        self.resolve(model, s, q0, qd0)
        return s["dt"]

    def retry(self, model, s, times, auto, failure=None, Q=None, QD=None):
        """(why, settings) to run once more with after a first attempt, or
        None: an engine whose own check finds a run diverged (``failure``)
        or inaccurate (its result Q, QD) says here which costlier settings
        cure it, among the settings it chose itself (``auto``: the keys
        requested as "auto"; an explicit value is never changed). Never
        judged against native's trajectory; the retry is in the run's
        ``notes`` and its cost includes both attempts."""
        return None

    def run(self, model, q0=None, qd0=None, settings=None, limit=None) -> EngineRun:
        """Simulates over model.times from (q0, qd0), by default the model's
        own assembly at the first instant (``start``). Bad settings raise
        InputError; an engine failure never raises (its status says it).
        Nothing of native's trajectory is read: the step is chosen and
        refined from the start's and the run's own figures alone.
        ``limit``: (seconds, the time.time() instant they end) the whole
        run may take, refinements included (kinem compare --max-seconds);
        past it the run fails with kinem.budget's message (``in_time``)."""
        with limited(limit):
            return self._run(model, q0, qd0, settings)

    def _run(self, model, q0, qd0, settings) -> EngineRun:
        began = time.perf_counter()
        s = self.settings(settings)
        times = np.asarray(model.times, float)
        notes, auto = [], {k for k, v in s.items() if v == "auto"}
        if s.get("substeps") is not None:
            auto.discard("dt")                 # the step is given as substeps
        why, early = None, None
        if q0 is None:
            try:
                q0, qd0 = start(model)
            except Failure as e:
                early = e
        if early is None:
            why = self.unsupported_with(model, q0, s)
        if early is None and not why:
            self.resolve(model, s, q0, qd0)

        state = {"estimate": {}, "capped": False}

        def finish(status, detail="", Q=None, QD=None, wall=0.0, steps=0):
            from kinem.result import trajectory

            traj = None if Q is None or status is not Status.OK else trajectory(model, times[:len(Q)], Q, QD)
            return EngineRun(engine=self.name, status=status, detail=detail, trajectory=traj,
                             q=Q if traj is not None else None, qd=QD if traj is not None else None, wall_time=wall,
                             steps=steps, substeps=s.get("substeps") or 0, settings=s, version=self.version(),
                             overhead=max(time.perf_counter() - began - wall, 0.0), intervals=len(times) - 1,
                             notes=tuple(notes), estimate=state["estimate"], capped=state["capped"])

        if why:
            return finish(Status.UNSUPPORTED, why)
        if early is not None:
            return finish(early.status, early.detail)
        q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
        wall = steps = 0
        kept = None   # the last ok attempt before a refinement: (Q, QD, settings, estimate)
        for attempt in range(1, 2 + MAX_REFINEMENTS):
            try:
                Q, QD, w, n = self.simulate(model, q0, qd0, s, times)
                wall, steps, failure = wall + w, steps + n, None
            except Failure as e:
                wall, steps, failure = wall + e.wall, steps + e.steps, e
            if isinstance(failure, OutOfTime):   # the whole run's bound: no earlier attempt stands, no rerun
                break
            if failure is not None and kept is not None:   # a refined run failed: the last good one stands
                Q, QD = kept[0], kept[1]
                s.clear()
                s.update(kept[2])
                notes.append(f"the refined run failed ({' '.join(failure.detail.split())[:100]}); kept the run "
                             f"at {s['substeps']} steps per output interval")
                state.update(estimate=kept[3], capped=True)
                failure = None
                break
            try:   # the checks of a run are bounded by its time limit too (in_time)
                again = self.retry(model, s, times, auto, failure, *((None, None) if failure else (Q, QD))) \
                    if attempt == 1 and auto else None
                if not again and failure is None and "dt" in auto and self.order:
                    again = self.refine(model, s, times, Q, QD, state, last=attempt == 1 + MAX_REFINEMENTS,
                                        first=not state.get("rated"))
                    state["rated"] = True
                    if again:
                        kept = (Q, QD, dict(s), state["estimate"])
            except OutOfTime as e:
                failure = e
                break
            if not again:
                break
            because, change = again
            s.update(change)
            self.resolve(model, s, q0, qd0)
            shown = [f"{k} = {s[k]:.6g}" if isinstance(s[k], float) else f"{k} = {s[k]}"
                     for k in change if change[k] is not None]
            notes.append(f"{because}: rerun with {', '.join(shown)} ({s['substeps']} steps per output interval); "
                         "the cost counts both attempts")
        if failure is not None:
            return finish(failure.status, " ".join(failure.detail.split()), steps=steps, wall=wall)
        if not (np.isfinite(Q).all() and np.isfinite(QD).all()):
            return finish(Status.NONFINITE, "non-finite coordinates", wall=wall, steps=steps)
        return finish(Status.OK, "", Q, QD, wall, steps)

    def refine(self, model, s, times, Q, QD, state, last=False, first=False):
        """dt = "auto": checks a run by ``self_check`` (the engine's own error
        figures, computed without native's trajectory) against the
        tolerance; above REFINE_AT of it, (why, settings) with the step that
        brings every figure to at most REFINE_TO of it (each figure ~
        dt^order, its own order when ``order`` is a dict). After the
        ``first`` completed attempt also by the rates of the run itself
        (``trajectory_rate``): a mechanism faster somewhere than at its
        start reruns at rate_step / that rate when that needs more than
        RATE_SLACK times the steps run (any more when the self-check has no
        figure: through a singular configuration); below that, the
        self-check judges the run. None when neither asks for
        more, or past the cost cap (MAX_SUBSTEPS per output interval,
        MAX_REFINEMENTS reruns): then state["capped"] when the self-check
        still exceeds the tolerance."""
        est = self_check(model, Q, QD, times)
        state["estimate"] = est
        orders = self.order if isinstance(self.order, dict) else dict.fromkeys(self.tolerance, self.order)
        ratios = [(est[k] / v, k) for k, v in self.tolerance.items() if k in est and v > 0 and orders.get(k)]
        ratio, worst = max(ratios) if ratios else (0.0, "")
        interval = float(times[1] - times[0]) if len(times) > 1 else float(model.case.end or 1.0)
        wanted = []   # (step, why)
        if ratio > REFINE_AT:
            wanted.append((s["dt"] * min((REFINE_TO / r) ** (1.0 / orders[k]) for r, k in ratios if r > REFINE_TO),
                           f"self-check: {worst} {est[worst]:.1e} is {ratio:.2g}x its limit"))
        if first and s.get("rate_step") and s.get("rate_scale") is not None:
            own = trajectory_rate(model, times, Q, QD)
            dt = min(interval, s["rate_step"] / own) if own > 0 else interval
            need = math.ceil(interval / dt * (1 - 1e-12))
            if need > s["substeps"] * (1 if not est else RATE_SLACK):
                wanted.append((dt, f"its own run's rate scale {own:.3g}/s is above its start's "
                                   f"{s['rate_scale']:.3g}/s"))
                s["rate_scale"] = own
        if not wanted:
            state["capped"] = False
            return None
        dt, why = min(wanted)
        if last or not np.isfinite(dt) or interval / dt > MAX_SUBSTEPS:
            state["capped"] = ratio > 1.0
            if not last and np.isfinite(dt) and s["substeps"] < MAX_SUBSTEPS:   # the cap itself, once
                return (f"{why}; the cap is {MAX_SUBSTEPS} steps per output interval",
                        {"dt": interval / MAX_SUBSTEPS, "substeps": None})
            return None
        return why, {"dt": dt, "substeps": None}

    def unsupported_with(self, model, q0, s) -> Reason | None:
        """``unsupported`` for these settings and start (an engine whose
        support depends on them overrides it)."""
        return self.unsupported(model)

    def simulate(self, model, q0, qd0, s, times):
        """(Q, QD, stepping seconds, steps) at the output instants ``times``
        with the checked settings s (substeps and dt resolved); raises
        Failure to stop with a status."""
        raise NotImplementedError

# -- the engines' own error check (dt = "auto") ---------------------------------

REFINE_AT = 1.0        # a self-check figure above this fraction of its limit refines the step ...
REFINE_TO = 0.7        # ... to the step that brings it to this fraction (errors ~ dt^order)
MAX_SUBSTEPS = 2000    # cost cap: engine steps per output interval
MAX_REFINEMENTS = 3    # cost cap: reruns after the first attempt
MAX_RUN_STEPS = 10**7  # given settings: engine steps in a run (native's most output intervals)
RATE_SLACK = 1.5       # a run whose own rates need more than this times its steps (rate_step / its rate
                       # scale) runs again at that step, whatever its self-check says
NEAR_SINGULAR = 1e-6   # smallest / largest singular value of the dimensionless Phi_q below which the
                       # first-order estimate means nothing (a change point: stress/change_point's
                       # estimate was 0.4 of V and refining made Exudyn stop)


CHECK_EVERY = 1024   # instants of an engine's own check (self_check) between looks at the run's time limit


def self_check(model, Q, QD, times) -> dict:
    """The errors of an engine's trajectory estimated from the constraints
    alone, without native's trajectory: a kinematically driven mechanism
    has as many constraints (drivers included) as coordinates, so at each
    output instant the position error is, to first order, dq = Phi_q^-1
    Phi(q, t) (the loop-closure and driver residual carried to the
    coordinates) and the velocity error exactly dqd = Phi_q^-1 (Phi_q qd - nu).
    Figures as adapters.compare's (bodies' origins and the named points /
    L or / the run's peak speed, angles in rad, angular velocities / the
    peak angular speed); {} when Phi_q is not square, or is singular or nearly
    so (NEAR_SINGULAR) at an output instant."""
    if Q is None or Q.shape[1] != model.n or model.m != model.n or not len(Q):
        return {}
    pts = _point_offsets(model)
    L = model.length
    dpos = dang = dvel = dw = 0.0
    vmax = wmax = 0.0
    for i, (q, qd, t) in enumerate(zip(Q, QD, times)):
        if not i % CHECK_EVERY:
            in_time(t)   # the run's time limit holds for its own checks too (a Python loop over the instants)
        J = model.jacobian(q, t, sparse=False)
        sv = np.linalg.svd(model.assemble(model.jac_values(q, t) * model.entry_scale, False), compute_uv=False)
        if not sv[-1] > NEAR_SINGULAR * sv[0]:   # through a singular configuration: no estimate, no refinement
            return {}
        try:
            dq = np.linalg.solve(J, model.phi(q, t))
            dqd = np.linalg.solve(J, J @ qd - model.nu(t))
        except np.linalg.LinAlgError:
            return {}
        for k, (b, offsets) in enumerate(pts):
            phi, w = q[3 * k + 2], qd[3 * k + 2]
            c, sn = np.cos(phi), np.sin(phi)
            for xi, eta in offsets:   # the origin is (0, 0)
                r = np.array([c * xi - sn * eta, sn * xi + c * eta])
                perp = np.array([-r[1], r[0]])
                dpos = max(dpos, float(np.hypot(*(dq[3 * k: 3 * k + 2] + perp * dq[3 * k + 2]))))
                dvel = max(dvel, float(np.hypot(*(dqd[3 * k: 3 * k + 2] + perp * dqd[3 * k + 2]))))
                vmax = max(vmax, float(np.hypot(*(qd[3 * k: 3 * k + 2] + perp * w))))
            dang = max(dang, abs(float(dq[3 * k + 2])))
            dw = max(dw, abs(float(dqd[3 * k + 2])))
            wmax = max(wmax, abs(float(w)))
    speed = max(L * wmax, vmax, 1e-300)
    return {"position_error_rel": dpos / L, "angle_error": dang, "velocity_error_rel": dvel / speed,
            "angular_velocity_error_rel": dw * L / speed}


def _point_offsets(model):
    """(body, [(0, 0) and each named point's local coordinates]) per body, in coordinate order."""
    named = {b: [(0.0, 0.0)] for b in model.body_names}
    for p in model.case.points:
        named[p.body].append(tuple(float(x) for x in p.at))
    return [(b, named[b]) for b in model.body_names]


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


START_TOLERANCE = 1e-13   # the start's assembly, as the report's reference


def start(model):
    """(q0, qd0): the model's own assembly at its first output instant (the
    position solve from the case's estimates at START_TOLERANCE, or the
    case's own tolerance when that cannot be reached, and the velocity
    solve there; kinem.tracking's, as native's first instant), from which
    every engine starts. Computed here from the model, never taken from a
    native trajectory, so that a changed native answer cannot change an
    engine's run. Raises Failure when the mechanism does not assemble."""
    from dataclasses import replace

    from kinem.analysis import Data
    from kinem.errors import AnalysisError
    from kinem.linalg import choose
    from kinem.options import Options
    from kinem.tracking import Tracker

    t0 = float(np.asarray(model.times, float)[0])
    case_options = Options.of(model.case)
    why = ""
    for options in (replace(case_options, tolerance=min(case_options.tolerance, START_TOLERANCE)), case_options):
        data = Data(q=model.q0.copy(), solver=choose(model, options))
        try:
            s = Tracker(model, data, True, False, options).start(t0)
        except AnalysisError as e:
            why = str(e)
            continue
        if s.qd is not None:
            return s.q.copy(), s.qd.copy()
        why = "singular at the start"
    raise Failure(Status.FAILED, f"no start: the assembly at t = {t0:g} failed ({why})")


def rate_scale(model, trajectory) -> float:
    """The mechanism's fastest rate (1/s) in a ``trajectory`` with
    velocities and accelerations: the largest of |omega|, sqrt(|alpha|),
    |d alpha/dt|^(1/3) over the bodies and sqrt(|a| / L), (|da/dt| / L)^(1/3)
    over the bodies and named points (L the characteristic length; the
    derivatives of the accelerations by differences over its instants). A
    time-stepper's errors scale as (rate x step)^2 for a second-order
    scheme, so a step rate_step / rate_scale gives mechanisms of every speed
    the same error class (docs/engines.md)."""
    tr, L = trajectory, model.length
    t = np.asarray(tr.t, float)
    cols = set(tr.columns)

    def slope(y):
        return np.abs(np.gradient(y, t)) if len(t) > 2 else np.zeros(1)

    rates = [0.0]
    for b in model.body_names:
        if f"{b}.omega" in cols:
            rates.append(np.abs(tr[f"{b}.omega"]).max())
        if f"{b}.alpha" in cols:
            rates += [np.sqrt(np.abs(tr[f"{b}.alpha"]).max()), np.cbrt(slope(tr[f"{b}.alpha"]).max())]
    for p in list(model.body_names) + list(model.point_names):
        if f"{p}.ax" in cols:
            a = tr[f"{p}.ax"] + 1j * tr[f"{p}.ay"]
            rates += [np.sqrt(np.abs(a).max() / L), np.cbrt(slope(a).max() / L)]
    return float(max(rates))


def start_rate(model, q0, qd0) -> float:
    """``rate_scale`` at the start (q0, qd0) alone: the accelerations there
    from Phi_q qdd = gamma (least squares when Phi_q is not square)."""
    from kinem.result import trajectory

    t0 = float(np.asarray(model.times, float)[0])
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    J = model.jacobian(q0, t0, sparse=False)
    qdd = np.linalg.lstsq(J, model.gamma(q0, qd0, t0), rcond=None)[0]
    if not np.isfinite(qdd).all():
        qdd = np.zeros_like(q0)
    return rate_scale(model, trajectory(model, [t0], q0[None], qd0[None], qdd[None]))


def trajectory_rate(model, times, Q, QD) -> float:
    """``rate_scale`` of an engine's own run: its velocities, and its
    accelerations by differences of them over the output instants."""
    from kinem.result import trajectory

    times = np.asarray(times, float)[:len(Q)]
    QDD = np.gradient(QD, times, axis=0) if len(times) > 1 else np.zeros_like(QD)
    return rate_scale(model, trajectory(model, times, Q, QD, QDD))


def drive_table(functions, t, order):
    """d^(order) of each driving function (kinem.functions specs) at the
    instants t: (len(t), len(functions)), one FunctionSet call."""
    if not len(functions):
        return np.zeros((len(t), 0))
    return np.asarray(FunctionSet(list(functions))(np.asarray(t, float), order)).reshape(len(t), len(functions))
