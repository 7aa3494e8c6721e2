"""The compiled march (docs/solver.md, "The march"): every output instant
solved in one compiled loop (kinem.loop.run) while the tracker's acceptance
test passes; Python runs once per solve, and again only for an instant
the loop hands back (kinem.tracking: sub-steps, singular configurations).

numba cannot loop over constraint families of different kernels, so each
set of families gets a module of its own: kinem/loop.py's ``run`` with
kinem.newton.settle written into it (``_run``) and its evaluators
``phi_all``, ``jac_all`` and ``gamma_all`` written out as the families'
kernel calls on their slices of the rows, written once into a
cache folder and compiled by numba with its cache on disk (a few seconds
the first time, then about 0.1 s to load in a new process); the loop's
helpers are kinem.loop's own, compiled once. The module's name
carries a hash of the sources it compiles in, so an edited kernel never
runs from a stale cache.
"""
import ast
import functools
import hashlib
import importlib.util
import os
import re
import sys
import tempfile
import weakref
from pathlib import Path

import numpy as np

from . import dense, inline, newton
from .jit import sources
from .options import Options
from .tracking import State, singular_pivot

# Fewer output instants of a 12-coordinate model go step by step: that costs
# under 20 ms, less than loading numba in a new process, about 0.4 s (there
# such runs interpret the kernels: kinem.solver.interpret). A step by step
# costs about (10 + n) x 15 us for n coordinates (measured: 5.7 ms at 300
# coordinates with SuperLU), so a larger model takes the march from
# proportionally fewer instants.
MIN_INSTANTS = 64
# Coordinates of a diagonal block above which the compiled unblocked LU loses
# to LAPACK and SuperLU step by step: measured on N-four-bar chains (one
# block), blocks are 2.9x faster at 78 coordinates, 2.2x at 186, 1.1x at 276
# and 1.7x slower at 402.
LIMIT = 200
HERE = Path(__file__).parent


def usable(model, trace: bool, instants: int, options: Options | None = None) -> bool:
    """The compiled march takes runs of at least MIN_INSTANTS output instants
    (fewer for larger models: instants x (10 + n) >= MIN_INSTANTS x 22) of
    models whose Jacobian is square and made of independent diagonal
    blocks of at most LIMIT coordinates (kinem.model.Blocks: one block for a
    small model, one per variant for merged variants), or of one block whose
    rows and columns order into a narrow band (``banded``). A trace, modified
    Newton, an explicit sparse LU or ``block = 1`` ask for the step-by-step
    march."""
    c = Options.of(model.case) if options is None else options
    if (c.block <= 1 or trace or c.jacobian_reuse or c.linear_solver == "sparse" or model.m != model.n
            or instants * (10 + model.n) < MIN_INSTANTS * (10 + 12)):
        return False
    if model.blocks.size <= LIMIT:
        return model.blocks.square
    return model.blocks.count == 1 and banded(model)


# Bandwidths kl + ku up to which a model of one block above LIMIT takes the
# banded LU (kinem.model.Band): its cost per coordinate grows as kl (kl + ku).
BAND = 32


def banded(model) -> bool:
    """Whether the march solves the model's Jacobian as a band."""
    if model.blocks.size <= LIMIT:
        return False
    b = model.band
    return b is not None and b.kl + b.ku <= BAND


_SOURCES = None
_MODULES = {}


def _folder() -> Path:
    """Where generated modules go: ``$KINEM_CACHE``, else beside kinem's own
    compiled cache, else a folder of this user's in the temporary directory;
    the first that this user owns, can write and nobody else can (the code
    and numba's caches there are run)."""
    for folder in (os.environ.get("KINEM_CACHE"), HERE / "__pycache__" / "march",
                   Path(tempfile.gettempdir()) / f"kinem-march-{os.getuid()}"):
        if folder is None:
            continue
        folder = Path(folder)
        try:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            st = folder.stat()
            if st.st_uid == os.getuid() and not st.st_mode & 0o022 and os.access(folder, os.W_OK):
                return folder
        except OSError:
            continue
    raise OSError("no folder of this user's for kinem's compiled march (set KINEM_CACHE)")


def _evaluators(forms, widths):
    """The imports of the families' kernels (inlined where they are called:
    kinem.jit.inlined), and the statements that stand for
    ``phi_all(q, E, k, A, out)``, ``jac_all(q, E, A, out)`` and
    ``gamma_all(q, qd, E, k, A, out)`` in kinem/loop.py (E = exp(i q) at the
    angle columns, kinem.constraints.base.rotations). forms: each family's three stages of
    calls (Family.march); family i's call j takes its arguments from
    A[i][j] = (args, values); widths: (rows, Jacobian entries) of each
    family. Written out in the loop, not called: passing A through a call
    costs more than the kernels' arithmetic (about 0.3 us on the
    slider-crank, measured)."""
    imports, inline, stages = [], [], {"phi_all": [], "jac_all": [], "gamma_all": []}
    r = e = 0
    for i, (stage_calls, (rows, nnz)) in enumerate(zip(forms, widths)):
        j = 0
        for name, calls, (o, width) in zip(stages, stage_calls, ((r, rows), (e, nnz), (r, rows))):
            for c in calls:
                imports.append(f"from {c.kernel.py_func.__module__} import {c.kernel.__name__} as _f{i}_{j}")
                inline.append(f"f{i}_{j} = inlined(_f{i}_{j})")
                qd = ", {qd}" if c.rates else ""
                tv = f", A[{i}][{j}][1][{{k}}:{{k}} + 1]" if c.values is not None else ""
                out = f", {{out}}[:, {o}:{o + width}]" if c.out else ""
                args = "".join(f", A[{i}][{j}][0][{a}]" for a in range(len(c.args)))
                stages[name].append(f"f{i}_{j}({{q}}{qd}, {{E}}{args}{tv}{out})")
                j += 1
        r, e = r + rows, e + nnz
    params = {"phi_all": ("q", "E", "k", "A", "out"), "jac_all": ("q", "E", "A", "out"),
              "gamma_all": ("q", "qd", "E", "k", "A", "out")}
    return sorted(set(imports)) + [""] + inline, {name: (params[name], lines) for name, lines in stages.items()}


# What kinem/loop.py's ``run`` uses besides the evaluators: the LU and solve
# helpers compiled (and cached) once in kinem.loop and called; the small
# ones called once or twice an iteration inlined, as the families' kernels
# (kinem.jit.inlined: a call costs more than their arithmetic).
CALLED = {"dense": ("assemble",), "loop": ("factorize", "lu_solve", "refine")}
INLINED = {"loop": ("lu_stats", "residual", "rotate"), "tracking": ("jump_sizes", "lagrange", "rejected")}
HELPERS = ("import numpy as np\n\nfrom kinem import dense, loop, tracking\nfrom kinem.jit import inlined, kernel\n"
           "from kinem.newton import NOT_CONVERGED, POLISH\n\n"
           + "".join(f"{name} = {module}.{name}\n" for module, names in CALLED.items() for name in names)
           + "".join(f"{name} = inlined({module}.{name})\n" for module, names in INLINED.items() for name in names))
CALL = re.compile(r"^(\s*)(phi_all|jac_all|gamma_all)\((.*)\)$", re.M)


def _write_out(loop, calls):
    """kinem/loop.py's source with each evaluator call replaced by its statements."""
    def replace(match):
        indent, name, args = match.groups()
        params, lines = calls[name]
        values = dict(zip(params, (a.strip() for a in args.split(","))))
        return "\n".join(indent + line.format(**values) for line in lines)
    return CALL.sub(replace, loop)


@functools.cache
def _run() -> str:
    """kinem/loop.py's ``run`` with kinem.newton.settle's statements in place
    of its call and loop.py's operations' in place of settle's (kinem.inline;
    the same for every set of families, so written once per process)."""
    fns = {f.name: f for f in ast.parse((HERE / "loop.py").read_text()).body if isinstance(f, ast.FunctionDef)}
    run = fns["run"]
    inline.expand(run, inline.function(newton.settle), "_s_")
    for name in ("evaluate", "factor", "correct"):
        inline.expand(run, fns[name], f"_{name}_")
    return ast.unparse(run)


def _clean(folder: Path) -> None:
    """Removes modules of other sources (an edited kinem) and their numba caches."""
    for p in list(folder.glob("march_*.py")) + list(folder.glob("__pycache__/march_*")):
        if _SOURCES not in p.name:
            try:
                p.unlink()
            except OSError:
                pass


_OF_MODEL = weakref.WeakKeyDictionary()


def program(model, forms):
    """The march module of the model's families (generated and imported
    once per process)."""
    global _SOURCES
    if model in _OF_MODEL:
        return _OF_MODEL[model]
    widths = [(f.n_rows, len(f.rows)) for f in model.families]
    imports, calls = _evaluators(forms, widths)
    key = hashlib.sha1(repr((imports, calls)).encode()).hexdigest()[:12]
    if key in _MODULES:
        _OF_MODEL[model] = _MODULES[key]
        return _MODULES[key]
    if _SOURCES is None:
        _SOURCES = sources(HERE)[:12]
    run = _write_out(_run(), calls)
    body = (f'"""Generated by kinem.march: the march of families {", ".join(type(f).__name__ for f in model.families)}'
            f' (sources {_SOURCES}). Not to be edited."""\n' + "\n".join([HELPERS] + imports) + "\n\n\n" + run + "\n")
    name = f"march_{key}_{_SOURCES}"
    folder = _folder()
    if not _MODULES:
        _clean(folder)
    path = folder / f"{name}.py"
    if not path.exists() or path.read_text() != body:
        tmp = path.with_name(f".{name}.{os.getpid()}.tmp")
        tmp.write_text(body)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(f"kinem._march.{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    _MODULES[key] = _OF_MODEL[model] = module
    return module


def prepare(model):
    """The model's march module, loaded (compiled the first time) and its
    ``run`` compiled for the model's argument types."""
    times = np.asarray(model.times[:1], float)
    forms = [f.march(times) for f in model.families]
    m = March(model, None, times, (np.empty((1, model.n)), None, None, np.empty(1, int), np.empty(1), np.empty(1)),
              forms)
    state = (model.q0.copy(), model.q0.copy(), model.q0.copy(), np.zeros(2), np.zeros((3, model.n)), np.zeros(3))
    m.module.run(times, 1, state, m.A, m.nu, m.structure, m.settings, (*m.out, m.counts))
    return m.module


def _structure(model):
    """The loop's ``structure`` (kinem.loop.run) of the model: its Jacobian's
    blocks or band and the angle columns."""
    nb = len(model.body_names)  # the angle columns: each body's phi, then the outlines' theta
    angles = np.concatenate([3 * np.arange(nb) + 2, np.arange(3 * nb, model.n)]).astype(np.intp)
    if banded(model):
        d = model.band
        return (*d.entries, model.entry_scale, d.row_pos, d.col_pos, np.empty(0, np.intp), np.ones(model.n, bool),
                d.sign, model.scale, model.col_scale, 1, model.n, d.height, d.width, (d.kl, d.ku, d.size, *d.coupling),
                angles, np.zeros((2, 1, model.n), np.uint64))
    b = model.blocks
    real = np.ones(b.count * b.size, bool)
    real[b.pad] = False
    none = np.empty(0, np.intp)
    patterns = dense.masks(*b.entries, b.pad, b.count, b.size) if b.size <= dense.MASK else \
        np.zeros((2, b.count, b.size), np.uint64)
    return (*b.entries, model.entry_scale, b.row_pos, b.col_pos, b.pad, real, b.sign, model.scale, model.col_scale,
            b.count, b.size, b.size, b.size, (-1, -1, 0, none, none), angles, patterns)


# model -> [structure, (times, rates, A, nu) of its last march, the loop's
# entry (March._entry)]: a model's next solve over the same instants (a loop
# of solves, a sweep of options) evaluates no time function again.
_PLANS = weakref.WeakKeyDictionary()
# Values kept at most (instants x equations, the size of nu; the families'
# values are fewer): a long run's (8 MB and up) are freed with its solve,
# as they cost little against it.
KEEP = 1_000_000


class March:
    """The compiled march of one solve: the model's families' arguments and
    time-function values at the output instants, and the tracker whose
    history it carries on."""

    def __init__(self, model, tracker, times, out, forms=None):
        self.model, self.tracker = model, tracker
        self.times = times = np.ascontiguousarray(times, float)
        self.rates = tracker is None or tracker.need_v
        plan = self.plan = _PLANS.get(model)
        if plan is None:
            plan = self.plan = _PLANS[model] = [_structure(model), None, None]
        self.structure, last = plan[:2]
        if (forms is None and last is not None and last[1] == self.rates and len(last[0]) == len(times)
                and (last[0] is times or np.array_equal(last[0], times))):
            _, _, self.A, self.nu = last
            self.module = program(model, None)
        else:
            forms = [f.march(times) for f in model.families] if forms is None else forms
            self.module = program(model, forms)
            empty = np.zeros((0, 0))
            self.A = tuple(tuple((c.args, empty if c.values is None else np.ascontiguousarray(c.values, float))
                                 for stage in form for c in stage) for form in forms)
            self.nu = np.ascontiguousarray(model.nu(times if self.rates else times[:1]).reshape(-1, model.m))
            if len(times) * model.m <= KEEP:
                # the model's own (read-only) instants are kept as they are: the next solve passes them again
                kept = times if times is model.times else times.copy()
                plan[1] = (kept, self.rates, self.A, self.nu)
        o = Options.of(model.case) if tracker is None else tracker.options
        self.settings = (float(o.tolerance), int(o.max_iterations), newton.MAX_STEP, singular_pivot(o.tolerance),
                         self.rates)
        Q, QD, QDD, iterations, residual, pivot = out  # QD, QDD None: not asked for; the loop needs them
        QD = np.empty_like(Q) if QD is None else QD
        QDD = np.empty_like(Q) if QDD is None else QDD
        self.out = (Q, QD, QDD, iterations, residual, pivot)
        self.counts = np.zeros(2, np.int64)

    def _entry(self, args):
        """The loop compiled for these arguments' types (compiled now if need
        be), to be called without numba's dispatch: typing the arguments'
        nested tuples costs more (about 5 us) than the call. The types are
        the model's (its families' arguments, its structure) and fixed by
        March (contiguous float arrays), so one entry serves its solves."""
        run = self.module.run.compiled()
        sig = tuple(run.typeof_pyval(a) for a in args)
        if sig not in run.overloads:
            run.compile(sig)
        self.plan[2] = run.overloads[sig].entry_point
        return self.plan[2]

    def advance(self, k: int, q0=None) -> int:
        """Output instants from k on, from the tracker's last state (k = 0:
        assembled from q0), until one is not accepted; returns the first
        instant not taken (len(times): all)."""
        tr, n = self.tracker, self.model.n
        if k == 0:
            q = np.array(self.model.q0 if q0 is None else q0, dtype=float)
            state = (q, np.zeros(n), np.zeros(n), np.array([self.times[0], 0.0]), np.zeros((3, n)), np.full(3, np.nan))
        else:
            last = tr.history[-1]
            if self.rates:
                qd, qdd = (last.qd, last.qdd) if last.qdd is not None else tr.rates(last)
            else:
                qd = qdd = np.zeros(n)
            T, H = tr.recent()
            state = (last.q.copy(), qd.copy(), qdd.copy(), np.array([last.t, last.det], float), H, T)
        self.counts[:] = 0
        args = (self.times, k, state, self.A, self.nu, self.structure, self.settings, (*self.out, self.counts))
        end, _ = (self.plan[2] or self._entry(args))(*args)
        d = tr.data
        d.jacobian_evaluations += int(self.counts[0])
        d.factorizations += int(self.counts[1])
        Q, QD, QDD, iterations, residual, pivot = self.out
        for j in range(max(k, end - 3), end):
            # the loop accepts no det flip: every instant it took has the last one's sign
            tr.accept(State(float(self.times[j]), Q[j].copy(), QD[j].copy() if self.rates else None,
                            QDD[j].copy() if self.rates else None, float(pivot[j]),
                            int(state[3][1]), int(iterations[j]), float(residual[j])))
        return end
