"""How ``kinem.solve`` solves a compiled Model: a frozen options object,
separate from the Model, so that changing a tolerance never recompiles.
The case file's [solver] section gives the defaults (``Options.of(case)``;
docs/case-format.md); docs/solver.md explains each option."""
import math
from dataclasses import dataclass, field
from typing import Callable

from . import native
from .errors import InputError

LINEAR_SOLVERS = ("auto", "dense", "sparse")
# Step attempts one run may make beyond one per output interval (kinem.budget):
# accepted sub-steps, rejected attempts and least-squares steps alike, each a
# Newton solve in Python of about 1 to 15 ms (the slider-crank with a harmonic
# driver of omega 1e2 to 1e4, measured); no case in cases/ needs any.
MAX_SUBSTEPS = 100_000
# The largest limits accepted: beyond them a limit is a typo, not a wish.
MOST_SUBSTEPS = 10**12
MOST_SECONDS = 1e7        # about four months
MOST_ITERATIONS = 10_000
MOST_BLOCK = 2**31 - 1


def singular_pivot(tolerance: float) -> float:
    """Pivot ratio of J_s below which a state is too near a singular
    configuration to trust. Newton stops within sqrt(tolerance) of a singular
    root, where the ratio is 0.4 to 0.6 sqrt(tolerance) (measured on the
    change-point cases); a regular path that only passes close to one, like
    a four-bar 1e-8 from its change point, keeps about 0.4 sqrt(margin)
    (3.9e-5 there). 1.5 sqrt(tolerance) separates the two with a factor of
    about 2.5 either way; normal configurations have 1e-2 to 1."""
    return min(1e-3, 1.5 * tolerance**0.5)


def _whole(name, value, low, high):
    """value as a whole number in [low, high], else an InputError naming the option."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and low <= value <= high \
        and math.isfinite(value) and int(value) == value   # (the range first: 10**400 has no float)
    if not ok:
        raise InputError(f"solver options: {name} {value!r:.60}; expected a whole number from {low:,} to {high:,}")


@dataclass(frozen=True)
class Options:
    tolerance: float = 1e-12       # max scaled residual |Phi_k| / scale_k of a converged position
    max_iterations: int = 25       # Newton iterations per position solve
    linear_solver: str = "auto"    # auto: dense LU up to kinem.model.DENSE_LIMIT coordinates, else sparse
    jacobian_reuse: bool = False   # modified Newton from the last instant's factorisation
    block: int = 256               # 1: step by step in Python; more: the compiled march (kinem.march)
    # step attempts beyond one per output interval a run may make (kinem.budget): past it, it fails naming
    # the drivers' rates or where steps keep being rejected
    max_substeps: int = MAX_SUBSTEPS
    max_seconds: float | None = None   # wall-clock seconds a run may take (None: no limit; kinem solve: 50)
    # on_substeps(count, t): called after each sub-step (kinem solve's progress bar)
    on_substeps: Callable | None = field(default=None, compare=False, repr=False)
    # the time.perf_counter() max_seconds counts from (None: the solve's start; kinem.stream: the run's)
    started: float | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        t = self.tolerance
        if not (isinstance(t, (int, float)) and not isinstance(t, bool) and 0 < t < 1):
            raise InputError(f"solver options: tolerance {t!r:.60}; expected a number in (0, 1)")
        _whole("max_iterations", self.max_iterations, 1, MOST_ITERATIONS)
        if self.linear_solver not in LINEAR_SOLVERS:
            raise InputError(f"solver options: linear_solver {self.linear_solver!r:.60}; expected one of "
                             f"{', '.join(LINEAR_SOLVERS)}")
        _whole("max_substeps", self.max_substeps, 0, MOST_SUBSTEPS)
        _whole("block", self.block, 1, MOST_BLOCK)
        s = self.max_seconds
        if s is not None and not (isinstance(s, (int, float)) and not isinstance(s, bool) and 0 < s <= MOST_SECONDS):
            raise InputError(f"solver options: max_seconds {s!r:.60}; expected a number of seconds in "
                             f"(0, {MOST_SECONDS:g}], or None for no limit")
        if not isinstance(self.jacobian_reuse, bool):
            raise InputError(f"solver options: jacobian_reuse {self.jacobian_reuse!r:.60}; expected True or False")
        if self.on_substeps is not None and not callable(self.on_substeps):
            raise InputError("solver options: on_substeps: expected a function (count, t) or None")
        # what the core's step is given (kinem.native: tolerance, max_iterations, max_step, pivot floor,
        # rates), without rates and with them: made once with the options (they are frozen)
        base = (float(t), int(self.max_iterations), float(native.MAX_STEP), singular_pivot(t))
        object.__setattr__(self, "step_settings", (base + (False,), base + (True,)))

    @classmethod
    def of(cls, case) -> "Options":
        """The options a case file's [solver] section asks for."""
        return cls(case.tolerance, case.max_iterations, case.linear_solver, case.jacobian_reuse, case.block)
