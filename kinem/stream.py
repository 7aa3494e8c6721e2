"""A long run in pieces, so that memory is bounded whatever the number of
output instants (``kinem solve``).

The output instants are cut into chunks of about CHUNK_VALUES numbers; each
chunk is one ``kinem.solve`` over its instants, started from the state the
previous chunk ended at (its last instant is the next chunk's first, solved
again from the converged state in no Newton iteration and not repeated in the
output). Each chunk's trajectory goes to ``on_chunk`` and is dropped.
A run of one chunk is exactly ``solve(model, outputs)``.
"""
import re
from dataclasses import dataclass

import numpy as np

from .outcome import Kind, Outcome

# Values (instants x columns) held per chunk: 1e6 doubles is 8 MB per array
# (trajectory, coordinates, rates, CSV text), a few of which are alive at once.
CHUNK_VALUES = 1_000_000
# Progress is shown (on a terminal) for runs of more than this many instants,
# in at least PROGRESS_UPDATES chunks.
PROGRESS_INSTANTS = 20_000
PROGRESS_UPDATES = 50


class Run(Kind):
    """How a streamed run ended (``Outcome.status``)."""
    SOLVED = ("solved", "all instants solved")
    STOPPED = ("stopped", "the analysis stopped", True)   # detail: the solver's message


@dataclass(frozen=True)
class Progress:
    """A streamed run's ``Outcome.value``."""
    instants: int          # instants solved
    events: tuple          # (t, text) singular configurations passed


# A step attempt beyond one per output interval (kinem.budget: a sub-step, a rejected
# attempt, a least-squares step; in Python, about 1 ms on the slider-crank) costs about as
# much as SUBSTEP_WORK output instants of the compiled march with their output (about
# 50 us each at 12 coordinates: docs/benchmarks.md, "Long runs and output").
SUBSTEP_WORK = 100


def work(model, instants=None) -> int:
    """The estimated work of a run before it starts: output instants x coordinates."""
    return (model.case.steps + 1 if instants is None else instants) * model.n


def substep_budget(model, limit, instants=None) -> int:
    """The step attempts a run may make within the work limit (Options.max_substeps):
    each counts as SUBSTEP_WORK output instants."""
    return max(int((limit - work(model, instants)) // (SUBSTEP_WORK * model.n)), 0)


def chunk_size(model, outputs, instants, progress=False) -> int:
    columns = 1 + (model.n + 2 * len(model.point_names)) * max(len(outputs), 1)
    size = max(1000, CHUNK_VALUES // columns)
    if progress:
        size = min(size, max(1000, -(-instants // PROGRESS_UPDATES)))
    return size


def run(model, outputs, on_chunk, trace=None, progress=None, size=None, options=None) -> Outcome:
    """An Outcome (Run, the solver's message, Progress): solves the case's output instants chunk by chunk: on_chunk(result) for
    each chunk's SolveResult (overlapping instant removed), trace(records) for
    each chunk's trace when given, progress(instants done, t) after each.
    ``options`` (default the case's): its max_substeps and max_seconds hold
    for the whole run, each chunk gets what the ones before left."""
    from dataclasses import replace

    from .options import Options
    from .solver import solve

    import time

    case = model.case
    options = Options.of(case) if options is None else options
    if options.started is None:   # the time limit holds for the whole run
        options = replace(options, started=time.perf_counter())
    left = options.max_substeps
    nt, h = case.steps + 1, case.end / case.steps
    size = size or chunk_size(model, outputs, nt)
    k, q0, events = 0, None, []
    while k < nt:
        first = max(k - 1, 0)                       # the overlap: the last instant solved
        times = np.arange(first, min(k + size, nt)) * h   # the same values as case.times
        r = solve(model, outputs, times=times, trace=trace is not None, q0=q0,
                  options=replace(options, max_substeps=left))
        left -= r.attempts
        skip = k - first
        t0 = times[0] if skip else -np.inf
        if trace is not None:
            trace([rec for rec in r.trace if rec[0] > t0])
        events += [e for e in r.events if e[0] > t0]
        done = len(r.trajectory) - skip
        if done > 0:
            on_chunk(_tail(r, skip))
        if not r.success:
            message = re.sub(r"\(instant (\d+) of \d+\)",
                             lambda m: f"(instant {int(m.group(1)) + first} of {nt - 1})", r.message, count=1)
            message = message.replace(f"limit of {max(left + r.attempts, 0):,} step attempts",
                                      f"limit of {options.max_substeps:,} step attempts", 1)
            message = _run_pace(message, options, k + max(done, 0), nt)
            return Outcome(Run.STOPPED, message, Progress(k + max(done, 0), tuple(events)))
        k += done
        q0 = r.q[-1]
        if progress is not None:
            progress(k, float(times[-1]))
    return Outcome(Run.SOLVED, value=Progress(nt, tuple(events)))


def _run_pace(message, options, solved, nt):
    """A march stopped by the run's time limit: the whole run's pace (with
    its output) instead of the last chunk's."""
    import time

    if options.max_seconds is None:
        return message
    elapsed = time.perf_counter() - options.started
    if elapsed < options.max_seconds:
        return message
    pace = elapsed / max(solved, 1)
    run = (f"the run solved {solved:,} of {nt:,} instants in {elapsed:.3g} s ({pace * 1e6:.3g} us each, with their "
           f"output); all of them need about {pace * nt:.3g} s")
    return re.sub(r"(is reached at t = \S+?)(: the march took .*)?$", lambda m: f"{m.group(1)}: {run}", message,
                  count=1)


def _tail(r, skip):
    """The result's trajectory without its first ``skip`` instants."""
    if not skip:
        return r.trajectory
    from .result import Trajectory

    tr = r.trajectory
    return Trajectory(tr.t[skip:], tr.columns, tr.data[skip:])

