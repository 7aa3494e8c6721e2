"""The commands other than solve: each one reads its arguments, calls the
API and prints or writes the answer; exit 0, or 1 for a failed verdict."""
import json
import sys
from pathlib import Path

from ..errors import AnalysisError, InputError, one_line
from .args import engine_list, engine_settings, file_format, frame_bar, load_model, output_list, warned
from .streams import note


def cmd_sweep(a):
    """kinem sweep CASE --set NAME=START:STOP:COUNT ...: one table of every variant (kinem.sweep)."""
    from ..output import Output, check
    from ..sweep import parse_values, sweep

    if a.out is not None:   # a bad --out refused before the variants are solved, not after
        check(a.out)
        if Path(a.out).suffix.lower() == ".npz":
            raise InputError(f"--out {a.out}: kinem sweep writes a CSV table; expected a .csv file name "
                             "(kinem.sweep(...).data holds the arrays)")
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
        from ..report.progress import Progress

        bar = Progress(0)
    try:
        result = warned(sweep, a.case, values, columns, bar)
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
    from ..info import describe, info

    if a.parameters and a.blocks:   # each lists instead of the summary: one would be ignored
        raise InputError("--parameters and --blocks: give at most one (each is a listing instead of the summary)")
    if a.parameters:
        from ..info import describe_parameters
        from ..parameters import parameters

        listed = parameters(load_model(a.case, values=a.set).case)
        print(json.dumps([p.as_dict() for p in listed], indent=2) if a.json else describe_parameters(listed))
        return 0
    if a.blocks:
        from ..info import blocks_as_dict, describe_blocks

        model = load_model(a.case, values=a.set)
        print(json.dumps(blocks_as_dict(model), indent=2) if a.json else describe_blocks(model))
        return 0
    i = info(load_model(a.case, values=a.set))
    print(json.dumps(i.as_dict(), indent=2) if a.json else describe(i))
    if not i.assembled:  # the figures above are of the closest configuration found
        from ..result import Status

        what = "assembles on a branch it excludes" if i.status is Status.WRONG_BRANCH else "does not assemble at t = 0"
        raise AnalysisError(f"{a.case}: {what}: {i.diagnosis}")
    return 0


def cmd_sensitivity(a):
    from ..output import check, write_trajectory
    from ..sensitivity import sensitivity

    fmt = file_format(a.out, a.format)
    if a.out is not None:
        check(a.out)   # before the solve
    model = load_model(a.case, a.end, a.steps)
    paths = [p.strip() for p in a.parameters.split(",") if p.strip()]
    s = sensitivity(model, paths, outputs=output_list(a.outputs))
    if s.singular.any():
        print(f"kinem: warning: {a.case}: {s.message}", file=sys.stderr)
    write_trajectory(s.derivatives, "-" if a.out is None else a.out, fmt)
    return 0


def cmd_tolerance(a):
    from ..output import check, write_trajectory
    from ..tolerance import MAX_SAMPLES, tolerance

    if not 0 <= a.samples <= MAX_SAMPLES:
        raise InputError(f"--samples: got {a.samples}; expected a whole number from 0 to {MAX_SAMPLES:,}")
    if a.seed < 0:
        raise InputError(f"--seed: got {a.seed}; expected a whole number, 0 or more")
    fmt = file_format(a.out, a.format)
    if a.out is not None:
        check(a.out)   # before the Monte Carlo samples, not after them
    model = load_model(a.case, a.end, a.steps)
    outputs = [c.strip() for c in a.outputs.split(",") if c.strip()] if a.outputs is not None else None
    progress = None
    if sys.stderr.isatty():
        from ..report.progress import Progress

        bar = Progress(a.samples)

        def show(done, total):
            bar.done = done
            bar.show(f"sample {done:,} of {total:,}")
        progress = show
    b = tolerance(model, samples=a.samples, outputs=outputs, seed=a.seed, progress=progress)
    write_trajectory(b.table, "-" if a.out is None else a.out, fmt)
    if b.singular:   # as kinem sensitivity warns
        print(f"kinem: warning: {a.case}: {b.singular}, and the linear bands with them", file=sys.stderr)
    left = [(c, amount, t) for c, amount, t in b.excess if amount > 0] if b.accepted else []   # none: no band
    for c, amount, t in left:   # where linearisation stops being trustworthy, output by output
        print(f"{c}: the Monte Carlo band leaves the worst-case linear band by at most {amount:.3g} (t = {t:.6g})",
              file=sys.stderr)
    if b.accepted and len(left) < len(b.excess):   # the others in one line, not one a ground point
        rest = len(b.excess) - len(left)
        print(f"kinem: the Monte Carlo band stays within the worst-case linear band for {'the other ' if left else ''}"
              f"{rest} output{'s' if rest != 1 else ''}", file=sys.stderr)
    if b.rejected:   # docs/design.md's words: a failed sample need not have left the branch
        none = "; none is in the band: its .mc columns are NaN" if not b.accepted else ""
        print(one_line(f"kinem: {len(b.rejected)} of {b.samples} samples left out of the Monte Carlo band (not a "
                       f"valid case, cannot assemble, leave the nominal's branch or fail on the way){none}; first: "
                       f"{b.rejected[0][1]}"), file=sys.stderr)
    return 0


MAX_JOBS = 1024   # --jobs: local worker processes (each started at once: a pool, not a queue)


def check_timeout(a):
    """--timeout of report, stress and compare bounds a run on a cluster
    (kinem.parallel.RUN_TIMEOUT): refused without --scheduler, where it would do nothing."""
    if a.timeout is not None and a.scheduler is None:
        raise InputError(f"--timeout {a.timeout:g}: only with --scheduler (it bounds a run on a Dask cluster; "
                         "local runs have no time limit); expected --scheduler ADDRESS or no --timeout")


def strict_json(value) -> str:
    """value as indented JSON that every reader takes: a figure not computed (NaN, infinite) is null, never
    NaN (no JSON number); numpy's numbers as floats (orjson: its own rules for both)."""
    import orjson

    return orjson.dumps(value, option=orjson.OPT_INDENT_2 | orjson.OPT_SERIALIZE_NUMPY, default=float).decode()


def check_jobs(jobs):
    """--jobs of report and stress: None (the core count) or 0 to MAX_JOBS."""
    if jobs is not None and not 0 <= jobs <= MAX_JOBS:
        raise InputError(f"--jobs: got {jobs}; expected 0 (no worker processes) to {MAX_JOBS}")


def cmd_stress(a):
    from .. import stress

    engines = engine_list(a.engines)
    check_jobs(a.jobs)
    check_timeout(a)
    outcomes = stress.run(engines, a.quick, a.jobs, a.scheduler)
    if a.json:
        print(strict_json([stress.as_dict(o) for o in outcomes]))
    else:
        print(stress.table(outcomes, engines))
    misses = stress.misses(outcomes, a.quick)
    for o, want in misses:
        print(f"native: {o.value.scenario}: {o.status.value} ({o.message}), expected {want.value}", file=sys.stderr)
    return 1 if misses else 0


def cmd_engines(a):
    from .. import engines

    if a.tune is not None:
        if a.update_docs:
            raise InputError("--tune and --update-docs: give at most one")
        return _tune(a)
    if a.quick or a.json:   # options of --tune alone: refused rather than ignored
        raise InputError(f"{'--quick' if a.quick else '--json'}: only with --tune; expected kinem engines --tune "
                         f"[ENGINES] {'--quick' if a.quick else '--json'}")
    if a.update_docs:
        changed = engines.update(Path(__file__).resolve().parents[2] / "docs" / "engines.md")
        print("docs/engines.md " + ("updated" if changed else "already current"))
    else:
        print(engines.markdown(), end="")
    return 0


def _tune(a):
    """kinem engines --tune [ENGINES]: the sweep behind the default settings (adapters/tune.py)."""
    from adapters import names, tune

    engines = list(dict.fromkeys(e.strip() for e in a.tune.split(",") if e.strip())) if a.tune else list(names())
    unknown = [e for e in engines if e not in names()]
    if unknown or not engines:   # ',' names no engine (--tune alone or --tune '' is every engine)
        raise InputError(f"--tune: got {a.tune!r}; expected a comma-separated list of {', '.join(names())}")
    models = tune._models(tune.QUICK_CASES if a.quick else tune.CASES, a.quick)
    results = [tune.sweep(e, quick=a.quick, repeats=1 if a.quick else 3, models=models) for e in engines]
    if a.json:
        print(strict_json(results))
    else:
        print("\n\n".join(tune.text(r) for r in results))
    return 0


def cmd_export(a):
    """kinem export CASE --engine NAME --out FILE: the engine model as the harness runs it."""
    from adapters.base import Failure, start
    from adapters.export import export

    model = load_model(a.case)
    try:
        q0, qd0 = start(model)   # the harness's start: the model's own assembly at the first instant
    except Failure as e:
        raise AnalysisError(f"{a.case}: no start to run the engine from: {e.detail}") from None
    settings = dict(model.case.engines.get(a.engine, {}))   # the case file's [engines.NAME] table, as the harness
    if settings:
        from adapters import case_settings

        case_settings(model, a.engine)   # checked as the harness checks it (naming the file and the key)
    text = export(model, a.engine, q0, qd0, settings)
    from ..output import write_atomic

    write_atomic(a.out, lambda f: f.write(text.encode()))   # devices, FIFOs and links written through
    note(a.out)
    return 0


def cmd_compare(a):
    import time
    from dataclasses import replace

    from adapters.compare import run_case, table

    from ..options import Options
    from .solve import time_limit

    started = time.perf_counter()
    engines = engine_list(a.engines)
    check_timeout(a)
    seconds = time_limit(a)   # native's solves, as kinem solve's, and the engines' runs (adapters.compare)
    model = load_model(a.case, a.end, a.steps)
    options = replace(Options.of(model.case), max_seconds=seconds, started=started)
    if a.sensitivity is not None:
        return _compare_sensitivity(a, model, engines, options)
    native, rows = run_case(model, engines, engine_settings(a.set, a.dt, engines), a.scheduler, options)
    if a.json:
        print(strict_json({"case": model.case.name, "length": model.length, "unit": model.case.length_unit,
                           "engines": {r.engine: r.as_dict() for r in rows}}))
    else:
        print(table(model.case.name, model.length, model.case.length_unit, rows))
    return 1 if any(r.verdict.fails for r in rows) else 0   # adapters.compare.Verdict: the report's rule too


def _compare_sensitivity(a, model, engines, options):
    """kinem compare --sensitivity: exact sensitivities against every source's
    central differences (adapters.sensitivity); exit 1 when one is outside."""
    from adapters import check_case
    from adapters.sensitivity import check, table

    check_case(model.case)
    if a.scheduler is not None:   # its runs are in this process: the option would be ignored
        raise InputError("--scheduler with --sensitivity: the sensitivity checks run in this process; expected "
                         "no --scheduler")
    given = None if a.sensitivity is True else [p.strip() for p in a.sensitivity.split(",") if p.strip()]
    if given == []:   # --sensitivity "$UNSET" or ',': not the case's list unseen
        raise InputError(f"--sensitivity: got {a.sensitivity!r}; expected design parameter paths P[,P...], or "
                         "--sensitivity alone for the case's [report] sensitivity")
    paths = given if given is not None else list(model.case.report.get("sensitivity", ()))
    if not paths:
        raise InputError(f"{a.case}: --sensitivity: no parameters given and the case has no [report] sensitivity; "
                         "expected --sensitivity P[,P...]")
    _, checks = check(model, paths, engines, engine_settings(a.set, a.dt, engines), options)
    if a.json:   # a figure not computed is null, never NaN (strict_json; compare's rows alike)
        print(strict_json({"case": model.case.name, "sensitivity": [
            {"engine": c.engine, "parameter": c.parameter, "status": c.status.value, "detail": c.detail, "h": c.h,
             "figure": c.figure, "error": c.error, "limit": c.limit, "at": c.at, "ratio": c.ratio,
             "within": c.within} for c in checks]}))
    else:
        print(table(model.case.name, checks))
    return 1 if any(c.within is False for c in checks) else 0


def cmd_report(a):
    from ..report import Options, run

    engines = engine_list(a.engines)  # '' refused as compare and animate refuse it; --engines native: native alone
    check_jobs(a.jobs)
    check_timeout(a)
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
        if a.update_baseline:   # "write the baseline to none": two options that contradict, not a guess between them
            raise InputError("--update-baseline with --baseline none: none is no baseline, so none to update; "
                             "expected --update-baseline alone (OUT/baseline.json) or with --baseline FILE")
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
    from ..report.diff import diff

    lines, regressions = diff(a.a, a.b)
    for line in lines:
        print(line)
    print(f"kinem diff: {a.b} against {a.a}: {regressions} regression(s), {len(lines) - regressions} other line(s)"
          if lines else f"kinem diff: {a.b} against {a.a}: nothing moved")
    return 1 if regressions else 0


def cmd_animate(a):
    import time
    from dataclasses import replace

    from ..options import Options
    from ..output import check
    from ..report.animate import check_output, write
    from .solve import time_limit

    started = time.perf_counter()
    engines = [e for e in engine_list(a.engines) if e != "native"]   # '' refused, as compare refuses it
    check_output(a.out)
    seconds = time_limit(a)   # native's solve and the engines' runs, as kinem compare's
    check(a.out)   # as sweep's --out: a read-only file, or a FIFO without a reader, before the runs
    model = load_model(a.case)
    options = replace(Options.of(model.case), max_seconds=seconds, started=started)
    bar = frame_bar()
    try:
        skipped = write(model, a.out, engines, bar, options)
    finally:
        if bar:
            bar.close()
    for name, why in skipped.items():
        print(one_line(f"{name}: not drawn: {why}"), file=sys.stderr)
    note(a.out)
    return 0
