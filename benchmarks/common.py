"""Shared pieces of the benchmark harness (benchmarks/run.py): the cases and
engines, ``say``, timing helpers, what-if patches, the machine description,
case loading and engine runners, and ``_plain`` for the JSON output.

Importing this module puts the repository root on sys.path (import it before
kinem and adapters)."""
import dataclasses
import gc
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import kinem  # noqa: E402

CASES = ("slider_crank", "four_bar", "quick_return_1")
from adapters import ENGINES  # noqa: E402 - the registry's engines
REFERENCE_TOLERANCE = 1e-13   # as kinem.report.runs: errors are measured against this solution
LOOSE, TIGHT = 1e-6, 1e-10    # position errors / L of the work-precision targets


def say(text=""):
    print(text, flush=True)


# -- timing -------------------------------------------------------------------------

def rounds(fns: dict, repeats: int, warm: bool = False) -> dict:
    """Runs each callable ``repeats`` times round-robin (A B C A B C ...);
    each returns (seconds, payload). Returns name -> (median seconds, all
    seconds, payload of the last run). ``warm``: each timed call right
    after an untimed one of the same callable, as in a loop of calls (the
    garbage collection between callables empties the processor's caches:
    it costs a 64-instant slider-crank solve 0.5 ms more, measured)."""
    times = {k: [] for k in fns}
    last = {}
    for _ in range(max(1, repeats)):
        for k, fn in fns.items():
            gc.collect()
            if warm:
                fn()
            seconds, last[k] = fn()
            times[k].append(seconds)
    return {k: (statistics.median(v), v, last[k]) for k, v in times.items()}


def load() -> str:
    """The load average (1, 5, 15 minutes) as the benchmarks print it."""
    return " ".join(open("/proc/loadavg").read().split()[:3]) if os.path.exists("/proc/loadavg") else "n/a"


def timed(fn):
    """fn as a ``rounds`` callable: () -> (seconds, fn's result)."""
    def run():
        start = time.perf_counter()
        out = fn()
        return time.perf_counter() - start, out
    return run


FIXED_INSTANTS = (64, 128, 256, 512, 1024)


def fixed_cost(case, repeats: int) -> dict:
    """The fixed cost of a solve: the least-squares intercept of the whole
    kinem.solve call's time over FIXED_INSTANTS output instants (each the
    median of 10 warm solves in a row, rounds interleaved) of ``case`` at
    its own step, and directly: a warm solve of 2 instants (issue 31 item
    6's measure; the intercept moves with the per-instant slope's fit);
    prints the times and the fit."""
    def loop_of_solves(model, count=10):
        out = []
        for _ in range(count):
            start = time.perf_counter()
            kinem.solve(model)
            out.append(time.perf_counter() - start)
        return statistics.median(out), None

    models = {K: kinem.compile(case.with_time(end=case.end * (K - 1) / case.steps, steps=K - 1))
              for K in FIXED_INSTANTS}
    for K, m in models.items():
        assert len(m.times) == K, (K, len(m.times))
        kinem.solve(m)  # warm
    res = rounds({K: (lambda m=m: loop_of_solves(m)) for K, m in models.items()}, repeats)
    K = np.array(FIXED_INSTANTS, float)
    t = np.array([res[k][0] for k in FIXED_INSTANTS])
    slope, fixed = np.polyfit(K, t, 1)
    worst = float(np.abs(t - (fixed + slope * K)).max())
    say("   " + ", ".join(f"t({k}) {1e6 * res[k][0]:.0f} us" for k in FIXED_INSTANTS))
    say(f"   fit: {1e6 * fixed:.1f} us + {1e6 * slope:.3f} us per instant (largest residual {1e6 * worst:.1f} us)")
    two = kinem.compile(case.with_time(end=case.end / case.steps, steps=1))   # issue 31 item 6: 2 instants
    assert len(two.times) == 2, len(two.times)
    kinem.solve(two)  # warm
    t2 = per_call(lambda: kinem.solve(two), repeats=max(7, repeats))
    say(f"   a warm solve of 2 instants: {1e6 * t2:.1f} us (median of {max(7, repeats)} batches)")
    return {"fixed_us": 1e6 * fixed, "us_per_instant": 1e6 * slope, "fit_residual_us": 1e6 * worst,
            "t_us": {str(k): 1e6 * res[k][0] for k in FIXED_INSTANTS}, "two_instants_us": 1e6 * t2,
            "rounds": repeats}


def per_call(fn, min_time=0.1, repeats=7) -> float:
    """Median seconds per call of a fast function (batches of calls)."""
    n, t = 1, 0.0
    while True:
        start = time.perf_counter()
        for _ in range(n):
            fn()
        t = time.perf_counter() - start
        if t >= min_time / repeats or n > 10**6:
            break
        n *= 4
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        samples.append((time.perf_counter() - start) / n)
    return statistics.median(samples)


def native(model, outputs=kinem.OUTPUTS, options=None):
    """A timed native solve with ``options`` (kinem.Options; default the
    case's): (wall_time of the analysis loop, SolveResult)."""
    def run():
        r = kinem.solve(model, outputs, options=options)
        if not r.success:
            raise RuntimeError(f"{model.case.name}: {r.message}")
        return r.wall_time, r
    return run


def step_by_step(model) -> kinem.Options:
    """The options that march the model one output instant at a time (block =
    1: the march before kinem.march, and the one sparse models, modified
    Newton and traces always use), the case's other options kept."""
    return dataclasses.replace(kinem.Options.of(model.case), block=1)


def march_of(model, options=None) -> str:
    """The march ``kinem.solve(model, options=options)`` takes (default: the case's options)."""
    try:
        from kinem.march import usable
    except ImportError:  # issue 23: no numba march; the compiled core marches every model
        return "core"

    options = kinem.Options.of(model.case) if options is None else options
    return "compiled" if usable(model, False, len(model.times), options) else "step"


def per_step(result) -> float:
    """Seconds per output instant of a SolveResult (as adapters.compare.native_row)."""
    return result.wall_time / max(len(result.iterations), 1)


# -- what-if patches (benchmark process only; kinem's files are untouched) ----------------

def parity_c(perm) -> int:
    """Permutation parity with the cycle count from scipy's C connected
    components instead of kinem.model.parity's Python loop."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    p = np.asarray(perm, dtype=np.intp)
    n = len(p)
    if n < 64:
        return _PARITY[0](p)
    g = csr_matrix((np.ones(n, np.int8), p, np.arange(n + 1)), shape=(n, n))
    cycles = connected_components(g, directed=False, return_labels=False)
    return -1 if (n - cycles) % 2 else 1


_PARITY = []


class patched:
    """Context manager: set module attributes, restore them on exit."""

    def __init__(self, *triples):
        self.triples = triples

    def __enter__(self):
        self.saved = [(m, k, getattr(m, k)) for m, k, _ in self.triples]
        for m, k, v in self.triples:
            setattr(m, k, v)

    def __exit__(self, *exc):
        for m, k, v in self.saved:
            setattr(m, k, v)


def fast_parity():
    from kinem import linalg

    if not _PARITY:
        _PARITY.append(linalg.parity)
    return patched((linalg, "parity", parity_c))


def timed_with(patch_factory, run):
    def fn():
        with patch_factory():
            return run()
    return fn


# -- machine --------------------------------------------------------------------------

def machine() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for pkg in ("kinem", "numpy", "scipy", "pymunk", "mujoco", "exudyn"):
        try:
            versions[pkg] = version(pkg)
        except PackageNotFoundError:
            versions[pkg] = "not installed"
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"cpu": cpu, "cores": os.cpu_count(), "usable_cores": usable, "python": platform.python_version(),
            "implementation": platform.python_implementation(), "platform": platform.platform(),
            "packages": versions, "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


# -- cases ------------------------------------------------------------------------------

def load_case(name, cfg):
    case = kinem.load(ROOT / "cases" / f"{name}.toml")
    if cfg.case_end is not None and cfg.case_end < case.end:
        h = case.end / case.steps
        case = case.with_time(cfg.case_end, max(1, round(cfg.case_end / h)))
    return case


def reference_solution(model):
    """The model solved at REFERENCE_TOLERANCE (at the case's if that fails)."""
    r = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(model.case), tolerance=REFERENCE_TOLERANCE))
    return r if r.success else kinem.solve(model)


def adapter_of(name):
    from adapters import get

    try:
        return get(name), ""
    except Exception as e:  # noqa: BLE001 - an engine that does not import is reported, not fatal
        return None, f"{type(e).__name__}: {e}"


def engine_runner(adapter, model, ref, overrides=None):
    settings = adapter.settings({**dict(model.case.engines.get(adapter.name, {})), **(overrides or {})})

    def run():
        r = adapter.run(model, settings=settings)
        return r.wall_time, r
    return run


def _plain(v):
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v if isinstance(v, (str, int, float, bool)) or v is None else str(v)
