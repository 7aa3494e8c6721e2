"""One root for every error kinem raises on purpose.

``InputError`` (exit code 2) is a problem with what the user gave: a case file,
a command-line value. ``AnalysisError`` (exit code 1) is an analysis that
could not finish: no Newton convergence, a singular Jacobian.
"""


class KinemError(Exception):
    """Root of all kinem errors."""


class InputError(KinemError):
    """Bad input. ``problems`` lists every problem found, each a one-line text
    that names the file, the place (constraint, body, section) and the key, and
    says what was expected."""

    def __init__(self, problems):
        if isinstance(problems, str):
            problems = [problems]
        self.problems = tuple(problems)
        text = self.problems[0]
        if len(self.problems) > 1:
            text += f" (and {len(self.problems) - 1} more: " + "; ".join(self.problems[1:]) + ")"
        super().__init__(text)


class AnalysisError(KinemError):
    """An analysis that could not finish."""


class OutputError(KinemError):
    """An output that could not be written (disk full, broken pipe): exit code 1.
    A bad output path (a missing directory, no permission) is an InputError."""


class ConvergenceError(AnalysisError):
    """Newton-Raphson did not reach the tolerance."""


class SingularError(AnalysisError):
    """The constraint Jacobian is (numerically) singular."""
