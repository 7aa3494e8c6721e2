"""The march (docs/solver.md, "The march"): every output instant solved by
the compiled core's loop (kinem.native.Plan.march: the predictor, the one
Newton, the acceptance test and the rate solves) while the acceptance test
passes; Python runs once per solve, and again only for an instant the loop
hands back (kinem.tracking: sub-steps, singular configurations). The same
compiled loop serves every model: nothing is generated or compiled here.
The loop polls for signals every few milliseconds (Ctrl-C raises
KeyboardInterrupt at once, whatever the number of instants) and stops at the
run's time limit (kinem.budget).
"""
import time
from functools import cached_property

import numpy as np

from . import native
from .errors import WorkLimitError
from .model import BLOCK_LIMIT
from .options import Options
from .tracking import State


def usable(model, trace: bool, instants: int, options: Options) -> bool:
    """Whether the march takes the model: square, made of independent
    diagonal blocks of at most BLOCK_LIMIT coordinates (kinem.model.Blocks: one
    block for a small model, one per variant for merged variants), or of one
    block whose rows and columns order into a narrow band (``banded``). A
    trace, modified Newton, an explicit sparse LU or ``block = 1`` ask for
    the step-by-step march (the same Newton and acceptance test, on any
    linear solver: kinem.analysis)."""
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
        self.rates = tracker.need_v
        self.settings = (float(options.tolerance), int(options.max_iterations), float(native.MAX_STEP),
                         tracker.pivot_floor, self.rates)
        self.budget = tracker.budget
        self.X, self.figures, self.ints = X, figures, ints
        n = model.n
        self.state = st = np.zeros(6 * n + 5)
        # the state: q, qd, qdd, (time, det sign), H (3 n), T (3); as advance(0) starts it, but for q
        st[3 * n], st[6 * n + 2:] = self.times[0], np.nan
        self.fresh = True

    @cached_property
    def parts(self) -> tuple:
        """The state's parts (views): q, qd, qdd, (time, det sign), H (3 n), T (3)."""
        st, n = self.state, self.model.n
        return st[:n], st[n:2 * n], st[2 * n:3 * n], st[3 * n:3 * n + 2], st[3 * n + 2:6 * n + 2], st[6 * n + 2:]

    def advance(self, k: int, q0=None) -> int:
        """Output instants from k on, from the tracker's last state (k = 0:
        assembled from q0), until one is not accepted; returns the first
        instant not taken (len(times): all)."""
        tr, st = self.tracker, self.state
        if k == 0:
            st[:self.model.n] = self.model.q0 if q0 is None else q0
            if not self.fresh:
                _, qd, qdd, last, H, T = self.parts
                qd[:] = qdd[:] = H[:] = 0.0
                last[:] = self.times[0], 0.0
                T[:] = np.nan
        else:
            q, qd, qdd, last, H, T = self.parts
            s = tr.history[-1]
            if self.rates:
                qd[:], qdd[:] = (s.qd, s.qdd) if s.qdd is not None else tr.rates(s)
            else:
                qd[:] = qdd[:] = 0.0
            times, states = tr.recent()
            T[:], H[:] = times, states.ravel()
            q[:], last[:] = s.q, (s.t, s.det)
        self.fresh = False
        ints = self.ints
        ints[-2:] = 0
        started = time.perf_counter()
        end, why = self.model.plan.march(self.times, k, st, self.settings + (float(self.budget.left()),), self.X,
                                         self.figures, ints)
        d = tr.data
        d.jacobian_evaluations += int(ints[-2])
        d.factorizations += int(ints[-1])
        if why == native.Why.OUT_OF_TIME:
            t = float(self.times[min(end, len(self.times) - 1)])
            raise WorkLimitError(self.budget.march_out_of_time(t, end - k, len(self.times) - k,
                                                               time.perf_counter() - started), instant=end)
        if end == len(self.times):
            return end  # every instant taken: the tracker carries nothing on
        Q, QD, QDD = self.X if self.rates else (self.X[0], None, None)
        residual, pivot = self.figures
        last = self.parts[3]
        for j in range(max(k, end - 3), end):
            # the loop accepts no det flip: every instant it took has the last one's sign
            tr.accept(State(float(self.times[j]), Q[j].copy(), QD[j].copy() if self.rates else None,
                            QDD[j].copy() if self.rates else None, float(pivot[j]),
                            int(last[1]), int(ints[j]), float(residual[j])))
        return end
