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
from .errors import OutOfTimeError
from .model import BLOCK_LIMIT
from .options import Options

OUT_OF_TIME = int(native.Why.OUT_OF_TIME)


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
    """The march of one solve: the model's plan, the output instants, the
    run's state (kinem.native.MarchState, the tracker's too) and budget
    (kinem.budget.Budget)."""

    def __init__(self, model, state, budget, times, X, figures, ints, options: Options, rates: bool):
        """state: at the estimates to assemble from; X (3, K, n): Q, QD, QDD with rates (``rates``), else (1,
        K, n): Q; figures (2, K): residual and pivot ratio; ints (K + 2): Newton iterations, then the
        loop's counts of Jacobian evaluations and factorisations (Plan.march adds to them: zeros at first)."""
        self.plan, self.state, self.budget = model.plan, state, budget
        self.times = times if times.flags.c_contiguous else np.ascontiguousarray(times)
        self.settings = options.step_settings[bool(rates)]
        self.X, self.figures, self.ints = X, figures, ints

    def advance(self, k: int) -> int:
        """Output instants from k on, from the state's last accepted instant
        (k = 0: assembled from its estimates), until one is not accepted;
        returns the first instant not taken (len(times): all). The state is
        left at the last instant taken."""
        started = time.perf_counter()
        end, why = self.plan.march(self.times, k, self.state, self.settings + (self.budget.deadline - started,),
                                   self.X, self.figures, self.ints)
        if why == OUT_OF_TIME:
            t = float(self.times[min(end, len(self.times) - 1)])
            raise OutOfTimeError(self.budget.march_out_of_time(t, end - k, len(self.times) - k,
                                                               time.perf_counter() - started), instant=end)
        return end
