"""``kinem report``: every case on the native solver and every engine, the
work-precision sweeps, and the baseline gate (docs/report.md).

    execute.py  which runs, where (kinem.parallel)  runs.py   one run (in a worker)
    results.py  results.json and its schema         gate.py   the baseline gate
    slowdown.py the gate's confirmed wall-time flag  diff.py   kinem diff A.json B.json
    html.py, plots.py, text.py: index.html, summary.md, junit.xml
"""
import dataclasses
import os
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..outcome import Kind, Outcome


@dataclass(frozen=True)
class Options:
    cases: tuple                 # case file paths
    engines: tuple               # engines besides native (always run: it is the reference)
    out: str = "reports"
    baseline: str | None = None
    update_baseline: bool = False
    quick: bool = False
    junit: bool = False
    fail_on_slowdown: bool = False
    workers: int | None = None   # None: os.cpu_count(); 0 or 1: in this process
    scheduler: str | None = None  # a Dask scheduler address: the runs go to its workers
    progress: bool | None = None  # None: when standard error is a terminal
    stress: bool | None = None   # the quick stress suite as a section: only when True (--stress)
    whole_set: bool | None = None  # the cases are the whole case set (not narrowed); None: they cover the baseline's
    baseline_default: bool = False  # no --baseline given: OUT/baseline.json is used when it exists
    work_precision: bool = False  # every case gets work-precision diagrams (else: [report] work_precision)


class Report(Kind):
    """How a report ended (``Outcome.status``; the detail is the one line the
    command prints)."""
    OK = ("ok", "ok")
    FAILED = ("failed", "FAILED", True)   # exit code 1: see _exit_code


@dataclass(frozen=True)
class Written:
    """A report's ``Outcome.value``."""
    doc: dict                    # results.json
    written: tuple               # paths written


def run(o: Options) -> Outcome:
    from ..output import release

    try:
        return _run(o)
    finally:
        release()   # a FIFO among the outputs, opened before the runs, that a failure left unwritten


def _run(o: Options) -> Outcome:
    from . import gate, html, results, text
    from .execute import FULL, QUICK, execute
    from .progress import Progress
    from .runs import REFERENCE_TOLERANCE

    start = time.perf_counter()
    o = _checked(o)
    cases = _load_cases(o.cases)
    old = None
    if o.baseline and (Path(o.baseline).exists() or not o.update_baseline):
        try:
            old = results.load(o.baseline)
        except InputError:
            if not o.update_baseline:
                raise
            # --update-baseline replaces a stale (other schema version) or broken baseline: no gate this time
    out = Path(o.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: not a directory")
    if out.is_symlink() and not out.exists():   # found here, not by the mkdir after the runs ("File exists")
        raise InputError(f"--out {out}: a symbolic link to {os.readlink(out)}, which does not exist; "
                         "expected a directory or a new name")
    target = Path(o.baseline or out / "baseline.json")
    if o.update_baseline and not (target.parent.is_dir() or target.parent == out):
        raise InputError(f"--baseline {target}: directory {target.parent} does not exist")
    check_outputs(out, [*FILES, *(["junit.xml"] if o.junit else [])] + [MANIFEST],
                  target if o.update_baseline else None)
    # a whole-set run: the case files given cover the baseline's cases, whatever their folder
    whole = o.whole_set if o.whole_set is not None else (
        old is not None and {c.name for _, c, _ in cases} >= {c["name"] for c in old["cases"]})
    sweep = QUICK if o.quick else FULL
    stress = bool(o.stress)   # only when asked: a user's cases are not followed by kinem's own scenarios
    bar = Progress(0, enabled=o.progress)
    try:
        if o.work_precision:
            sweep = dataclasses.replace(sweep, every_case=True)
        runs = execute([(p, c) for p, c, _ in cases], o.engines, sweep, o.workers, bar, o.scheduler,
                       (stress_tasks(o.engines) if stress else 0) + len(cases))   # then the stress suite, figures
        options = {"quick": o.quick, "engines": list(o.engines), "workers": _workers(o.workers),
                   "reference_tolerance": REFERENCE_TOLERANCE, "native_tolerances": list(sweep.tolerances),
                   "dt_factors": list(sweep.dt_factors),
                   "family_factors": list(sweep.family_factors), "native_repeats": sweep.native_repeats,
                   "whole_set": bool(whole),
                   "stress": "--stress" if stress else None}
        doc, series = results.build(cases, runs, options, time.perf_counter() - start)
        if stress:
            from . import stress_section

            doc["stress"] = stress_section.run(o.engines, o.workers, o.scheduler, bar)
        if old is not None:
            from .slowdown import confirm

            confirm(doc, old, cases)
            doc["gate"] = gate.gate(doc, old, o.baseline, o.fail_on_slowdown, default=o.baseline_default)
        bad = results.problems(doc, results.SCHEMA)
        if bad:  # a bug here, not the user's input
            raise RuntimeError(f"results.json does not match its schema: {bad[0]}")
        sections = _sections(doc, series, o.workers, bar)
    finally:
        bar.close()
    doc["duration"] = time.perf_counter() - start   # runs and plots
    files = {"results.json": results.dumps(doc), "summary.md": text.summary_md(doc),
             "index.html": html.index_html(doc, sections, series.get("(equivalence)"))}   # as FILES
    if o.junit:
        files["junit.xml"] = text.junit_xml(doc)
    written = write_outputs(out, files)
    refused = results.missing_figures(doc) if o.update_baseline else []
    if o.update_baseline and not refused:
        written.append(_write(target, files["results.json"]))
    code = 1 if refused else _exit_code(doc, o)
    line = _line(doc, out, code, o)
    if refused:
        line += f"; baseline NOT written: {refused[0]}"
    return Outcome(Report.FAILED if code else Report.OK, line, Written(doc, tuple(written)))


MAX_JOBS = 1024   # workers: local worker processes (kinem.cli's --jobs)


def _checked(o: Options) -> Options:
    """``o`` checked field by field before anything is read or run, as the
    command line checks its options (an InputError naming the field); its
    engines each once, native left out (it always runs)."""
    import numbers

    import numpy as np
    from adapters import names

    def bad(field, expected):
        return InputError(f"report: Options({field}={getattr(o, field)!r:.80}): expected {expected}")

    path = (str, os.PathLike)
    cases = () if o.cases is None else o.cases
    if isinstance(cases, path) or not isinstance(cases, (list, tuple)) or not all(isinstance(c, path) for c in cases):
        raise bad("cases", "a list of case file paths (empty or None: cases/*.toml)")
    known = ("native", *names())
    if isinstance(o.engines, str) or not isinstance(o.engines, (list, tuple)) \
            or not all(isinstance(e, str) and e in known for e in o.engines):
        raise bad("engines", f"a list of engine names, each one of {', '.join(known)} (native always runs)")
    for field in ("out", "baseline"):
        v = getattr(o, field)
        if (v is not None or field == "out") and not isinstance(v, path):
            raise bad(field, "a path" + (" or None" if field == "baseline" else ""))
        if v is not None and not str(v):   # '' is Path('.'): the report in the working folder, or no gate, unseen
            raise InputError(f"--{field} '': an empty path (an unset shell variable?); expected a " + (
                "directory" if field == "out" else "results.json, or --baseline none for no gate"))
    flags = ("update_baseline", "quick", "junit", "fail_on_slowdown", "baseline_default", "work_precision")
    for field in (*flags, "progress", "stress", "whole_set"):
        v = getattr(o, field)
        if not isinstance(v, (bool, np.bool_)) and (field in flags or v is not None):
            raise bad(field, ("True or False" if field in flags else "True, False or None") +
                      (" (None: when standard error is a terminal)" if field == "progress" else ""))
    if o.workers is not None and (isinstance(o.workers, bool) or not isinstance(o.workers, numbers.Integral)
                                  or not 0 <= o.workers <= MAX_JOBS):
        raise bad("workers", f"None (the core count) or a whole number from 0 (no worker processes) to {MAX_JOBS}")
    if o.scheduler is not None and not isinstance(o.scheduler, str):
        raise bad("scheduler", "None or a Dask scheduler address such as tcp://host:8786")
    return dataclasses.replace(o, cases=tuple(cases), engines=tuple(dict.fromkeys(e for e in o.engines if e != "native")),
                               workers=None if o.workers is None else int(o.workers),   # numpy's too: results.json
                               **{f: None if getattr(o, f) is None else bool(getattr(o, f))
                                  for f in (*flags, "progress", "stress", "whole_set")})


def stress_tasks(engines) -> int:
    """How many runs the quick stress suite makes (for the progress bar)."""
    from ..stress import scenarios

    return sum(1 + (len(engines) if s.engines else 0) for s in scenarios(quick=True))


def _sections(doc, series, workers, bar=None):
    """The per-case HTML sections (plots take most of the time: in parallel
    too, in local processes even with a scheduler: they carry the series)."""
    from .html import render_section
    from .progress import run_all

    jobs = [(c, series.get(c["name"], {})) for c in doc["cases"]]
    return run_all(render_section, jobs, [f"figures of {c['name']}" for c in doc["cases"]], workers, None, bar)


def _load_cases(paths):
    from ..case import load
    from ..model import compile

    if not paths:
        raise InputError("no case files given and none in cases/")
    out, names = [], {}
    for p in paths:
        case = load(p)
        if case.name in names:
            raise InputError(f"{p}: case name '{case.name}' is also the name of {names[case.name]}; "
                             "expected unique case names")
        names[case.name] = p
        out.append((str(p), case, compile(case)))
    return out


def _workers(w):
    return (os.cpu_count() or 1) if w is None else w


MANIFEST = "manifest.json"
FILES = ("results.json", "summary.md", "index.html")   # then junit.xml (--junit) and manifest.json


def check_outputs(out: Path, names, baseline=None) -> None:
    """Every file the report will write, checked before the first run as
    kinem.output writes it (a directory, a read-only file, a link into a
    missing folder are refused; a link, FIFO or device is written through):
    exit 2 naming the file, the old report left whole, instead of a failed
    write after every run. ``out`` need not exist: then the folder it will
    be made in is checked."""
    from ..errors import OutputError
    from ..output import check

    paths = [out / name for name in names] if out.is_dir() else []
    if not out.is_dir():
        made_in = next(p for p in out.absolute().parents if p.exists())
        if not made_in.is_dir() or not os.access(made_in, os.W_OK | os.X_OK):
            raise InputError(f"--out {out}: cannot create it: {made_in} is "
                             f"{'not a directory' if not made_in.is_dir() else 'not writable'}")
    if baseline is not None and baseline.parent.is_dir():   # else OUT/baseline.json, OUT made after the runs
        paths.append(baseline)
    for path in paths:
        try:
            check(path)
        except OutputError as e:   # a read-only file: bad input here, as nothing has run
            raise InputError(str(e)) from None


def write_outputs(out: Path, files: dict) -> list:
    """Writes the report's files into out so that the set is consistent as a
    whole: every file is checked (as before the runs: one may have gone bad
    since; refused with the old report still whole), the old manifest.json
    is removed (emptied through it where it is a symbolic link), every file
    is written atomically, and manifest.json (each
    file's name, size and SHA-256) is written last. A reader checks it (``complete``): no manifest, or a file
    that does not match it, means an interrupted or failed run."""
    import hashlib
    import json

    from ..output import check

    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"--out {out}: cannot write: {e.strerror}") from None
    for name in [*files, MANIFEST]:   # again (it may have changed during the runs): the old report kept whole
        check(out / name)
    manifest = out / MANIFEST
    try:
        if manifest.is_symlink():   # the user's link: written through (an empty manifest until the end), never removed
            _write(manifest, "{}\n")
        elif manifest.is_file():
            manifest.unlink()
    except OSError as e:
        raise InputError(f"--out {out}: cannot write: {e.strerror}") from None
    data = {name: body.encode("utf-8") for name, body in files.items()}
    written = [_write(out / name, body) for name, body in files.items()]
    manifest = {"files": {name: {"bytes": len(b), "sha256": hashlib.sha256(b).hexdigest()}
                          for name, b in data.items()}}
    _write(out / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return written


def complete(out) -> bool:
    """Whether out holds one whole report: its manifest.json and every file it
    lists, each with the size and SHA-256 recorded."""
    import hashlib
    import json

    try:
        listed = json.loads((Path(out) / MANIFEST).read_text())["files"]
        return all(hashlib.sha256((Path(out) / name).read_bytes()).hexdigest() == f["sha256"]
                   for name, f in listed.items())
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _write(path, body) -> str:
    from ..output import write_atomic

    data = body.encode("utf-8")
    write_atomic(path, lambda f: f.write(data))
    return str(path)


def _exit_code(doc, o) -> int:
    """1 when an engine did not import, the native solver failed, the gate
    failed, or a run failed that the baseline does not already record as
    failed (without a baseline: any failed run)."""
    from .gate import failed

    from .text import failed as lost

    if any(e["outcome"] != "ok" for e in doc["engines"].values()):
        return 1
    if doc.get("stress") and doc["stress"]["native_misses"]:
        return 1
    from adapters.compare import Verdict

    g = doc["gate"]
    for c in doc["cases"]:
        for r in c["runs"]:
            if not g and not lost(r) and Verdict(r["verdict"]).fails:   # the one verdict rule, without a baseline
                return 1
            if not lost(r):
                continue
            known = g and r["engine"] != "native" and g["kinds"].get(f"{c['name']}/{r['engine']}") != "new"
            if not known:
                return 1
    if not o.update_baseline and failed(g):
        return 1
    return 0


def _of_native(g) -> str:
    """' (N of native)': how many regressions are native's own (its answer moved, or it
    disagrees with the engines' consensus), so that a formulation change is named as one."""
    n = sum(f["fatal"] and f["kind"] != "slower" and f["engine"] == "native" for f in g["findings"])
    return f" ({n} of native)" if n else ""


def _line(doc, out, code, o) -> str:
    runs = [r for c in doc["cases"] for r in c["runs"]]
    from .text import failed as lost

    failed = sum(lost(r) for r in runs)
    g = doc["gate"]
    if not g:
        gate = "no baseline" + (f" (none at {out / 'baseline.json'}; --update-baseline writes one)"
                                if o.baseline_default and not o.baseline else "")
    else:
        gate = (f"{g['regressions']} regressions{_of_native(g)}, {g['slowdowns']} slowdowns vs {g['baseline']}"
                + (" (default; --baseline none to skip)" if o.baseline_default else ""))
        if g["not_compared"]:
            gate += f"; {len(g['not_compared'])} thing(s) not compared (listed in summary.md and index.html)"
    if o.update_baseline:
        gate += f"; baseline {o.baseline or out / 'baseline.json'} updated"
    return (f"kinem report: {len(doc['cases'])} cases, {len(runs)} runs, {failed} failed; {gate}; "
            f"{doc['duration']:.0f} s; {'FAILED' if code else 'ok'}; see {out / 'index.html'}")
