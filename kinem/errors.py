"""One root for every error kinem raises on purpose.

``InputError`` (exit code 2) is a problem with what the user gave: a case file,
a command-line value, an argument. ``AnalysisError`` (exit code 1) is an analysis that
could not finish: no Newton convergence, a singular Jacobian, a work or time
limit. ``CoreError`` (exit code 3) is a fault of kinem itself.
"""


class KinemError(Exception):
    """Root of all kinem errors."""


class KinemWarning(UserWarning):
    """Input that is valid but looks like a mistake (a crank speed that
    looks like degrees per second given as radians); the command line prints
    each as one line, ``kinem: warning: ...``."""


class InputError(KinemError):
    """Bad input. ``problems`` lists every problem found, each a one-line text
    that names the file, the place (constraint, body, section) and the key, and
    says what was expected; one root cause is one problem. The message is the
    first SHOWN of them and " (and N more)": one line, of bounded length."""

    SHOWN = 3

    def __init__(self, problems):
        if isinstance(problems, str):
            problems = [problems]
        self.problems = tuple(one_line(p) for p in problems)
        super().__init__(self.summary())

    def summary(self, hint: str = "") -> str:
        """The first SHOWN problems and " (and N more)", with ``hint`` after N."""
        more = len(self.problems) - self.SHOWN
        tail = f" (and {more} more{'; ' + hint if hint else ''})" if more > 0 else ""
        return "; ".join(self.problems[:self.SHOWN]) + tail


MAX_LINE = 500  # characters of one problem; longer ones end in "..."


def one_line(text) -> str:
    """Text as one line of printable characters (control characters escaped),
    at most MAX_LINE long."""
    text = str(text)
    if not text.isprintable():
        text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return text if len(text) <= MAX_LINE else text[:MAX_LINE - 3] + "..."


class UnknownColumn(InputError, KeyError):
    """A trajectory has no column of that name (a KeyError too: the
    mapping's own error)."""

    def __str__(self):
        return self.summary()


class AnalysisError(KinemError):
    """An analysis that could not finish."""


class OutputError(KinemError):
    """An output that could not be written (disk full, broken pipe): exit code 1.
    A bad output path (a missing directory, no permission) is an InputError."""


class BrokenPipe(OutputError):
    """Standard output's reader went away (``kinem solve CASE | head``): the
    command line ends quietly with exit code 141 (128 + SIGPIPE), as a Unix
    tool that SIGPIPE stops."""


class ConvergenceError(AnalysisError):
    """Newton-Raphson did not reach the tolerance."""


class SingularError(AnalysisError):
    """The constraint Jacobian is (numerically) singular."""


class WorkLimitError(AnalysisError):
    """A run needs more step attempts than its limit (Options.max_substeps,
    ``kinem solve --max-work``) or more time (Options.max_seconds,
    ``--max-seconds``): kinem.budget. ``instant``: the first output instant
    not solved (None: the one being stepped to)."""

    def __init__(self, message, instant=None):
        super().__init__(message)
        self.instant = instant


class OutOfTimeError(WorkLimitError):
    """The run's time limit (Options.max_seconds, ``--max-seconds``) is
    reached: a SolveResult's status OUT_OF_TIME."""


class CoreError(KinemError):
    """A fault inside the compiled core (kinem._core): a panic or an
    inconsistent table. Not a verdict on the analysis (never reported as a
    numerical failure nor retried with a smaller step): ``kinem`` reports
    it as an internal error with its message (exit code 3), never an abort."""
