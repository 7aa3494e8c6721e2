"""How ``kinem.solve`` solves a compiled Model: a frozen options object,
separate from the Model, so that changing a tolerance never recompiles.
The case file's [solver] section gives the defaults (``Options.of(case)``;
docs/case-format.md); docs/solver.md explains each option."""
from dataclasses import dataclass

from .errors import InputError

LINEAR_SOLVERS = ("auto", "dense", "sparse")


@dataclass(frozen=True)
class Options:
    tolerance: float = 1e-12       # max scaled residual |Phi_k| / scale_k of a converged position
    max_iterations: int = 25       # Newton iterations per position solve
    linear_solver: str = "auto"    # auto: dense LU up to kinem.model.DENSE_LIMIT coordinates, else sparse
    jacobian_reuse: bool = False   # modified Newton from the last instant's factorisation
    block: int = 256               # 1: step by step in Python; more: the compiled march (kinem.march)

    def __post_init__(self):
        if not 0 < self.tolerance < 1:
            raise InputError(f"solver options: tolerance {self.tolerance!r}; expected a number in (0, 1)")
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise InputError(f"solver options: max_iterations {self.max_iterations!r}; expected a whole number >= 1")
        if self.linear_solver not in LINEAR_SOLVERS:
            raise InputError(f"solver options: linear_solver {self.linear_solver!r}; expected one of "
                             f"{', '.join(LINEAR_SOLVERS)}")
        if int(self.block) != self.block or self.block < 1:
            raise InputError(f"solver options: block {self.block!r}; expected a whole number >= 1")

    @classmethod
    def of(cls, case) -> "Options":
        """The options a case file's [solver] section asks for."""
        return cls(case.tolerance, case.max_iterations, case.linear_solver, case.jacobian_reuse, case.block)
