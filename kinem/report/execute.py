"""Which runs the report makes and where they run.

Every case gets a main run on the native solver and on each engine (default
settings). Work-precision cases (the case file's [report] work_precision =
true, or every case with --work-precision) also get a sweep: the native solver over
NATIVE_TOLERANCES, each engine over its default time step times
``dt_factors`` (the factor 1 point is the main run), and each other family
of the engine's own accuracy knobs (adapters.tune.families: MuJoCo's and
Exudyn's integrators, pymunk's iterations) over its default time step times
``family_factors``. Runs are independent, so they go to a
process pool or a Dask cluster (kinem.parallel); an engine's sweep is
submitted only once its main run came back "ok", smallest time steps (the
longest runs) first.
"""
import dataclasses
import os
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass

from .. import parallel
from .progress import TICK
from .runs import Task, run_task, step

NATIVE_TOLERANCES = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)


@dataclass(frozen=True)
class Sweep:
    """How much work the report does. Native wall times are medians of
    ``native_repeats`` runs (they take milliseconds, so one run is noisy);
    engine runs are timed once."""
    dt_factors: tuple
    tolerances: tuple = NATIVE_TOLERANCES
    native_repeats: int = 3
    family_factors: tuple = ()   # dt factors of the other knob families (none: the defaults' family only)
    every_case: bool = False     # --work-precision: every case swept, not only those whose file asks


# two decades, 1-2-5 steps; the other knob families the coarse decade at three points, none costlier
# than the main run (their finest steps dominated the added time: Exudyn trapezoidal at 0.2 dt, 3-5x a main run)
FULL = Sweep(dt_factors=(10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.1), native_repeats=3, family_factors=(10.0, 3.0, 1.0))
QUICK = Sweep(dt_factors=(10.0, 5.0, 2.0, 1.0), native_repeats=1)  # the coarse decade, the defaults' family only


def wants_sweep(case, sweep=None) -> bool:
    """The case file's [report] work_precision = true, or --work-precision."""
    return bool(case.report.get("work_precision")) or bool(sweep and sweep.every_case)


def execute(cases, engines, sweep: Sweep, workers=None, progress=None, scheduler=None, later=0):
    """cases: (path, Case) pairs. Returns {path: [run dicts]}: the main runs
    (native first, then engines in order) and the sweep points. workers:
    local processes (None: one per core; 0 or 1: this process); scheduler: a
    Dask scheduler address to run on instead; later: runs the progress bar
    counts after these (the stress suite)."""
    main = [Task(p, "native", repeats=sweep.native_repeats) for p, _ in cases]
    main += [Task(p, e) for p, _ in cases for e in engines]
    swept = {p for p, c in cases if wants_sweep(c, sweep)}
    extra = [Task(p, "native", "tolerance", tol, sweep.native_repeats) for p in sorted(swept)
             for tol in sweep.tolerances]
    planned = {(p, e): len([f for f in sweep.dt_factors if f != 1.0]) for p in swept for e in engines}
    if progress:
        progress.total = len(main) + len(extra) + sum(planned.values()) + later
    out = {p: [] for p, _ in cases}

    def follow(task, r):
        """Sweep tasks of an engine's finished main run."""
        if task.engine == "native" or task.knob is not None or (task.path, task.engine) not in planned:
            return []
        n = planned[(task.path, task.engine)]
        dt = step(r)   # dt = "auto": the step the engine chose
        if r["outcome"] != "ok" or dt is None:
            if progress:
                progress.drop(n)
            return []
        tasks = [Task(task.path, task.engine, "dt", dt * f) for f in sorted(sweep.dt_factors) if f != 1.0]
        for family in (r.get("families") or [])[1:]:      # the first is the defaults': swept above
            tasks += [Task(task.path, task.engine, "dt", dt * f, point=tuple(sorted(dict(family, dt=dt * f).items())))
                      for f in sorted(sweep.family_factors)]
        if progress:   # the other families' points are known only now
            progress.total += len(tasks) - n
        return tasks

    def record(task, r):
        out[task.path].append(r)
        if progress:
            progress.step(_label(task))

    with parallel.executor(workers, scheduler) as pool:
        if pool is None:  # in this process (tests, debugging)
            queue = main + extra
            while queue:
                task = queue.pop(0)
                if progress:
                    progress.waiting([_label(task)])
                r = run_task(task)
                record(task, r)
                queue += follow(task, r)
            return out

        def submit(t):
            # a cluster's workers may run elsewhere: give them absolute case paths
            sent = dataclasses.replace(t, path=os.path.abspath(t.path)) if scheduler is not None else t
            running[pool.submit(run_task, sent)] = t

        running = {}
        for t in main + extra:
            submit(t)
        while running:
            done, _ = wait(running, timeout=TICK, return_when=FIRST_COMPLETED)
            if progress and not done:
                progress.waiting(_label(t) for t in list(running.values())[:parallel.workers(workers)])
            for f in done:
                task = running.pop(f)
                r = dict(f.result(), path=task.path)
                record(task, r)
                for t in follow(task, r):
                    submit(t)
    return out


def _label(task):
    family = "".join(f" {k}={v}" for k, v in task.point if k != task.knob)
    return (f"{os.path.basename(task.path)} {task.engine}" + (f" {task.knob}={task.value:.3g}" if task.knob else "")
            + family)
