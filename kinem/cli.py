"""The command line: a thin layer over the Python API.

Exit codes: 0 success, 1 analysis failure (no convergence, singular
Jacobian), 2 bad input (case file, arguments), 3 internal error. Errors are
one line on standard error, never a traceback (set KINEM_DEBUG=1 for one).
"""
import argparse
import errno
import json
import os
import sys
from pathlib import Path

from .errors import MAX_LINE, AnalysisError, BrokenPipe, CoreError, InputError, KinemError, one_line
from .result import OUTPUTS


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        command = self.prog.removeprefix("kinem").strip()   # "solve", or "" for kinem itself
        raise InputError(f"{command}: {message}" if command else message)


def _load(path, end=None, steps=None, values=None):
    from .case import check_time, load, time_options
    from .model import compile

    end, steps = time_options(end, steps)  # the rules of the case file's [time]
    case = _warned(load, path, parameters=_values(values))
    if end is not None or steps is not None:
        case = check_time(case.with_time(end, steps))
    return compile(case)


def _outputs(text, extra=()):
    items = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in items if s not in OUTPUTS + extra]
    if bad or not items:
        raise InputError(f"--outputs: got {text!r}; expected a comma-separated list of {', '.join(OUTPUTS + extra)}")
    return tuple(items)


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


def _flush():
    """Standard output flushed here, where its errors (a closed pipe, a full
    device) are reported in one line, not at interpreter exit."""
    try:
        sys.stdout.flush()
    except OSError:
        _quiet_stdout()
        raise


def _quiet_stdout():
    """After a failed write to standard output, the interpreter's own flush
    at exit would print a traceback: point the descriptor at /dev/null (dup2
    onto descriptor 1; the device is opened, never replaced)."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError):
        pass


def _standard_streams():
    """Standard descriptors closed by the caller (``>&-``, ``2>&-``) are
    reopened on /dev/null before anything else is opened, so that no output
    file takes their number: standard output read-only (printing to it fails
    with EBADF, exit code 1, where the output was to be printed there),
    standard error writable (its messages are lost, the exit code stays)."""
    for fd, flags in ((0, os.O_RDONLY), (1, os.O_RDONLY), (2, os.O_WRONLY)):
        try:
            os.fstat(fd)
            continue
        except OSError:
            pass
        new = os.open(os.devnull, flags)
        if new != fd:
            os.dup2(new, fd)
            os.close(new)
        if fd == 1:
            sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the process's standard output
        elif fd == 2:
            sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115


def _note(text):
    """Prints a note on standard output after the named output is complete
    (the file written): a closed or broken standard output does not fail the
    command."""
    try:
        print(one_line(text), flush=True)   # a path with a newline stays one line
    except (OSError, ValueError):
        _quiet_stdout()


def cmd_solve(a):
    from . import stream
    from .output import Output, TrajectoryWriter

    import time

    from .margins import MARGINS
    from .options import MOST_SECONDS

    started = time.perf_counter()
    fmt = _format(a.out, a.format)
    outputs = _outputs(a.outputs, (MARGINS,))
    limit = MAX_WORK if a.max_work is None else a.max_work
    if not 1 <= limit <= MOST_WORK:   # NaN too
        raise InputError(f"--max-work: got {limit:g}; expected a number of output instants x coordinates "
                         f"from 1 to {MOST_WORK:g}")
    seconds = MAX_SECONDS if a.max_seconds is None else a.max_seconds
    if not 0 < seconds <= MOST_SECONDS:
        raise InputError(f"--max-seconds: got {seconds:g}; expected a number of seconds in (0, {MOST_SECONDS:g}]")
    model = _load(a.case, a.end, a.steps, a.set)
    nt = model.case.steps + 1
    if stream.work(model) > limit:
        raise InputError(f"{a.case}: {nt:,} output instants x {model.n} coordinates = {stream.work(model):.3g} "
                         f"exceeds the work limit {limit:.3g}; raise it with --max-work, or fewer --steps")
    from .solver import check_square

    check_square(model)
    bar, shown = None, [False]
    if sys.stderr.isatty():
        from .report.progress import Progress

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

        from .options import Options

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


def _warned(fn, *args, **kwargs):
    """fn(...) with the KinemWarnings it gives printed as one line each on standard error."""
    import warnings

    from .errors import KinemWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", KinemWarning)
        out = fn(*args, **kwargs)
    for w in caught:
        if issubclass(w.category, KinemWarning):
            print(one_line(f"kinem: warning: {w.message}"), file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return out


def _frame_bar():
    """A frame progress bar (kinem.notebook.frame_bar) when standard error is a terminal, else None."""
    if not sys.stderr.isatty():
        return None
    from .notebook import frame_bar

    return frame_bar(1)


def _values(items) -> dict:
    """--set NAME=VALUE (repeatable) of solve and info: name -> value text
    (kinem.parameters.apply resolves the name and checks the value)."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise InputError(f"--set: got {item!r}; expected NAME=VALUE with NAME a named dimension of the "
                             "case's [parameters] or a design parameter path (kinem info CASE --parameters)")
        out[name.strip()] = value.strip()
    return out


def _set_option(p):
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="a named dimension of the case's [parameters] or a design parameter path (repeatable): "
                        "--set crank=55, --set constraints.B.si.0=0.31")


def _format(out, fmt):
    """--format, or the one --out's suffix names (csv by default); they must agree."""
    suffix = Path(out).suffix.lower().lstrip(".") if out and out != "-" else ""
    if fmt and suffix in ("csv", "npz") and suffix != fmt:
        raise InputError(f"--format {fmt} does not match --out {out}: expected a .{fmt} file name, "
                         f"or --format {suffix}")
    fmt = fmt or (suffix if suffix in ("csv", "npz") else "csv")
    if fmt == "npz" and (not out or out == "-"):
        raise InputError("--format npz needs --out FILE")
    return fmt


class _Trace:
    """--diagnostics: the full trace as CSV, every Newton iteration, rejected
    sub-step and instant, then the events (singular configurations passed);
    to FILE or, with '-', standard error. Written chunk by chunk."""

    def __init__(self, target):
        self.target, self.out = target, None

    def __enter__(self):
        from .output import Output

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


def cmd_sweep(a):
    """kinem sweep CASE --set NAME=START:STOP:COUNT ...: one table of every variant (kinem.sweep)."""
    from .output import Output
    from .sweep import parse_values, sweep

    values = {}
    for item in a.set or ():
        name, v = parse_values(item)
        if name in values:
            raise InputError(f"--set: {name!r} given twice; expected each parameter once")
        values[name] = v
    if not values:
        raise InputError("sweep: no --set; expected one or more --set NAME=START:STOP:COUNT")
    columns = [c.strip() for c in a.outputs.split(",") if c.strip()] if a.outputs is not None else None
    bar = None
    if sys.stderr.isatty():
        from .report.progress import Progress

        bar = Progress(0)
    try:
        result = _warned(sweep, a.case, values, columns, bar)
    finally:
        if bar:
            bar.close()
    with Output("-" if a.out is None else a.out) as out:
        out.write(result.csv())
        out.commit()
    failed = [k for k, e in enumerate(result.errors) if e]
    if failed:
        print(one_line(f"kinem: {len(failed)} of {len(result)} variants failed (variant {failed[0]}: "
                       f"{result.errors[failed[0]]}); their rows say why"), file=sys.stderr)
        return 1
    return 0


def cmd_info(a):
    from .info import describe, info

    if a.parameters:
        from .info import describe_parameters
        from .parameters import parameters

        listed = parameters(_load(a.case, values=a.set).case)
        print(json.dumps([p.as_dict() for p in listed], indent=2) if a.json else describe_parameters(listed))
        return 0
    if a.blocks:
        from .info import blocks_as_dict, describe_blocks

        model = _load(a.case, values=a.set)
        print(json.dumps(blocks_as_dict(model), indent=2) if a.json else describe_blocks(model))
        return 0
    i = info(_load(a.case, values=a.set))
    print(json.dumps(i.as_dict(), indent=2) if a.json else describe(i))
    if not i.assembled:  # the figures above are of the closest configuration found
        from .result import Status

        what = "assembles on a branch it excludes" if i.status is Status.WRONG_BRANCH else "does not assemble at t = 0"
        raise AnalysisError(f"{a.case}: {what}: {i.diagnosis}")
    return 0


def cmd_sensitivity(a):
    from .output import write_trajectory
    from .sensitivity import sensitivity

    fmt = _format(a.out, a.format)
    model = _load(a.case, a.end, a.steps)
    paths = [p.strip() for p in a.parameters.split(",") if p.strip()]
    s = sensitivity(model, paths, outputs=_outputs(a.outputs))
    if s.singular.any():
        print(f"kinem: warning: {a.case}: {s.message}", file=sys.stderr)
    write_trajectory(s.derivatives, "-" if a.out is None else a.out, fmt)
    return 0


def cmd_tolerance(a):
    from .output import write_trajectory
    from .tolerance import tolerance

    fmt = _format(a.out, a.format)
    model = _load(a.case, a.end, a.steps)
    outputs = [c.strip() for c in a.outputs.split(",") if c.strip()] if a.outputs else None
    progress = None
    if sys.stderr.isatty():
        from .report.progress import Progress

        bar = Progress(a.samples)

        def progress(done, total):
            bar.done = done
            bar.show(f"sample {done:,} of {total:,}")
    b = tolerance(model, samples=a.samples, outputs=outputs, seed=a.seed, progress=progress)
    write_trajectory(b.table, "-" if a.out is None else a.out, fmt)
    for c, amount, t in b.excess:
        print(f"{c}: the Monte Carlo band leaves the worst-case linear band by at most {amount:.3g} (t = {t:.6g})",
              file=sys.stderr)
    if b.rejected:
        print(f"kinem: {len(b.rejected)} of {b.samples} samples not on the nominal's branch, left out; first: "
              f"{b.rejected[0][1]}", file=sys.stderr)
    return 0


def _settings(items, dt, engines=None):
    """--set engine.key=value (repeatable) and --dt into engine -> overrides,
    checked by each engine named (or in ``engines``) with a one-line error."""
    from adapters import names, settings

    ENGINES = names()
    out = {e: {} for e in ENGINES}
    for item in items or ():
        key, sep, raw = item.partition("=")
        engine, dot, name = key.partition(".")
        if not sep or not dot or engine not in ENGINES or not name:
            raise InputError(f"--set: got {item!r}; expected ENGINE.KEY=VALUE with ENGINE one of {', '.join(ENGINES)}")
        try:
            value = json.loads(raw)
        except ValueError:
            value = raw
        out[engine][name] = value
    if dt is not None:
        if not dt > 0:
            raise InputError(f"--dt: got {dt}; expected a positive time step")
        for e in ENGINES:
            out[e].setdefault("dt", dt)
    for e in ENGINES:
        if e in (engines or ()) or any(x.partition(".")[0] == e for x in items or ()):
            settings(e, out[e], "--set" if items else "--dt")
    return out


def _engines(text, allow_empty=False) -> list:
    """--engines: a comma-separated list of native and the engines (None: all)."""
    from adapters import names

    ENGINES = names()
    if text is None:
        return ["native", *ENGINES]
    from .casefile.checks import suggest

    engines = [e.strip() for e in text.split(",") if e.strip()]
    unknown = [e for e in engines if e not in ("native",) + ENGINES]
    guess = suggest(unknown[0], ("native",) + ENGINES) if unknown else None
    if guess is not None:
        raise InputError(f"--engines: unknown engine {unknown[0]!r}; did you mean '{guess}'?")
    if unknown or not (engines or allow_empty):
        raise InputError(f"--engines: got {text!r}; expected a comma-separated list of native, {', '.join(ENGINES)}")
    return engines


def cmd_stress(a):
    from . import stress

    engines = _engines(a.engines)
    outcomes = stress.run(engines, a.quick, a.jobs, a.scheduler)
    if a.json:
        print(json.dumps([stress.as_dict(o) for o in outcomes], indent=2, default=float))
    else:
        print(stress.table(outcomes, engines))
    misses = stress.misses(outcomes, a.quick)
    for o, want in misses:
        print(f"native: {o.value.scenario}: {o.status.value} ({o.message}), expected {want.value}", file=sys.stderr)
    return 1 if misses else 0


def cmd_engines(a):
    from . import engines

    if a.tune is not None:
        return _tune(a)
    if a.update_docs:
        changed = engines.update(Path(__file__).resolve().parents[1] / "docs" / "engines.md")
        print("docs/engines.md " + ("updated" if changed else "already current"))
    else:
        print(engines.markdown(), end="")
    return 0


def _tune(a):
    """kinem engines --tune [ENGINES]: the sweep behind the default settings (adapters/tune.py)."""
    from adapters import names, tune

    engines = [e.strip() for e in a.tune.split(",") if e.strip()] if a.tune else list(names())
    unknown = [e for e in engines if e not in names()]
    if unknown:
        raise InputError(f"--tune: got {a.tune!r}; expected a comma-separated list of {', '.join(names())}")
    models = tune._models(tune.QUICK_CASES if a.quick else tune.CASES, a.quick)
    results = [tune.sweep(e, quick=a.quick, repeats=1 if a.quick else 3, models=models) for e in engines]
    if a.json:
        print(json.dumps(results, indent=2, default=float))
    else:
        print("\n\n".join(tune.text(r) for r in results))
    return 0


def cmd_export(a):
    """kinem export CASE --engine NAME --out FILE: the engine model as the harness runs it."""
    from adapters.base import Failure, start
    from adapters.export import export

    model = _load(a.case)
    try:
        q0, qd0 = start(model)   # the harness's start: the model's own assembly at the first instant
    except Failure as e:
        raise AnalysisError(f"{a.case}: no start to run the engine from: {e.detail}") from None
    settings = dict(model.case.engines.get(a.engine, {}))   # the case file's [engines.NAME] table, as the harness
    if settings:
        from adapters import case_settings

        case_settings(model, a.engine)   # checked as the harness checks it (naming the file and the key)
    text = export(model, a.engine, q0, qd0, settings)
    from .output import write_atomic

    write_atomic(a.out, lambda f: f.write(text.encode()))   # devices, FIFOs and links written through
    _note(a.out)
    return 0


def cmd_completion(a):
    """kinem completion SHELL: the tab-completion script (shtab, optional)."""
    try:
        import shtab
    except ImportError:
        raise KinemError("completion needs shtab, which is not installed: pip install shtab") from None
    print(shtab.complete(parser(), shell=a.shell), end="")
    return 0


def cmd_compare(a):
    from adapters.compare import run_case, table

    engines = _engines(a.engines)
    model = _load(a.case, a.end, a.steps)
    if a.sensitivity is not None:
        return _compare_sensitivity(a, model, engines)
    native, rows = run_case(model, engines, _settings(a.set, a.dt, engines), a.scheduler)
    if a.json:
        print(json.dumps({"case": model.case.name, "length": model.length, "unit": model.case.length_unit,
                          "engines": {r.engine: r.as_dict() for r in rows}}, indent=2, default=float))
    else:
        print(table(model.case.name, model.length, model.case.length_unit, rows))
    return 1 if any(r.verdict.fails for r in rows) else 0   # adapters.compare.Verdict: the report's rule too


def _compare_sensitivity(a, model, engines):
    """kinem compare --sensitivity: exact sensitivities against every source's
    central differences (adapters.sensitivity); exit 1 when one is outside."""
    from adapters import check_case
    from adapters.sensitivity import check, table

    check_case(model.case)
    paths = [p.strip() for p in a.sensitivity.split(",") if p.strip()] or list(model.case.report.get("sensitivity", ()))
    if not paths:
        raise InputError(f"{a.case}: --sensitivity: no parameters given and the case has no [report] sensitivity; "
                         "expected --sensitivity P[,P...]")
    _, checks = check(model, paths, engines, _settings(a.set, a.dt, engines))
    if a.json:
        print(json.dumps({"case": model.case.name, "sensitivity": [
            {"engine": c.engine, "parameter": c.parameter, "status": c.status.value, "detail": c.detail, "h": c.h,
             "figure": c.figure, "error": c.error, "limit": c.limit, "at": c.at, "ratio": c.ratio,
             "within": c.within} for c in checks]}, indent=2, default=float))
    else:
        print(table(model.case.name, checks))
    return 1 if any(c.within is False for c in checks) else 0


def cmd_report(a):
    from .report import Options, run

    engines = _engines(a.engines, allow_empty=True)  # native always runs in the report
    if a.jobs is not None and a.jobs < 0:
        raise InputError(f"--jobs: got {a.jobs}; expected 0 (no worker processes) or more")
    whole = sorted(str(p) for p in Path("cases").glob("*.toml"))
    paths = a.cases or whole
    engines = tuple(dict.fromkeys(e for e in engines if e != "native"))
    if a.stress and a.no_stress:
        raise InputError("--stress and --no-stress: give at most one")
    baseline = a.baseline
    if baseline is None:   # OUT/baseline.json when it exists
        found = Path(a.out) / "baseline.json"
        baseline = str(found) if found.is_file() else None
    elif baseline == "none":
        baseline = None
    outcome = run(Options(cases=tuple(paths), engines=engines, out=a.out,
                          baseline=baseline, update_baseline=a.update_baseline, quick=a.quick, junit=a.junit,
                          fail_on_slowdown=a.fail_on_slowdown, workers=a.jobs, scheduler=a.scheduler,
                          stress=True if a.stress else False if a.no_stress else None,
                          work_precision=a.work_precision,
                          baseline_default=a.baseline is None))
    print(outcome.detail)
    return outcome.exit_code


def cmd_diff(a):
    from .report.diff import diff

    lines, regressions = diff(a.a, a.b)
    for line in lines:
        print(line)
    print(f"kinem diff: {a.b} against {a.a}: {regressions} regression(s), {len(lines) - regressions} other line(s)"
          if lines else f"kinem diff: {a.b} against {a.a}: nothing moved")
    return 1 if regressions else 0


def cmd_animate(a):
    from .report.animate import check_output, write

    engines = [e for e in _engines(a.engines, allow_empty=True) if e != "native"]
    check_output(a.out)
    bar = _frame_bar()
    try:
        skipped = write(_load(a.case), a.out, engines, bar)
    finally:
        if bar:
            bar.close()
    for name, why in skipped.items():
        print(one_line(f"{name}: not drawn: {why}"), file=sys.stderr)
    _note(a.out)
    return 0


def parser():
    from . import __version__
    from .stream import SUBSTEP_WORK

    p = _Parser(prog="kinem", description="Planar kinematics in Cartesian coordinates (Nikravesh, Ch. 4).",
                epilog="kinem COMMAND --help for a command's options; README.md and docs/ for more.")
    p.add_argument("--version", action="version", version=f"kinem {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    s = sub.add_parser("solve", help="solve a case; write its trajectory")
    s.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    s.add_argument("--out", help="output file (default: CSV to standard output)")
    s.add_argument("--format", choices=("csv", "npz"),
                   help="csv (default; to standard output without --out) or npz (needs --out); must agree with "
                        "--out's suffix")
    s.add_argument("--outputs", default=",".join(OUTPUTS),
                   help="any of positions,velocities,accelerations,margins (margins: the smallest singular value "
                        "of the dimensionless Jacobian and the transmission angles, docs/design.md)")
    s.add_argument("--end", help="end time (overrides the case; the case file's range)")
    s.add_argument("--steps", help="number of output intervals (overrides the case; the case file's range)")
    s.add_argument("--diagnostics", nargs="?", const="-", metavar="FILE",
                   help="write the full trace (Newton iterations, rejected sub-steps, conditioning) as CSV "
                        "to FILE, or to standard error")
    _errors_option(s)
    s.add_argument("--partial", action="store_true",
                   help="when the analysis fails, still write the instants solved, marked partial "
                        "(CSV: a last line '# partial: REASON'; NPZ: arrays partial and message)")
    s.add_argument("--max-work", type=float, metavar="N",
                   help=f"refuse runs above N output instants x coordinates (default {MAX_WORK:g}); each step "
                        f"attempt beyond one per output interval counts as {SUBSTEP_WORK} instants")
    s.add_argument("--max-seconds", type=float, metavar="S",
                   help=f"stop a run after S seconds, naming what took the time (default {MAX_SECONDS:g})")
    _set_option(s)
    s.set_defaults(run=cmd_solve)

    i = sub.add_parser("info", help="coordinates, equations, Jacobian non-zeros, degrees of freedom")
    i.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    i.add_argument("--json", action="store_true", help="the same figures as JSON")
    i.add_argument("--parameters", action="store_true",
                   help="list the case's design parameters instead: path, value, unit, what it is")
    i.add_argument("--blocks", action="store_true",
                   help="the structural decomposition instead: the blocks solved in order, each its coordinates "
                        "and the constraints that close it (docs/solver.md)")
    _set_option(i)
    _errors_option(i)
    i.set_defaults(run=cmd_info)

    sw = sub.add_parser("sweep", help="solve a case over a grid of its design parameters; one table "
                                      "(variant, parameters, t, outputs)")
    sw.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    sw.add_argument("--set", action="append", metavar="NAME=START:STOP:COUNT",
                    help="a named dimension's or design parameter path's values (repeatable: every combination): "
                         "COUNT values from START to STOP, or A,B,C")
    sw.add_argument("--outputs", metavar="COLUMNS", help="comma-separated trajectory columns (default: all)")
    sw.add_argument("--out", help="output CSV file (default: standard output)")
    _errors_option(sw)
    sw.set_defaults(run=cmd_sweep)


    se = sub.add_parser("sensitivity", help="exact d/dp of every output column for design parameters p")
    se.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    se.add_argument("--parameters", required=True, metavar="P,...",
                    help="comma-separated parameter paths (kinem info CASE --parameters lists them)")
    se.add_argument("--out", help="output file (default: CSV to standard output)")
    se.add_argument("--format", choices=("csv", "npz"), help="csv (default) or npz (needs --out)")
    se.add_argument("--outputs", default=",".join(OUTPUTS), help="any of positions,velocities,accelerations")
    se.add_argument("--end", help="end time (overrides the case)")
    se.add_argument("--steps", help="number of output intervals (overrides the case)")
    se.set_defaults(run=cmd_sensitivity)

    tl = sub.add_parser("tolerance", help="tolerance bands: linear worst case, root-sum-square, Monte Carlo")
    tl.add_argument("case", help="the case file, with a [tolerances] section")
    tl.add_argument("--samples", type=int, default=1000, help="Monte Carlo samples (default 1000)")
    tl.add_argument("--outputs", help="comma-separated output columns (default: every named point's x and y)")
    tl.add_argument("--seed", type=int, default=0, help="the samples' seed (default 0)")
    tl.add_argument("--out", help="output file (default: CSV to standard output)")
    tl.add_argument("--format", choices=("csv", "npz"), help="csv (default) or npz (needs --out)")
    tl.add_argument("--end", help="end time (overrides the case)")
    tl.add_argument("--steps", help="number of output intervals (overrides the case)")
    tl.set_defaults(run=cmd_tolerance)

    st = sub.add_parser("stress", help="the stress suite on native and the engines, each outcome classified")
    st.add_argument("--engines", help="comma-separated: native and engines (default: all)")
    st.add_argument("--quick", action="store_true", help="fewer sweep points and a 100-turn long run")
    st.add_argument("--jobs", type=int, help="worker processes (default: the core count; 0 or 1: none)")
    _scheduler_option(st)
    st.add_argument("--json", action="store_true", help="every outcome as JSON instead of the table")
    st.set_defaults(run=cmd_stress)

    e = sub.add_parser("engines", help="the engines' support matrix, default settings and tolerances")
    e.add_argument("--update-docs", action="store_true", help="rewrite the generated section of docs/engines.md")
    e.add_argument("--tune", nargs="?", const="", metavar="ENGINES",
                   help="sweep the engines' own accuracy knobs on the book cases; print each setting's worst error "
                        "and cost per output interval, the Pareto front and the cheapest setting within tolerance")
    e.add_argument("--quick", action="store_true", help="with --tune: two short cases (a smoke run)")
    e.add_argument("--json", action="store_true", help="with --tune: the sweep as JSON")
    e.set_defaults(run=cmd_engines)

    x = sub.add_parser("export", help="the engine model exactly as the harness runs it, as a file "
                                      "(MuJoCo: MJCF XML; Exudyn, pymunk: a runnable Python script)")
    x.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    x.add_argument("--engine", required=True, help="mujoco, exudyn or pymunk")
    x.add_argument("--out", required=True, help="output file")
    x.set_defaults(run=cmd_export)

    c = sub.add_parser("compare", help="run the case on the native solver and the engines; compare")
    c.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    c.add_argument("--engines", help="comma-separated: native and engines (default: all)")
    c.add_argument("--dt", type=float, help="engine time step (overrides every engine's dt)")
    c.add_argument("--set", action="append", metavar="ENGINE.KEY=VALUE", help="an engine setting (repeatable)")
    _scheduler_option(c)
    c.add_argument("--json", action="store_true", help="the error figures as JSON instead of the table")
    c.add_argument("--end", help="end time (overrides the case)")
    c.add_argument("--steps", help="number of output intervals (overrides the case)")
    c.add_argument("--sensitivity", nargs="?", const="", metavar="P[,P...]",
                   help="check the exact sensitivities to these parameter paths (default: the case's [report] "
                        "sensitivity) against native's and the engines' central differences")
    _errors_option(c)
    c.set_defaults(run=cmd_compare)

    r = sub.add_parser("report", help="every case on native and the engines: index.html, summary.md, "
                                      "results.json, baseline gate (docs/report.md)")
    r.add_argument("cases", nargs="*", help="case files (default: cases/*.toml)")
    r.add_argument("--engines", help="engines to run (default: all; native always runs: it is the reference)")
    r.add_argument("--out", default="reports", help="output directory (default: reports)")
    r.add_argument("--baseline", metavar="FILE",
                   help="a stored results.json to gate against (exit 1 on regression); default OUT/baseline.json "
                        "when it exists; 'none': no gate")
    r.add_argument("--update-baseline", action="store_true",
                   help="write this run's results.json to --baseline (default: OUT/baseline.json)")
    r.add_argument("--quick", action="store_true", help="shorter work-precision sweeps, one native timing")
    r.add_argument("--junit", action="store_true", help="also write OUT/junit.xml")
    r.add_argument("--fail-on-slowdown", action="store_true", help="a flagged wall-time slowdown fails the run")
    r.add_argument("--jobs", type=int, help="worker processes (default: CPU count; 0 or 1: none)")
    r.add_argument("--stress", action="store_true",
                   help="also run kinem's own stress suite as a section (never by default)")
    r.add_argument("--no-stress", action="store_true", help="no stress suite (the default; kept for old scripts)")
    r.add_argument("--work-precision", action="store_true",
                   help="work-precision diagrams for every case (default: cases with [report] work_precision = true)")
    _scheduler_option(r)
    r.set_defaults(run=cmd_report)

    an = sub.add_parser("animate", help="the report's animation of one case: native solid, engines as ghosts, "
                                        "the named points' paths (.svg, .gif, or .mp4 with ffmpeg)")
    an.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    an.add_argument("--out", required=True, help="FILE.svg (animated SVG), FILE.gif, or FILE.mp4")
    an.add_argument("--engines", default="native,pymunk,mujoco,exudyn",
                    help="engines drawn as ghosts over the native solution")
    an.set_defaults(run=cmd_animate)

    d = sub.add_parser("diff", help="what moved between two results.json files of kinem report (B against A, "
                                    "judged as the gate judges a run against its baseline)")
    d.add_argument("a", metavar="A.json", help="the earlier results.json (or baseline)")
    d.add_argument("b", metavar="B.json", help="the later results.json")
    _errors_option(d)
    d.set_defaults(run=cmd_diff)

    co = sub.add_parser("completion", help="print the shell's tab-completion script (needs shtab): "
                                           "eval \"$(kinem completion bash)\"")
    co.add_argument("shell", choices=("bash", "zsh", "tcsh"), help="the shell")
    co.set_defaults(run=cmd_completion)
    return p


def _errors_option(p):
    p.add_argument("--errors", choices=("first", "all"), default="first",
                   help="bad input: the first few problems on one line (default) or every problem, one a line")


def _scheduler_option(p):
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the workers of this Dask distributed scheduler (e.g. tcp://host:8786) "
                        "instead of local processes")
    p.add_argument("--timeout", type=float, metavar="SECONDS", action=_Timeout,
                   help="with --scheduler: stop the run after this long (default 6 h; kinem/parallel.py)")


class _Timeout(argparse.Action):
    """--timeout sets kinem.parallel.RUN_TIMEOUT for this command."""

    def __call__(self, parser, namespace, value, option_string=None):
        from . import parallel

        if not value > 0:
            raise InputError(f"--timeout: got {value}; expected a positive number of seconds")
        parallel.RUN_TIMEOUT = value
        setattr(namespace, self.dest, value)


def _terminate(signum, frame):
    """SIGTERM, SIGHUP: clean up (temporary files) as for Ctrl-C, then exit
    128 + signal; while an output is being published (output.HOLD) the exit
    waits until it is."""
    from . import output

    output.STOP["signal"] = signum   # in case the exit below is swallowed where the signal lands
    if output.HOLD["depth"]:
        return
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    import signal

    def unraisable(u, default=sys.unraisablehook):  # our exit, swallowed in a callback: no traceback printed
        from . import output

        if not (output.STOP["signal"] is not None and isinstance(u.exc_value, SystemExit)):
            default(u)

    handled = [s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None]
    try:
        previous = {s: signal.signal(s, _terminate) for s in handled}
    except ValueError:   # not the main thread: leave the signals alone
        previous = {}
    hook, sys.unraisablehook = sys.unraisablehook, unraisable
    try:
        _standard_streams()
        return _main(argv)
    finally:
        sys.unraisablehook = hook
        for s, h in previous.items():
            signal.signal(s, h)
        from . import output

        output.STOP["signal"] = None


def _main(argv) -> int:
    a = None
    try:
        p = parser()
        a = p.parse_args(argv)
        if a.command is None:   # bare kinem: the usage
            p.print_help()
            _flush()
            return 0
        _threads_note()
        code = a.run(a)
        _flush()
        return code
    except InputError as e:
        if getattr(a, "errors", None) == "all":
            for problem in e.problems:
                print(f"kinem: error: {problem}", file=sys.stderr)
        else:
            print(f"kinem: error: {e.summary('--errors all lists them')}", file=sys.stderr)
        return 2
    except AnalysisError as e:
        print(f"kinem: analysis failed: {one_line(e)}", file=sys.stderr)
        return 1
    except CoreError as e:   # a fault of kinem's compiled core: not a verdict on the case
        return _internal(e)
    except BrokenPipe:   # kinem solve CASE | head: quietly, as a Unix tool
        _quiet_stdout()
        return 141
    except KinemError as e:   # OutputError among them: a write that failed
        print(f"kinem: error: {one_line(e)}", file=sys.stderr)
        try:
            sys.stdout.flush()
        except OSError:
            _quiet_stdout()
        return 1
    except KeyboardInterrupt:
        return 130
    except OSError as e:
        if e.errno == errno.EPIPE:   # print() to standard output, its reader gone: quietly
            _quiet_stdout()
            return 141
        if e.errno in (errno.EBADF, errno.ENOSPC, errno.EIO, errno.EDQUOT, errno.EFBIG):  # print() to stdout
            print(f"kinem: error: standard output: write failed: {e.strerror}", file=sys.stderr)
            _quiet_stdout()
            return 1
        return _internal(e)
    except Exception as e:  # noqa: BLE001 - one line, never a traceback
        return _internal(e)


def _threads_note():
    """A note on standard error when RAYON_NUM_THREADS asks for more threads
    than the machine has cores: the core's pool is capped at the cores."""
    asked = os.environ.get("RAYON_NUM_THREADS", "").strip()
    if not asked.isdigit():
        return
    from . import native

    if int(asked) > native.CORES:
        print(f"kinem: note: RAYON_NUM_THREADS={asked} is above this machine's {native.CORES} cores: "
              f"the core uses {native.THREADS} threads", file=sys.stderr)


def _internal(e) -> int:
    if os.environ.get("KINEM_DEBUG"):
        raise e
    print(f"kinem: internal error: {type(e).__name__}: {one_line(e)}", file=sys.stderr)
    return 3
