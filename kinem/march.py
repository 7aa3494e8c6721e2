"""The block march: several output instants solved together
(docs/solver.md, "Block march").

For a small model the cost of an instant is the Python overhead of some
forty calls on arrays of a dozen numbers, not arithmetic. So a square model
whose Jacobian's diagonal blocks are small (kinem.model.Blocks) takes its
output instants in blocks of up to ``[solver] block``: Newton-Raphson runs
on every instant of a block at once, each from the extrapolation of the last
accepted state (kinem.tracking.extrapolate), with one kernel call per
constraint family and compiled batched LUs of the diagonal blocks
(kinem.dense) per iteration. Velocities and accelerations follow in the same way.

Every instant then passes the tracker's own tests as if it had been reached
in one step from the instant before it: converged, pivot ratio above the
floor, the same sign of det(J_s), and no jump from the predictor of the
previous instant. The instants before the first that fails are accepted.
The tracker then takes that output step on its own (sub-steps, singular
configurations), and blocks resume, growing again from one instant.
"""
from dataclasses import dataclass

import numpy as np

from . import dense
from .analysis import MAX_STEP
from .linalg import PIVOT_RATIO, lu_det_sign, pivot_ratio
from .options import Options
from .tracking import State, extrapolate, jumps, rejected


START = 64
# Fewer output instants go step by step: that costs under 20 ms, less than
# loading numba in a new process, about 0.4 s (there such runs interpret the
# kernels: kinem.solver.interpret).
MIN_INSTANTS = 64
GROW_ITERATIONS = 3
SHRINK_ITERATIONS = 4
ITERATIONS = 8
# Coordinates of a diagonal block above which the compiled unblocked LU loses
# to LAPACK and SuperLU step by step: measured on N-four-bar chains (one
# block), blocks are 2.9x faster at 78 coordinates, 2.2x at 186, 1.1x at 276
# and 1.7x slower at 402.
LIMIT = 200


def usable(model, trace: bool, instants: int, options: Options | None = None) -> bool:
    """Blocks are for runs of at least MIN_INSTANTS output instants of models
    whose Jacobian is square and made of independent diagonal blocks of at
    most LIMIT coordinates (kinem.model.Blocks: one block for a small model,
    one per variant for merged variants). A trace, modified Newton or an
    explicit sparse LU ask for the step-by-step march."""
    c = Options.of(model.case) if options is None else options
    if (c.block <= 1 or trace or c.jacobian_reuse or c.linear_solver == "sparse" or model.m != model.n
            or instants < MIN_INSTANTS):
        return False
    return model.blocks.size <= LIMIT and model.blocks.square


@dataclass
class Instants:
    """Accepted instants of a block, time-major."""
    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None
    iterations: np.ndarray
    residual: np.ndarray
    pivot: np.ndarray

    def __len__(self):
        return len(self.q)


def factorize(Js, blocks):
    """LU factors of the dimensionless Jacobians of K instants, each as its
    C diagonal blocks (Js: (K * C, s, s), kinem.model.Blocks; C = 1 for a
    small model), with each instant's pivot ratio (over all its blocks) and
    sign of det, as kinem.linalg.Factor computes them, in one compiled pass
    (kinem.dense); Js is overwritten. Returns ((LU, pivots), pivot ratio
    (K,), det sign (K,))."""
    P = dense.factor(Js)
    diag = np.diagonal(Js, axis1=1, axis2=2)
    per_instant = diag.reshape(-1, blocks.count * blocks.size)
    ratio = pivot_ratio(np.delete(per_instant, blocks.pad, axis=1) if blocks.pad.size else per_instant)
    det = lu_det_sign(diag, P).reshape(-1, blocks.count).prod(axis=1) * blocks.sign
    return (Js, P), np.where(ratio < PIVOT_RATIO, 0.0, ratio), det


def solve_each(model, factors, B):
    """x[k] from Phi_q x[k] = B[k] (K, m), with the factors of the blocks of J_s."""
    b = model.blocks
    X = np.zeros((len(B), b.count * b.size))
    X[:, b.row_pos] = B / model.scale
    dense.solve(*factors, X.reshape(-1, b.size))
    return X[:, b.col_pos] * model.col_scale


# Entries of a block's Jacobians (K * C * s * s) at most: bounds the instants per block of merged variants.
MAX_ENTRIES = 2**20


class Block:
    def __init__(self, model, tracker):
        self.model, self.tracker, self.data = model, tracker, tracker.data
        self.need_v, self.need_a = tracker.need_v, tracker.need_a
        b = self.blocks = model.blocks
        self.options = tracker.options
        self.limit = max(1, min(self.options.block, MAX_ENTRIES // (b.count * b.size**2)))
        self.size = min(START, self.limit)
        # Jacobians of a block, reused: a fresh array of this size costs more in page faults than its arithmetic
        self.work = np.empty((self.limit * b.count, b.size, b.size))

    def dimensionless(self, Q, t):
        """J_s at the instants (Q, t) as their diagonal blocks (K * C, s, s),
        in the block's work array."""
        m, d, C = self.model, self.data, self.blocks.count
        d.jacobian_evaluations += len(t)
        return dense.assemble(m.jac_values(Q, t), *self.blocks.entries, m.entry_scale, self.blocks.pad,
                              self.work[:len(t) * C])

    def newton(self, Q, t):
        """Newton-Raphson on all instants at once (kinem.analysis.position);
        an instant stops iterating when it has converged. Returns (Q,
        iterations, residual, Phi at convergence, converged)."""
        m, d = self.model, self.data
        tol, max_it = self.options.tolerance, min(self.options.max_iterations, ITERATIONS)
        K = len(t)
        iterations = np.zeros(K, dtype=int)
        residual = np.full(K, np.inf)
        done = np.zeros(K, dtype=bool)
        final = np.zeros((K, m.m))
        b = self.blocks
        for it in range(max_it + 1):
            phi = m.phi(Q, t)
            active = dense.converged(phi, m.scale, tol, it, done, iterations, residual, final)
            if it == max_it or not len(active):
                break
            Js = self.dimensionless(Q[active], t[active])
            d.factorizations += len(active)
            pivots = dense.factor(Js)
            dense.newton_step(Js, pivots, phi, active, m.scale, m.col_scale, b.row_pos, b.col_pos, MAX_STEP, Q)
        return Q, iterations, residual, final, done

    def advance(self, times) -> Instants:
        """As many of the output instants ``times`` as pass the tests, from
        the tracker's last accepted state; the tracker's history moves on."""
        m, tr = self.model, self.tracker
        hist = tr.history[-3:]
        last = hist[-1]
        Q, iterations, residual, final, done = self.newton(self.start(times, hist), times)
        n = int(np.argmin(done)) if not done.all() else len(done)
        if n == 0:
            return self.empty()
        Q, t = Q[:n], times[:n]
        b = self.blocks
        factors, pivot, det = factorize(self.dimensionless(Q, t), b)
        self.data.factorizations += n
        previous = np.concatenate([[last.det], det[:-1]])
        # the tracker's test (tracking.rejected) without the jump, known only with the rates
        n = self.accepted(rejected(pivot, det, previous, False, tr.pivot_floor))
        if n == 0:
            return self.empty()
        Q, t, factors = Q[:n], t[:n], (factors[0][:n * b.count], factors[1][:n * b.count])
        Q += solve_each(m, factors, -final[:n])  # analysis.refine: one more Newton correction
        QD = QDD = None
        if self.need_v:
            # rates from the Jacobian at the corrected positions: to rounding, not to the tolerance
            factors = factorize(self.dimensionless(Q, t), b)[0]
            self.data.factorizations += n
            QD = solve_each(m, factors, m.nu(t))
            if self.need_a:
                QDD = solve_each(m, factors, m.gamma(Q, QD, t))
        n = self.accepted(rejected(pivot[:n], det[:n], previous[:n], self.jumps(hist, t, Q, QD, QDD), tr.pivot_floor))
        if n == 0:
            return self.empty()
        out = Instants(Q[:n], None if QD is None else QD[:n], None if QDD is None else QDD[:n],
                       iterations[:n], residual[:n], pivot[:n])
        for k in range(max(0, n - 3), n):
            tr.accept(State(float(t[k]), Q[k].copy(), None if QD is None else QD[k].copy(),
                            None if QDD is None else QDD[k].copy(), float(pivot[k]), int(det[k]),
                            int(iterations[k]), float(residual[k])))
        return out

    def start(self, times, hist):
        """Newton starts for the block: the tracker's predictor from the last
        state, plus the cubic Taylor term (the third derivative taken as the
        change of qdd over the last step), so that far instants start closer.
        A run that does not output accelerations gets them for this (``rates``)."""
        K, n, last = len(times), self.model.n, hist[-1]
        T = np.broadcast_to([p.t for p in hist], (K, len(hist)))
        H = np.broadcast_to([p.q for p in hist], (K, len(hist), n))
        if last.qdd is not None:
            QD, QDD = [last.qd], [p.qdd for p in hist[-2:]]
        else:
            QD, QDD = self.rates(hist[-2:])
        q, _ = extrapolate(times, T, H, np.broadcast_to(QD[-1], (K, n)), np.broadcast_to(QDD[-1], (K, n)))
        if len(hist) > 1:
            h = times - last.t
            q += (h**3 / 6)[:, None] * ((QDD[-1] - QDD[-2]) / (last.t - hist[-2].t))
        return q

    def rates(self, states):
        """Velocities and accelerations at accepted states of a run that does
        not output them, for the block's starts: without them a block's far
        instants start from a poorer extrapolation and take more iterations
        than these few solves cost."""
        m = self.model
        Q, t = np.array([s.q for s in states]), np.array([s.t for s in states])
        Js = self.dimensionless(Q, t)
        factors = (Js, dense.factor(Js))
        self.data.factorizations += len(t)
        QD = solve_each(m, factors, m.nu(t))
        return QD, solve_each(m, factors, m.gamma(Q, QD, t))

    @staticmethod
    def accepted(why) -> int:
        """How many instants pass the test, up to the first that fails."""
        return int(np.argmax(why != 0)) if why.any() else len(why)

    def jumps(self, hist, t, Q, QD, QDD):
        """Whether each instant's correction from its own predictor (from the
        instant before it) is a jump (tracking.jumps)."""
        m = self.model
        n = len(t)
        if QD is not None:
            prev_q = np.concatenate([[hist[-1].q], Q[:-1]])
            prev_qd = np.concatenate([[hist[-1].qd], QD[:-1]])
            prev_qdd = None if QDD is None else np.concatenate([[hist[-1].qdd], QDD[:-1]])
            T = np.concatenate([[hist[-1].t], t[:-1]])[:, None]
            pred, order = extrapolate(t, T, prev_q[:, None], prev_qd, prev_qdd)
        else:
            pad = 3 - len(hist)
            allT = np.concatenate([np.full(pad, np.nan), [p.t for p in hist], t])
            allQ = np.concatenate([np.zeros((pad, m.n)), [p.q for p in hist], Q])
            idx = np.arange(n)[:, None] + np.arange(3)
            pred, order = extrapolate(t, allT[idx], allQ[idx])
            prev_q = allQ[idx[:, -1]]
        jump, _, _ = jumps(m, Q, pred, prev_q, self.options.tolerance)
        return jump & (order >= 1)

    def empty(self) -> Instants:
        return Instants(np.empty((0, self.model.n)), None, None, np.empty(0, int), np.empty(0), np.empty(0))

    def next_size(self, got: Instants) -> int:
        """The next block's size: after a full block, double it while its last
        instant converged in at most GROW_ITERATIONS iterations, halve it when
        that took more than SHRINK_ITERATIONS (far instants start too far
        away to be worth solving together); after a partial one, what was
        accepted."""
        n, size = len(got), self.size
        if n < size:
            size = max(1, n)
        elif got.iterations[-1] <= GROW_ITERATIONS:
            size = min(2 * size, self.limit)
        elif got.iterations[-1] > SHRINK_ITERATIONS:
            size = max(1, size // 2)
        self.size = size
        return size
