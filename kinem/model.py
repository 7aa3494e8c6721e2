"""compile(): a Case into an immutable Model.

The Model holds the coordinate index map (three coordinates per body, then
artificial coordinates), the constraint families with their rows, and the
Jacobian sparsity pattern, all computed once, and the compiled core
(kinem._core.Core, built from the families' tables) that evaluates Phi,
the Jacobian values, nu and gamma of all the families in one call, at one
instant (q of shape (n,), t a number) or at a batch of them (q, qd of shape
(..., n), t a number or an array of the leading shape (...)): the rows, or
Jacobian values, are on the last axis.
"""
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import native
from .constraints import REGISTRY
from .constraints.base import local_points
from .functions import FunctionTable
from .outline import OutlineTable
from .spec import Case

DENSE_LIMIT = 200  # coordinates; above this 'auto' uses the sparse LU
# Coordinates up to which a model is one diagonal block (Model.blocks), without
# looking for its connected components (the core's, Model._pattern).
ONE_BLOCK = 64
# The march (kinem.native.Plan) takes diagonal blocks of up to BLOCK_LIMIT
# coordinates (a dense LU each; up to 64 on their nonzeros), or one block
# whose rows and columns order into a band of kl + ku <= BAND_LIMIT (its cost
# per coordinate grows as kl (kl + ku)).
BLOCK_LIMIT = 200
BAND_LIMIT = 32
MASK = 64  # blocks of up to this many coordinates are factorised on their nonzeros (bit masks)


def parity(perm) -> int:
    """+1 for an even permutation, -1 for an odd one: (-1)^(n - cycles). Each
    cycle is counted at its smallest index: after k doublings, label[i] is
    the least of the 2^k indices i, perm[i], perm[perm[i]], ..."""
    p = np.asarray(perm, np.intp)
    n = len(p)
    label = np.arange(n)
    for _ in range(max(1, n.bit_length())):
        label = np.minimum(label, label[p])
        p = p[p]
    cycles = int(np.count_nonzero(label == np.arange(n)))
    return -1 if (n - cycles) % 2 else 1


class _Context:
    """What families see while compiling."""

    def __init__(self, case: Case, length: float):
        self.body_col = {b.name: 3 * k for k, b in enumerate(case.bodies)}
        self.bodies = {b.name: b for b in case.bodies}
        self.length = length
        self.n = 3 * len(case.bodies)
        self.artificial = []  # (label, estimate)

    def cols(self, names) -> np.ndarray:
        return np.array([self.body_col[n] for n in names], dtype=np.intp)

    def add_coordinates(self, labels, estimates) -> np.ndarray:
        """Appends artificial coordinates (Sec. 4.2.5); returns their columns."""
        start = self.n + len(self.artificial)
        self.artificial += list(zip(labels, estimates))
        return np.arange(start, start + len(labels), dtype=np.intp)


def characteristic_length(case: Case) -> float:
    """The mechanism's size L: the largest of the local point distances |s'|,
    the positive lengths of constraints (link lengths, radii), the outlines'
    reach (|centre| + largest s), the named
    points' distances, and the distances between body origins in the initial
    estimate. Used to scale residuals and to normalise errors."""
    values = [0.0]
    for c in case.constraints:
        for key in REGISTRY[c.type].keys:
            v = c.get(key.name)
            if v is None:
                continue
            size = key.size(v)
            if size is not None:
                values.append(size)
    values += [float(np.hypot(*p.at)) for p in case.points]
    origins = np.array([b.q[:2] for b in case.bodies])
    if len(origins) > 1:
        span = origins.max(axis=0) - origins.min(axis=0)
        values.append(float(np.hypot(*span)))
    L = max(values)
    return L if L > 1e-12 else 1.0  # nothing to measure by (or a size that would underflow its squares)


@dataclass(frozen=True)
class Blocks:
    """The Jacobian's independent diagonal blocks (connected components of
    its pattern), laid side by side: block c's k-th row (coordinate) at
    position c * size + k of a stacked vector of count * size entries.
    Smaller blocks are padded to ``size`` (pad: their unused positions).
    Variants merged into one case (kinem.batch) are one block each."""
    count: int
    size: int
    row_pos: np.ndarray   # (m,)
    col_pos: np.ndarray   # (n,)
    pad: np.ndarray       # positions with no row and no coordinate
    square: bool          # every block has as many rows as coordinates
    sign: int             # det(Phi_q) = sign * product of the blocks' dets (the rows' and columns' reordering)
    entries: tuple        # (block, row in it, column in it) of each Jacobian entry, as kinem.dense.assemble takes them


@dataclass(frozen=True)
class Band:
    """Phi_q of a large square model arranged for a banded LU (the compiled
    march, kinem.loop): the rows with a single entry (grounds, drivers of
    a coordinate) give their coordinate directly, with no fill, and the
    rest is ordered by reverse Cuthill-McKee to bandwidths kl below and ku
    above the diagonal. Positions: the reduced system's first (size of
    them), then the single-entry rows and their columns. Its matrix J (1,
    height, width): the band in LAPACK's gbtrf storage (rows 0 to 2 kl +
    ku), then the single entries' values (row ``height - 2``), then the
    values of the reduced rows' entries in single-entry columns (row
    ``height - 1``, coupling[0]: their reduced row, coupling[1]: their
    single-entry index)."""
    size: int
    kl: int
    ku: int
    height: int
    width: int
    row_pos: np.ndarray
    col_pos: np.ndarray
    sign: int
    entries: tuple
    coupling: tuple


@dataclass(frozen=True)
class Structure:
    """The structural decomposition (issue 31; kinem/core/src/decompose.rs):
    a maximum matching of the Jacobian's rows (drivers included) to its
    coordinates and the strongly connected components of the graph it
    induces order the unknowns block-triangularly: each block's
    coordinates are fixed by its rows given the earlier blocks'. ``exact``
    False (redundant, too few equations, structurally singular): the whole
    system is one block and ``kind`` says why."""
    exact: bool
    kind: str
    rank: int             # the structural rank
    blocks: tuple         # ((rows, coordinates), ...) in solve order, each a tuple of indices


@dataclass(frozen=True, eq=False)
class Model:
    case: Case
    families: tuple
    n: int                    # coordinates
    m: int                    # equations
    coordinate_names: tuple   # "<body>.x", ..., "<constraint>.theta"
    q0: np.ndarray            # initial estimate
    row_labels: tuple
    row_owner: tuple          # constraint name of each row
    driving: np.ndarray       # bool per row
    scale: np.ndarray         # residual scale per row (docs/solver.md)
    offsets: tuple            # first row of each family
    jac_rows: np.ndarray
    jac_cols: np.ndarray
    length: float             # characteristic length L
    sparse: bool
    point_names: tuple
    point_cols: np.ndarray
    point_local: np.ndarray   # complex
    artificial: tuple         # labels of artificial coordinates
    col_scale: np.ndarray     # L for x, y columns, 1 for angles: q = col_scale * (dimensionless q)
    entry_scale: np.ndarray   # per Jacobian entry: col_scale[col] / scale[row]
    _csc: tuple = field(repr=False, default=None)
    _zero: np.ndarray = field(repr=False, default=None)  # zeros (nnz,), intp
    core: native.Core = field(repr=False, default=None)  # the compiled evaluation (kinem._core)
    # separate_tables (read-only): the tables the tangents of kinem.sensitivity and kinem.variants move
    tables: tuple = field(repr=False, default=None)

    def __repr__(self) -> str:
        """One line: the case, its size and its families (not the case's whole text)."""
        kinds = ", ".join(type(f).__name__ for f in self.families)
        return (f"Model({self.case.name!r}: {len(self.case.bodies)} bodies, {self.n} coordinates, {self.m} "
                f"equations, {self.nnz} Jacobian entries; families {kinds})")

    def __reduce__(self):
        """A model pickles as its case and compiles again where it is
        loaded (a Dask worker, another process): the core's tables are built
        from the case, never shipped."""
        return compile, (self.case,)

    # -- structure ---------------------------------------------------------
    @property
    def body_names(self) -> tuple:
        return tuple(b.name for b in self.case.bodies)

    @property
    def nnz(self) -> int:
        return len(self.jac_rows)

    @cached_property
    def options(self):
        """The case file's [solver] section as Options (``Options.of(case)``,
        made once: ``solve``'s default)."""
        from .options import Options

        return Options.of(self.case)

    @cached_property
    def derived_frames(self) -> bool:
        """Whether a body's frame derives from drawn points (``Body.derived``)."""
        return any(b.derived for b in self.case.bodies)

    @cached_property
    def times(self) -> np.ndarray:
        """The case's output instants (read-only)."""
        t = self.case.times
        t.flags.writeable = False
        return t

    @cached_property
    def blocks(self) -> Blocks:
        """The diagonal blocks; a model of up to ONE_BLOCK coordinates is
        taken whole, without looking for them."""
        if self.n <= ONE_BLOCK:
            return Blocks(1, max(self.m, self.n), np.arange(self.m), np.arange(self.n), np.empty(0, np.intp),
                          self.m == self.n, 1, (self._zero, self.jac_rows, self.jac_cols))
        col_block = self._pattern[4]
        count = int(col_block.max(initial=-1)) + 1
        row_block = col_block[self.jac_cols[np.unique(self.jac_rows, return_index=True)[1]]]
        cols_in = np.bincount(col_block, minlength=count)
        rows_in = np.bincount(row_block, minlength=count)
        size = int(max(cols_in.max(), rows_in.max()))

        def positions(block):  # c * size + rank of the index within its block
            order = np.argsort(block, kind="stable")
            start = np.concatenate([[0], np.cumsum(np.bincount(block, minlength=count))[:-1]])
            pos = np.empty(len(block), np.intp)
            pos[order] = block[order] * size + np.arange(len(block)) - start[block[order]]
            return pos

        used = np.zeros(count * size, bool)
        row_pos, col_pos = positions(row_block), positions(col_block)
        used[col_pos] = True
        rows, cols = row_pos[self.jac_rows], col_pos[self.jac_cols]
        return Blocks(count, size, row_pos, col_pos, np.flatnonzero(~used), bool((cols_in == rows_in).all()),
                      parity(np.argsort(row_pos)) * parity(np.argsort(col_pos)),
                      (rows // size, rows % size, cols % size))

    @cached_property
    def structure(self) -> Structure:
        """The block-triangular decomposition (``Structure``), computed by
        the core from the pattern (drivers included)."""
        exact, kind, rank, blocks, _ = self._pattern
        return Structure(exact, kind, rank, tuple((tuple(r), tuple(c)) for r, c in blocks))

    @cached_property
    def _pattern(self) -> tuple:
        """The core's look at the Jacobian's pattern (native.Plan.blocks):
        its decomposition and the connected component of each coordinate."""
        *found, connected = native.Plan.blocks(self.m, self.n, self.jac_rows.astype(np.int64),
                                               self.jac_cols.astype(np.int64))
        return (*found, np.asarray(connected, np.intp))

    @cached_property
    def band(self) -> Band | None:
        """The banded arrangement of a square Phi_q (``Band``); None when its
        single-entry rows share a column (a structurally singular Jacobian)."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import reverse_cuthill_mckee

        m, n, rows, cols = self.m, self.n, self.jac_rows, self.jac_cols
        count = np.bincount(rows, minlength=m)
        one = np.flatnonzero(count == 1)
        entries = np.flatnonzero(count[rows] == 1)  # one per single-entry row
        single_cols = cols[entries[np.argsort(rows[entries])]]
        if m != n or len(np.unique(single_cols)) != len(one):
            return None
        ns, size = len(one), n - len(one)
        rest_r = np.setdiff1d(np.arange(m), one)
        rest_c = np.setdiff1d(np.arange(n), single_cols)
        r_idx, c_idx = -np.ones(m, np.intp), -np.ones(n, np.intp)
        r_idx[rest_r], c_idx[rest_c] = np.arange(size), np.arange(size)
        inner = (r_idx[rows] >= 0) & (c_idx[cols] >= 0)
        R, C = r_idx[rows[inner]], c_idx[cols[inner]]
        P = coo_matrix((np.ones(len(R)), (R, C)), shape=(size, size)).tocsr()
        order = reverse_cuthill_mckee((P.T @ P).tocsr(), symmetric_mode=True)
        cpos = np.empty(size, np.intp)
        cpos[order] = np.arange(size)
        first, last = np.full(size, size), np.full(size, -1)
        np.minimum.at(first, R, cpos[C])
        np.maximum.at(last, R, cpos[C])
        rpos = np.empty(size, np.intp)
        rpos[np.lexsort((last, first))] = np.arange(size)
        row_pos, col_pos = np.empty(m, np.intp), np.empty(n, np.intp)
        row_pos[rest_r], col_pos[rest_c] = rpos, cpos
        row_pos[one], col_pos[single_cols] = size + np.arange(ns), size + np.arange(ns)
        r, c = row_pos[rows], col_pos[cols]
        band = (r < size) & (c < size)
        kl = int(max(0, (r - c)[band].max(initial=0)))
        ku = int(max(0, (c - r)[band].max(initial=0)))
        height = 2 * kl + ku + 1 + 2
        couple = (r < size) & (c >= size)
        n_couple = int(couple.sum())
        J_row, J_col = np.empty(len(rows), np.intp), np.empty(len(rows), np.intp)
        J_row[band], J_col[band] = kl + ku + r[band] - c[band], c[band]
        single = r >= size
        J_row[single], J_col[single] = height - 2, r[single] - size
        J_row[couple], J_col[couple] = height - 1, np.arange(n_couple)
        width = max(size, ns, n_couple, 1)
        return Band(size, kl, ku, height, width, row_pos, col_pos,
                    parity(np.argsort(row_pos)) * parity(np.argsort(col_pos)),
                    (self._zero, J_row, J_col), (r[couple], c[couple] - size))

    @cached_property
    def plan(self):
        """The march's linear structure in the compiled core (kinem.native.Plan:
        its LU and march): J_s's diagonal blocks, or its band for a large
        chain; None for a model with neither (not square, a block above
        BLOCK_LIMIT without a narrow band): those go step by step with
        SuperLU (kinem.linalg)."""
        if self.m != self.n:
            return None
        b = self.blocks
        if b.size <= BLOCK_LIMIT:
            if not b.square:
                return None
            blk, rows, cols = b.entries
            real = np.ones(b.count * b.size, np.int64)
            real[b.pad] = 0
            masks = np.zeros((2, b.count * b.size), np.uint64)
            if b.size <= MASK:
                one = np.uint64(1)
                base = np.asarray(blk, np.int64) * b.size
                np.bitwise_or.at(masks[0], base + rows, one << np.asarray(cols, np.uint64))
                np.bitwise_or.at(masks[1], base + cols, one << np.asarray(rows, np.uint64))
                diag = np.asarray(b.pad, np.int64)
                np.bitwise_or.at(masks[0], diag, one << (diag % b.size).astype(np.uint64))
                np.bitwise_or.at(masks[1], diag, one << (diag % b.size).astype(np.uint64))
            columns = dict(pad=np.asarray(b.pad, np.int64), rows_mask=masks[0].view(np.int64),
                           cols_mask=masks[1].view(np.int64), row_pos=b.row_pos, col_pos=b.col_pos, real=real)
            shape = (False, b.count, b.size, b.size, b.size, 0, 0, b.sign)
        else:
            d = self.band if b.count == 1 else None
            if d is None or d.kl + d.ku > BAND_LIMIT:
                return None
            blk, rows, cols = d.entries
            columns = dict(couple_row=d.coupling[0], couple_col=d.coupling[1], row_pos=d.row_pos, col_pos=d.col_pos,
                           real=np.ones(self.n, np.int64))
            shape = (True, 1, d.size, d.height, d.width, d.kl, d.ku, d.sign)
        columns.update(block=blk, row=rows, col=cols, entry_scale=self.entry_scale, scale=self.scale,
                       col_scale=self.col_scale)
        columns = {k: np.ascontiguousarray(v, np.float64 if np.asarray(v).dtype.kind == "f" else np.int64)
                   for k, v in columns.items()}
        return native.Plan(self.core, *shape, columns)

    # -- evaluation ----------------------------------------------------------
    def _batch(self, q, t, qd=None):
        """Q (K, n) (and QD), T (K,) C-contiguous float64 for the core, and
        the leading shape: q (..., n) (broadcast with qd), t a number or an
        array that broadcasts with the leading shape."""
        if qd is None and isinstance(t, (float, int)) and type(q) is np.ndarray and q.ndim == 1 and q.dtype == float:
            return np.ascontiguousarray(q).reshape(1, -1), np.array((t,), dtype=float), ()  # one instant: the fast path
        q = np.asarray(q, dtype=float)
        if qd is not None:
            qd = np.asarray(qd, dtype=float)
            if qd.shape != q.shape:
                q, qd = np.broadcast_arrays(q, qd)
        t = np.asarray(t, dtype=float)
        lead = q.shape[:-1]
        if t.shape != lead:
            lead = np.broadcast_shapes(lead, t.shape)
            q = np.broadcast_to(q, lead + q.shape[-1:])
            qd = None if qd is None else np.broadcast_to(qd, lead + qd.shape[-1:])
            t = np.broadcast_to(t, lead)
        Q = np.ascontiguousarray(q.reshape(-1, self.n))
        T = np.ascontiguousarray(t.reshape(-1))
        if qd is None:
            return Q, T, lead
        return Q, np.ascontiguousarray(qd.reshape(-1, self.n)), T, lead

    def phi(self, q, t) -> np.ndarray:
        Q, T, lead = self._batch(q, t)
        return self.core.phi(Q, T).reshape(lead + (self.m,))

    def jac_values(self, q, t) -> np.ndarray:
        """Jacobian entries in the order of (jac_rows, jac_cols)."""
        Q, T, lead = self._batch(q, t)
        return self.core.jac(Q, T).reshape(lead + (self.nnz,))

    def nu(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return self.core.nu(np.ascontiguousarray(t.reshape(-1))).reshape(t.shape + (self.m,))

    def gamma(self, q, qd, t) -> np.ndarray:
        Q, QD, T, lead = self._batch(q, t, qd)
        return self.core.gamma(Q, QD, T).reshape(lead + (self.m,))

    def jacobian(self, q, t, sparse=None):
        """Phi_q as a dense array, or a scipy CSC matrix when sparse."""
        return self.assemble(self.jac_values(q, t), self.sparse if sparse is None else sparse)

    def assemble(self, values, sparse: bool):
        """The Jacobian from its values (nnz,): dense (m, n) or scipy CSC.
        A batch of values (..., nnz) assembles dense only, to (..., m, n)."""
        if sparse:
            if values.ndim > 1:
                raise ValueError("a batch of Jacobians assembles dense only")
            from scipy.sparse import csc_matrix

            order, indices, indptr = self._csc
            return csc_matrix((values[order], indices, indptr), shape=(self.m, self.n))
        values = np.asarray(values, dtype=float)
        J = np.zeros(values.shape[:-1] + (self.m, self.n))
        J[..., self.jac_rows, self.jac_cols] = values
        return J

    def scaled_residual(self, phi) -> np.ndarray:
        """|Phi| / scale, row by row (phi (m,) or a batch (..., m))."""
        return np.abs(phi) / self.scale

    def kinematic_residual(self, Q, times) -> float:
        """Max scaled residual of the kinematic (non-driving) constraints over
        the configurations Q[k] at times[k]: loop closure of a trajectory."""
        nd = ~self.driving
        K = min(len(Q), len(times))
        rows = []   # each instant's largest, as one core call per chunk of instants (one a call: 20 us an instant)
        for k in range(0, K, RESIDUAL_CHUNK):
            phi = self.phi(np.asarray(Q[k:min(k + RESIDUAL_CHUNK, K)], dtype=float),
                           np.asarray(times[k:min(k + RESIDUAL_CHUNK, K)], dtype=float))
            rows += self.scaled_residual(phi)[:, nd].max(axis=1, initial=0.0).tolist()
        return max(rows, default=0.0)   # Python's max over the instants, as before (a NaN first stays)


RESIDUAL_CHUNK = 65536   # instants of one batched residual (Model.kinematic_residual): a few MB


def core_tables(families, share: bool = True, separate=None) -> tuple:
    """The families' tables (Family.table), the model's driving functions
    and outlines (equal ones share a number unless ``share`` is False);
    their arrays taken from ``separate`` (the same families'
    ``separate_tables``) when given, not made again."""
    functions, outlines = FunctionTable(share), OutlineTable(share)
    tables = [f.table(functions, outlines) for f in families]
    if separate is None:
        return tables, functions.arrays(), outlines.arrays()
    return (tables, _taken_functions(functions.functions, separate),
            _taken_outlines(outlines.outlines, separate))


def _first_places(items, listed) -> np.ndarray:
    """Where each of ``items`` is first in ``listed`` (by identity)."""
    first = {}
    for k, x in enumerate(listed):
        first.setdefault(id(x), k)
    return np.array([first[id(x)] for x in items], np.intp)


def _runs(lo, hi) -> np.ndarray:
    """The indices lo[0] .. hi[0] - 1, lo[1] .. hi[1] - 1, ... end to end."""
    return np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]) if len(lo) else np.zeros(0, np.intp)


def _taken_functions(functions, separate) -> dict:
    """FunctionTable.arrays of ``functions`` (each numbered by the separate
    tables too) from the separate tables' arrays: the same numbers."""
    u = _first_places(functions, [x for f, _ in separate[3] for x in f])
    f = separate[1]
    lo, hi = f["start"][u], f["start"][u + 1]
    return {"kind": f["kind"][u], "start": np.concatenate([[0], np.cumsum(hi - lo)]).astype(np.int64),
            "data": f["data"][_runs(lo, hi)]}


def _taken_outlines(outlines, separate) -> dict:
    """OutlineTable.arrays of ``outlines`` from the separate tables' arrays
    (no spline fitted again): the same numbers."""
    u = _first_places(outlines, [x for _, o in separate[3] for x in o])
    o = separate[2]
    lo, hi = o["first"][u], o["last"][u] + 1
    first = np.cumsum(hi - lo) - (hi - lo)
    pieces = _runs(lo, hi)
    return {"first": first, "last": first + (hi - lo) - 1, "t0": o["t0"][u], "span": o["span"][u],
            "periodic": o["periodic"][u], "center": o["center"][u], "starts": o["starts"][pieces],
            "coef": o["coef"].reshape(-1, 4)[pieces].ravel()}


def separate_tables(families) -> tuple:
    """The families' tables with every function and outline its own number
    (so that a moved one keeps its place: kinem.sensitivity's tangents are
    taken against them), and which functions and outlines each family
    numbered: (tables, functions, outlines, numbered)."""
    functions, outlines = FunctionTable(False), OutlineTable(False)
    tables, numbered = [], []
    for f in families:
        before = len(functions.functions), len(outlines.outlines)
        tables.append(f.table(functions, outlines))
        numbered.append((tuple(functions.functions[before[0]:]), tuple(outlines.outlines[before[1]:])))
    return tuple(tables), functions.arrays(), outlines.arrays(), tuple(numbered)


def _frozen_tables(tables) -> tuple:
    """``separate_tables``' result with its arrays read-only."""
    for d in [t for _, t in tables[0]] + [tables[1], tables[2]]:
        for v in d.values():
            v.flags.writeable = False
    return tables


def core_of(families, n: int, n_bodies: int, artificial: int, separate=None) -> native.Core:
    """The compiled core of the families: their tables (functions and
    outlines from ``separate`` when given: ``core_tables``), and the
    model's angle columns (every body's phi, every artificial coordinate:
    e^{i q} of those is computed once per configuration)."""
    angles = np.concatenate([3 * np.arange(n_bodies) + 2, 3 * n_bodies + np.arange(artificial)]).astype(np.int64)
    return native.Core(n, *core_tables(families, separate=separate), angles)


def families_of(case: Case, length: float) -> tuple:
    """The case's constraint families (each over all its constraints, in
    order of first appearance) and the compiling context."""
    ctx = _Context(case, length)
    groups = {}
    for c in case.constraints:
        groups.setdefault(REGISTRY[c.type].family, []).append(c)
    return tuple(cls(cons, ctx) for cls, cons in groups.items()), ctx


def compile(case: Case) -> Model:
    """Build the immutable Model of a validated Case."""
    if not isinstance(case, Case):
        from .errors import InputError

        raise InputError(f"compile: case {type(case).__name__}: expected a kinem.Case (kinem.load(path))")
    families, ctx = families_of(case, characteristic_length(case))

    offsets, rows, cols, r = [], [], [], 0
    for f in families:
        offsets.append(r)
        rows.append(f.rows + r)
        cols.append(f.cols)
        r += f.n_rows
    jac_rows = np.concatenate(rows).astype(np.intp)
    jac_cols = np.concatenate(cols).astype(np.intp)
    n = ctx.n + len(ctx.artificial)

    names = [f"{b.name}.{k}" for b in case.bodies for k in ("x", "y", "phi")]
    names += [label for label, _ in ctx.artificial]
    q0 = np.array([v for b in case.bodies for v in b.q] + [e for _, e in ctx.artificial], dtype=float)

    sparse = n > DENSE_LIMIT  # the format Model.jacobian gives by default (the solver is solve's options')
    order = np.lexsort((jac_rows, jac_cols))
    indptr = np.searchsorted(jac_cols[order], np.arange(n + 1))
    csc = (order, jac_rows[order], indptr)

    col_scale = np.ones(n)
    col_scale[: ctx.n] = np.tile([ctx.length, ctx.length, 1.0], len(case.bodies))
    scale = np.concatenate([np.asarray(f.scale, float) for f in families])

    separate = _frozen_tables(separate_tables(families))
    model = Model(
        case=case, families=families, n=n, m=r, coordinate_names=tuple(names), q0=q0,
        row_labels=tuple(x for f in families for x in f.labels),
        row_owner=tuple(x for f in families for x in f.owner),
        driving=np.concatenate([np.asarray(f.driving, bool) for f in families]),
        scale=scale, col_scale=col_scale, entry_scale=col_scale[jac_cols] / scale[jac_rows],
        offsets=tuple(offsets), jac_rows=jac_rows, jac_cols=jac_cols, length=ctx.length, sparse=sparse,
        point_names=tuple(p.name for p in case.points),
        point_cols=ctx.cols(p.body for p in case.points),
        point_local=local_points([p.at for p in case.points]),
        artificial=tuple(label for label, _ in ctx.artificial),
        _csc=csc, _zero=np.zeros(len(jac_rows), np.intp),
        core=core_of(families, n, len(case.bodies), len(ctx.artificial), separate),
        tables=separate,
    )
    for a in (model.q0, model.driving, model.scale, model.jac_rows, model.jac_cols,
              model.point_cols, model.point_local, model.col_scale, model.entry_scale):
        a.flags.writeable = False
    return model
