"""The march (docs/solver.md, "The march"): every output instant solved by
the compiled core's loop (kinem.native.Plan.march: the core's step at each
instant, its predictor, Newton, acceptance test and rate solves) while the
acceptance test passes; Python runs once per solve, and again only for an
instant the loop hands back (kinem.tracking: sub-steps, singular
configurations, by the same step). The loop and the tracker carry on one
state, the tracker's kinem.native.MarchState. The same compiled loop serves
every model: nothing is generated or compiled here.
The loop polls for signals every few milliseconds (Ctrl-C raises
KeyboardInterrupt at once, whatever the number of instants) and stops at the
run's time limit (kinem.budget).
"""
import time

import numpy as np

from . import native
from .errors import WorkLimitError
from .model import BLOCK_LIMIT
from .options import Options


def usable(model, trace: bool, instants: int, options: Options) -> bool:
    """Whether the march takes the model: square, made of independent
    diagonal blocks of at most BLOCK_LIMIT coordinates (kinem.model.Blocks: one
    block for a small model, one per variant for merged variants), or of one
    block whose rows and columns order into a narrow band (``banded``). A
    trace, modified Newton, an explicit sparse LU or ``block = 1`` ask for
    the step-by-step march (kinem.tracking: the same step, one call per
    instant, on Python's operations where another linear solver, a trace or
    modified Newton needs them: kinem.analysis.Steps)."""
    c = options
    if c.block <= 1 or trace or c.jacobian_reuse or c.linear_solver == "sparse" or model.m != model.n:
        return False
    return model.plan is not None


def banded(model) -> bool:
    """Whether the model's Jacobian is solved as a band (kinem.model.Band)."""
    return model.blocks.size > BLOCK_LIMIT and model.plan is not None


class March:
    """The march of one solve: the model's plan, the output instants and
    the tracker whose history it carries on."""

    def __init__(self, model, tracker, times, X, figures, ints, options: Options):
        """X (3, K, n): Q, QD, QDD with rates, else (1, K, n): Q; figures (2, K): residual and pivot ratio; ints
        (K + 2): Newton iterations, then the loop's counts (Plan.march)."""
        self.model, self.tracker = model, tracker
        self.times = np.ascontiguousarray(times, float)
        self.settings = tracker.settings
        self.budget = tracker.budget
        self.X, self.figures, self.ints = X, figures, ints

    def advance(self, k: int, q0=None) -> int:
        """Output instants from k on, from the tracker's last state (k = 0:
        assembled from q0), until one is not accepted; returns the first
        instant not taken (len(times): all). The tracker's state is left at
        the last instant taken."""
        st = self.tracker.state
        if k == 0:
            st.restart(np.asarray(self.model.q0 if q0 is None else q0, dtype=float))
        ints = self.ints
        ints[-2:] = 0
        started = time.perf_counter()
        end, why = self.model.plan.march(self.times, k, st, self.settings + (float(self.budget.left()),), self.X,
                                         self.figures, ints)
        d = self.tracker.data
        d.jacobian_evaluations += int(ints[-2])
        d.factorizations += int(ints[-1])
        if why == native.Why.OUT_OF_TIME:
            t = float(self.times[min(end, len(self.times) - 1)])
            raise WorkLimitError(self.budget.march_out_of_time(t, end - k, len(self.times) - k,
                                                               time.perf_counter() - started), instant=end)
        return end
