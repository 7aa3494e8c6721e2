"""kinem solve: a case's trajectory, streamed to a file or standard output
chunk by chunk, never partial unless asked (--partial)."""
import sys

from ..errors import MAX_LINE, AnalysisError, InputError, one_line
from .args import file_format, load_model, output_list


# Work (output instants x coordinates) above which ``solve`` refuses to start
# unless --max-work raises it: a few minutes of solving and writing on one
# core (the slider-crank's 12 coordinates: about 4e6 output steps; measured
# in docs/benchmarks.md, "Long runs and output"). Memory does not limit it: output is
# streamed (kinem.stream).
MAX_WORK = 5e7
# The largest --max-work accepted: beyond, a typo (1e400 is infinite).
MOST_WORK = 1e15
# Seconds a ``kinem solve`` may take by default (--max-seconds): with the start
# and the writing, any case file is answered or refused within a minute.
MAX_SECONDS = 50.0
# The progress bar is redrawn every SHOW_SUBSTEPS sub-steps (each costs milliseconds).
SHOW_SUBSTEPS = 100



def time_limit(a) -> float:
    """--max-seconds of solve, compare and animate: MAX_SECONDS by default, else within (0, MOST_SECONDS]."""
    from ..options import MOST_SECONDS

    seconds = MAX_SECONDS if a.max_seconds is None else a.max_seconds
    if not 0 < seconds <= MOST_SECONDS:
        raise InputError(f"--max-seconds: got {seconds:g}; expected a number of seconds in (0, {MOST_SECONDS:g}]")
    return seconds


def cmd_solve(a):
    from .. import stream
    from ..output import Output, TrajectoryWriter

    import time

    from ..margins import MARGINS

    started = time.perf_counter()
    fmt = file_format(a.out, a.format)
    outputs = output_list(a.outputs, (MARGINS,))
    limit = MAX_WORK if a.max_work is None else a.max_work
    if not 1 <= limit <= MOST_WORK:   # NaN too
        raise InputError(f"--max-work: got {limit:g}; expected a number of output instants x coordinates "
                         f"from 1 to {MOST_WORK:g}")
    seconds = time_limit(a)
    model = load_model(a.case, a.end, a.steps, a.set)
    nt = model.case.steps + 1
    if stream.work(model) > limit:
        raise InputError(f"{a.case}: {nt:,} output instants x {model.n} coordinates = {stream.work(model):.3g} "
                         f"exceeds the work limit {limit:.3g}; raise it with --max-work, or fewer --steps")
    from ..solver import check_square

    check_square(model)
    bar, shown = None, [False]
    if sys.stderr.isatty():
        from ..report.progress import Progress

        bar = Progress(nt)
    long = nt > stream.PROGRESS_INSTANTS
    size = stream.chunk_size(model, outputs, nt, progress=bar is not None and long)
    with Output("-" if a.out is None else a.out) as out, _Trace(a.diagnostics) as trace:
        writer, held = None, None

        def on_chunk(traj):
            # one chunk is held back: a run that fails in its first chunk writes nothing
            # without --partial, even where writing cannot be taken back (standard output)
            nonlocal writer, held
            if held is not None:
                if writer is None:
                    writer = TrajectoryWriter(out, held.columns, fmt)
                writer.add(held.t, held.data)
            held = traj

        substeps = [0, 0]   # the run's sub-steps: in the chunks done, in this one

        def show(t):
            shown[0] = True
            count = substeps[0] + substeps[1]
            bar.show(f"t = {t:.6g} of {model.case.end:.6g}" + (f", {count:,} sub-steps" if count else ""))

        def progress(done, t):
            substeps[0], substeps[1] = substeps[0] + substeps[1], 0
            bar.done = done
            if long or shown[0]:
                show(t)

        def on_substeps(count, t):   # a run that sub-steps a lot shows its bar, whatever its instants
            substeps[1] = count
            if count % SHOW_SUBSTEPS == 0:
                show(t)

        from dataclasses import replace

        from ..options import Options

        options = replace(Options.of(model.case), max_substeps=stream.substep_budget(model, limit),
                          max_seconds=seconds, started=started, on_substeps=on_substeps if bar else None)
        try:
            o = stream.run(model, outputs, on_chunk, trace.add if trace else None,
                           progress if bar else None, size, options)
        finally:
            if bar and shown[0]:
                bar.close()
        if trace:
            trace.finish(o.value.events)
        kept = ""
        if o.success or (held is not None and (a.partial or writer is not None and out.in_place)):
            on_chunk(None)
            writer.finish(None if o.success else o.detail)   # a failed run's instants: marked partial
            out.commit()
            if o.success:
                return 0
            kept = f"; the {o.value.instants} instants solved are in {a.out or 'standard output'}, marked partial"
    # the note on the instants kept survives the one-line cap: the solver's message is shortened instead
    room = MAX_LINE - len("kinem: analysis failed: ") - len(f"{a.case}: ") - len(kept)
    message = one_line(o.detail)
    if len(message) > room:
        message = message[:max(room - 3, 0)] + "..."
    raise AnalysisError(f"{a.case}: {message}{kept}")


class _Trace:
    """--diagnostics: the full trace as CSV, every Newton iteration, rejected
    sub-step and instant, then the events (singular configurations passed);
    to FILE or, with '-', standard error. Written chunk by chunk."""

    def __init__(self, target):
        self.target, self.out = target, None

    def __enter__(self):
        from ..output import Output

        if self.target is None:
            return None
        if self.target != "-":
            self.out = Output(self.target)
        self._write("t,what,iteration,scaled_residual,detail\n")
        return self

    def _write(self, text):
        if self.out is None:
            sys.stderr.write(text)
        else:
            self.out.write(text.encode())

    def add(self, records):
        self._write("".join(f"{t:.17g},{what},{it},{res:.6e},\"{str(detail).replace(chr(34), chr(39))}\"\n"
                            for t, what, it, res, detail in records))

    def finish(self, events):
        self._write("".join(f"{t:.17g},event,,,\"{text.replace(chr(34), chr(39))}\"\n" for t, text in events))
        if self.out is not None:
            self.out.commit()

    def __exit__(self, *exc):
        if self.out is not None:
            self.out.close()
        return False
