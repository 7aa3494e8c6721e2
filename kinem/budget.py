"""The work bound of one solve (docs/solver.md, "Work and time limits"):
every step attempt the tracker makes beyond one per output interval
(accepted sub-steps and rejected attempts alike) and every least-squares
(Gauss-Newton) step counts against ``Options.max_substeps``; the wall clock
against ``Options.max_seconds``. Past either, the run ends with a
WorkLimitError whose one line names what consumed the budget: the fastest
driver's rate and the step it needs, or the instant where steps keep being
rejected, or the march's pace over many instants."""
import math
import time

from .errors import InputError, OutOfTimeError, WorkLimitError
from .rates import fastest_driver

# Numbers a result held whole in memory may have (float64: 1.6 GB): a sweep's table, a batch of variants,
# a trajectory's sensitivities. Beyond, numpy's MemoryError (an internal error) or the machine's memory
# gone; kinem solve streams its trajectory instead (--max-work bounds its time).
MAX_HELD = 2e8


def check_held(numbers, source, what, fewer) -> None:
    """An InputError naming ``what`` (its sizes, multiplied) and what to make ``fewer``
    when a result of ``numbers`` numbers would be held in memory beyond MAX_HELD."""
    if numbers > MAX_HELD:
        raise InputError(f"{source}: {what} = {numbers:.3g} numbers exceeds the {MAX_HELD:.3g} a result held in "
                         f"memory may have ({MAX_HELD * 8 / 1e9:.1f} GB); expected {fewer}")


def check_solutions(model, sources, command, fewer) -> None:
    """check_held for ``sources`` whole solutions of ``model`` (positions,
    velocities and accelerations at every instant: native's and each
    engine's, as ``command`` holds them)."""
    K = len(model.times)
    check_held(3 * K * model.n * sources, model.case.source, f"{command}: {K:,} instants x {model.n} coordinates x 3 "
               f"(positions, velocities, accelerations) x {sources} solution(s)", fewer)


def out_of_time(seconds) -> str:
    """The time limit's words: native's solves (Budget) and the engines' runs of compare (adapters.base)."""
    return (f"the time limit of {seconds:.3g} s (Options.max_seconds, --max-seconds of kinem solve, "
            "compare and animate) is reached")


# Rejected attempts in a row after which a run is said to be stuck at an instant.
STUCK = 10


class Budget:
    """The attempts and seconds one solve may still spend."""

    def __init__(self, model, options):
        self.model = model
        self.limit = options.max_substeps
        self.seconds = options.max_seconds
        self.start = options.started if options.started is not None else time.perf_counter()
        self.deadline = math.inf if options.max_seconds is None else self.start + options.max_seconds
        self.attempts = 0     # counted against the limit
        self.rejected = 0     # of them, rejected
        self.streak = 0       # rejected in a row
        self.step = 0.0       # the last accepted sub-step
        self.interval = (0.0, 0.0)   # the output interval being crossed: (t0, h)

    def left(self) -> float:
        """Seconds left (inf: no limit)."""
        return self.deadline - time.perf_counter()

    def begin(self, t0, h):
        """The tracker starts crossing the output interval [t0, t0 + h]."""
        self.interval = (t0, h)

    def spend(self, t, rejected=False, step=0.0):
        """One more attempt, at t (an accepted sub-step of ``step``); WorkLimitError past the limit or the time."""
        self.attempts += 1
        self.rejected += rejected
        self.streak = self.streak + 1 if rejected else 0
        self.step = step or self.step
        if self.attempts > self.limit:
            raise WorkLimitError(self.why(f"more than the limit of {self.limit:,} step attempts "
                                          "(Options.max_substeps, kinem solve --max-work)", t))
        self.check(t)

    def check(self, t):
        """OutOfTimeError (a WorkLimitError) when the time is up (at t)."""
        if time.perf_counter() > self.deadline:
            raise OutOfTimeError(self.why(self.out_of_time(), t))

    def out_of_time(self) -> str:
        return out_of_time(self.seconds)

    def why(self, what, t) -> str:
        """What consumed the budget, the run being at t."""
        if self.attempts == 0:
            return f"{what} at t = {t:.6g}"
        tally = f"{self.rejected:,} of the run's {self.attempts:,} step attempts were rejected"
        if self.streak >= STUCK:
            return (f"{what} at t = {t:.6g}: steps keep being rejected there ({self.streak:,} in a row; {tally}): "
                    "a singular configuration, or a jump the predictor cannot follow")
        t0, h = self.interval
        step = self.step or (t - t0)
        steps = math.ceil(self.model.case.end / step) if step > 0 else 0
        driver = fastest_driver(self.model, t0, t0 + h) if h > 0 else None
        fast = f"driver '{driver[0]}' moves at up to {driver[1]:.3g} {driver[2]}; " if driver else ""
        return (f"{what} at t = {t:.6g}: {fast}the output interval of {h:.3g} s needs steps of about "
                f"{step:.2g} s (--steps {steps:,} or more would need none); {tally}")

    def march_out_of_time(self, t, done, total, seconds) -> str:
        """The march stopped by the time limit at t, having taken ``done`` of ``total`` instants in ``seconds``."""
        if done <= 0:
            return f"{self.out_of_time()} at t = {t:.6g}"
        pace = seconds / done
        return (f"{self.out_of_time()} at t = {t:.6g}: the march took {done:,} of {total:,} instants at "
                f"{pace * 1e6:.3g} us each; all of them need about {pace * total:.3g} s")
