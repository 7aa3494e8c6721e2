"""How ``kinem.solve`` solves a compiled Model: a frozen options object,
separate from the Model, so that changing a tolerance never recompiles.
The case file's [solver] section gives the defaults (``Options.of(case)``;
docs/case-format.md); docs/solver.md explains each option."""
from dataclasses import dataclass, field
from typing import Callable

from .errors import InputError

LINEAR_SOLVERS = ("auto", "dense", "sparse")
# Sub-steps (steps between output instants, kinem.tracking) one run may take:
# each is a Newton solve in Python, about 3 to 6 ms with its rejected tries on
# the slider-crank (a harmonic driver of omega 1e2 and 1e3, measured), so about
# 5 to 10 minutes; no case in cases/ needs any.
MAX_SUBSTEPS = 100_000


@dataclass(frozen=True)
class Options:
    tolerance: float = 1e-12       # max scaled residual |Phi_k| / scale_k of a converged position
    max_iterations: int = 25       # Newton iterations per position solve
    linear_solver: str = "auto"    # auto: dense LU up to kinem.model.DENSE_LIMIT coordinates, else sparse
    jacobian_reuse: bool = False   # modified Newton from the last instant's factorisation
    block: int = 256               # 1: step by step in Python; more: the compiled march (kinem.march)
    max_substeps: int = MAX_SUBSTEPS   # sub-steps a run may take: beyond, it fails naming the drivers' rates
    # on_substeps(count, t): called after each sub-step (kinem solve's progress bar)
    on_substeps: Callable | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        if not 0 < self.tolerance < 1:
            raise InputError(f"solver options: tolerance {self.tolerance!r}; expected a number in (0, 1)")
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise InputError(f"solver options: max_iterations {self.max_iterations!r}; expected a whole number >= 1")
        if self.linear_solver not in LINEAR_SOLVERS:
            raise InputError(f"solver options: linear_solver {self.linear_solver!r}; expected one of "
                             f"{', '.join(LINEAR_SOLVERS)}")
        if int(self.max_substeps) != self.max_substeps or self.max_substeps < 0:
            raise InputError(f"solver options: max_substeps {self.max_substeps!r}; expected a whole number >= 0")
        if int(self.block) != self.block or self.block < 1:
            raise InputError(f"solver options: block {self.block!r}; expected a whole number >= 1")

    @classmethod
    def of(cls, case) -> "Options":
        """The options a case file's [solver] section asks for."""
        return cls(case.tolerance, case.max_iterations, case.linear_solver, case.jacobian_reuse, case.block)
