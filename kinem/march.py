"""The march (docs/solver.md, "The march"): every output instant solved by
the compiled core's loop (kinem.native.Plan.march: the predictor, the one
Newton, the acceptance test and the rate solves) while the acceptance test
passes; Python runs once per solve, and again only for an instant the loop
hands back (kinem.tracking: sub-steps, singular configurations). The same
compiled loop serves every model: nothing is generated or compiled here.
"""
import numpy as np

from . import native
from .model import BLOCK_LIMIT
from .options import Options
from .tracking import State, singular_pivot


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

    def __init__(self, model, tracker, times, out, options: Options):
        self.model, self.tracker = model, tracker
        self.times = np.ascontiguousarray(times, float)
        self.rates = tracker.need_v
        self.settings = (float(options.tolerance), int(options.max_iterations), float(native.MAX_STEP),
                         singular_pivot(options.tolerance), self.rates)
        Q, QD, QDD, iterations, residual, pivot = out  # QD, QDD None: not asked for; the loop needs them
        QD = np.empty_like(Q) if QD is None else QD
        QDD = np.empty_like(Q) if QDD is None else QDD
        self.out = (Q, QD, QDD, iterations, residual, pivot)
        self.counts = np.zeros(2, np.int64)

    def advance(self, k: int, q0=None) -> int:
        """Output instants from k on, from the tracker's last state (k = 0:
        assembled from q0), until one is not accepted; returns the first
        instant not taken (len(times): all)."""
        tr, n = self.tracker, self.model.n
        if k == 0:
            q = np.array(self.model.q0 if q0 is None else q0, dtype=float)
            qd, qdd = np.zeros(n), np.zeros(n)
            last, H, T = np.array([self.times[0], 0.0]), np.zeros((3, n)), np.full(3, np.nan)
        else:
            s = tr.history[-1]
            if self.rates:
                qd, qdd = (s.qd, s.qdd) if s.qdd is not None else tr.rates(s)
            else:
                qd = qdd = np.zeros(n)
            T, H = tr.recent()
            q, qd, qdd, last = s.q.copy(), np.array(qd, float), np.array(qdd, float), np.array([s.t, s.det], float)
        self.counts[:] = 0
        Q, QD, QDD, iterations, residual, pivot = self.out
        end, _ = self.model.plan.march(self.times, k, q, qd, qdd, last, H, T, *self.settings,
                                       Q, QD, QDD, iterations, residual, pivot, self.counts)
        d = tr.data
        d.jacobian_evaluations += int(self.counts[0])
        d.factorizations += int(self.counts[1])
        if end == len(self.times):
            return end  # every instant taken: the tracker carries nothing on
        for j in range(max(k, end - 3), end):
            # the loop accepts no det flip: every instant it took has the last one's sign
            tr.accept(State(float(self.times[j]), Q[j].copy(), QD[j].copy() if self.rates else None,
                            QDD[j].copy() if self.rates else None, float(pivot[j]),
                            int(last[1]), int(iterations[j]), float(residual[j])))
        return end
