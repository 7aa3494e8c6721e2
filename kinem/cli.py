"""The command line: a thin layer over the Python API.

Exit codes: 0 success, 1 analysis failure (no convergence, singular
Jacobian), 2 bad input (case file, arguments), 3 internal error. Errors are
one line on standard error, never a traceback (set KINEM_DEBUG=1 for one).
"""
import argparse
import json
import os
import sys
from pathlib import Path

from .errors import AnalysisError, InputError, KinemError
from .result import OUTPUTS


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise InputError(f"{self.prog}: {message}")


def _load(path, end=None, steps=None):
    from .case import check_time, load
    from .model import compile

    case = load(path)
    if end is not None or steps is not None:
        case = check_time(case.with_time(end, steps))
    return compile(case)


def _outputs(text):
    items = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in items if s not in OUTPUTS]
    if bad or not items:
        raise InputError(f"--outputs: got {text!r}; expected a comma-separated list of {', '.join(OUTPUTS)}")
    return tuple(items)


def cmd_solve(a):
    from .analysis import solve
    from .output import csv_text, write_trajectory

    if a.end is not None and not a.end > 0:
        raise InputError(f"--end: got {a.end}; expected a positive time")
    if a.steps is not None and a.steps < 1:
        raise InputError(f"--steps: got {a.steps}; expected a whole number >= 1")
    fmt = a.format or ("npz" if a.out and a.out.endswith(".npz") else "csv")
    if fmt == "npz" and not a.out:
        raise InputError("--format npz needs --out FILE")
    model = _load(a.case, a.end, a.steps)
    r = solve(model, _outputs(a.outputs), trace=a.diagnostics is not None)
    if a.diagnostics is not None:
        _write_trace(r, a.diagnostics)
    if not r.success:
        raise AnalysisError(f"{a.case}: {r.message}")
    if a.out:
        write_trajectory(r.trajectory, a.out, fmt)
    else:
        sys.stdout.write(csv_text(r.trajectory))
    return 0


def _write_trace(r, target):
    """The full trace as CSV: every Newton iteration, rejected sub-step and
    instant, then the events (singular configurations passed)."""
    from .output import write_atomic

    lines = ["t,what,iteration,scaled_residual,detail"]
    lines += [f"{t:.17g},{what},{it},{res:.6e},\"{str(detail).replace(chr(34), chr(39))}\""
              for t, what, it, res, detail in r.trace]
    lines += [f"{t:.17g},event,,,\"{text.replace(chr(34), chr(39))}\"" for t, text in r.events]
    text = "\n".join(lines) + "\n"
    if target == "-":
        sys.stderr.write(text)
    else:
        write_atomic(target, lambda f: f.write(text.encode()))


def cmd_info(a):
    from .info import describe, info

    i = info(_load(a.case))
    print(json.dumps(i.as_dict(), indent=2) if a.json else describe(i))
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
    engines = [e.strip() for e in text.split(",") if e.strip()]
    if any(e not in ("native",) + ENGINES for e in engines) or not (engines or allow_empty):
        raise InputError(f"--engines: got {text!r}; expected a comma-separated list of native, {', '.join(ENGINES)}")
    return engines


def cmd_stress(a):
    from . import stress

    engines = _engines(a.engines)
    rows = stress.run(engines, a.quick, a.jobs, a.scheduler)
    if a.json:
        print(json.dumps(rows, indent=2, default=float))
    else:
        print(stress.table(rows, engines))
    want = stress.expected(a.quick)
    misses = [r for r in rows if r["engine"] == "native" and r["outcome"] != want[r["scenario"]]]
    for r in misses:
        print(f"native: {r['scenario']}: {r['outcome']}, expected {want[r['scenario']]}", file=sys.stderr)
    return 1 if misses else 0


def cmd_engines(a):
    from adapters import matrix

    if a.tune is not None:
        return _tune(a)
    if a.update_docs:
        changed = matrix.update(Path(__file__).resolve().parents[1] / "docs" / "engines.md")
        print("docs/engines.md " + ("updated" if changed else "already current"))
    else:
        print(matrix.markdown(), end="")
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
    from adapters.export import export
    from .analysis import solve

    model = _load(a.case)
    native = solve(model)
    if not native.success:
        raise AnalysisError(f"{a.case}: no native solution at t = 0 to start the engine from: {native.message}")
    settings = dict(model.case.engines.get(a.engine, {}))   # the case file's [engines.NAME] table, as the harness
    if settings:
        from adapters import case_settings

        case_settings(model, a.engine)   # checked as the harness checks it (naming the file and the key)
    text = export(model, a.engine, native.q[0], native.qd[0], settings)
    out = Path(a.out)
    if out.is_symlink() or (out.exists() and not out.is_file()):   # a device, FIFO or link: written through
        with open(out, "w") as f:
            f.write(text)
    else:
        from .output import write_atomic

        write_atomic(out, lambda f: f.write(text.encode()))
    return 0


def cmd_compare(a):
    from adapters.compare import run_case, table

    engines = _engines(a.engines)
    model = _load(a.case)
    native, rows = run_case(model, engines, _settings(a.set, a.dt, engines), a.scheduler)
    if a.json:
        print(json.dumps({"case": model.case.name, "length": model.length, "unit": model.case.length_unit,
                          "engines": {r.engine: r.as_dict() for r in rows}}, indent=2, default=float))
    else:
        print(table(model.case.name, model.length, model.case.length_unit, rows))
    return 0 if all(r.within_tolerance is not False for r in rows) else 1


def cmd_report(a):
    from .report import Options, run

    engines = _engines(a.engines, allow_empty=True)  # native always runs in the report
    if a.jobs is not None and a.jobs < 0:
        raise InputError(f"--jobs: got {a.jobs}; expected 0 (no worker processes) or more")
    paths = a.cases or sorted(str(p) for p in Path("cases").glob("*.toml"))
    engines = tuple(dict.fromkeys(e for e in engines if e != "native"))
    outcome = run(Options(cases=tuple(paths), engines=engines, out=a.out,
                          baseline=a.baseline, update_baseline=a.update_baseline, quick=a.quick, junit=a.junit,
                          fail_on_slowdown=a.fail_on_slowdown, workers=a.jobs,
                          scheduler=a.scheduler, stress=not a.no_stress))
    print(outcome.line)
    return outcome.exit_code


def parser():
    p = _Parser(prog="kinem", description="Planar kinematics in Cartesian coordinates (Nikravesh, Ch. 4).")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("solve", help="solve a case; write its trajectory")
    s.add_argument("case")
    s.add_argument("--out", help="output file (default: CSV to standard output)")
    s.add_argument("--format", choices=("csv", "npz"))
    s.add_argument("--outputs", default=",".join(OUTPUTS), help="any of positions,velocities,accelerations")
    s.add_argument("--end", type=float, help="end time (overrides the case)")
    s.add_argument("--steps", type=int, help="number of output intervals (overrides the case)")
    s.add_argument("--diagnostics", nargs="?", const="-", metavar="FILE",
                   help="write the full trace (Newton iterations, rejected sub-steps, conditioning) as CSV "
                        "to FILE, or to standard error")
    s.set_defaults(run=cmd_solve)

    i = sub.add_parser("info", help="coordinates, equations, Jacobian non-zeros, degrees of freedom")
    i.add_argument("case")
    i.add_argument("--json", action="store_true")
    i.set_defaults(run=cmd_info)

    st = sub.add_parser("stress", help="the stress suite on native and the engines, each outcome classified")
    st.add_argument("--engines", help="comma-separated: native and engines (default: all)")
    st.add_argument("--quick", action="store_true", help="fewer sweep points and a 100-turn long run")
    st.add_argument("--jobs", type=int, help="worker processes (default: the core count; 0 or 1: none)")
    _scheduler_option(st)
    st.add_argument("--json", action="store_true")
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
    x.add_argument("case")
    x.add_argument("--engine", required=True, help="mujoco, exudyn or pymunk")
    x.add_argument("--out", required=True, help="output file")
    x.set_defaults(run=cmd_export)

    c = sub.add_parser("compare", help="run the case on the native solver and the engines; compare")
    c.add_argument("case")
    c.add_argument("--engines", help="comma-separated: native and engines (default: all)")
    c.add_argument("--dt", type=float, help="engine time step (overrides every engine's dt)")
    c.add_argument("--set", action="append", metavar="ENGINE.KEY=VALUE", help="an engine setting (repeatable)")
    _scheduler_option(c)
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_compare)

    r = sub.add_parser("report", help="every case on native and the engines: index.html, summary.md, "
                                      "results.json, baseline gate (docs/report.md)")
    r.add_argument("cases", nargs="*", help="case files (default: cases/*.toml)")
    r.add_argument("--engines", help="engines to run (default: all; native always runs: it is the reference)")
    r.add_argument("--out", default="reports", help="output directory (default: reports)")
    r.add_argument("--baseline", metavar="FILE", help="a stored results.json to gate against (exit 1 on regression)")
    r.add_argument("--update-baseline", action="store_true",
                   help="write this run's results.json to --baseline (default: OUT/baseline.json)")
    r.add_argument("--quick", action="store_true", help="shorter work-precision sweeps, one native timing")
    r.add_argument("--junit", action="store_true", help="also write OUT/junit.xml")
    r.add_argument("--fail-on-slowdown", action="store_true", help="a flagged wall-time slowdown fails the run")
    r.add_argument("--jobs", type=int, help="worker processes (default: CPU count; 0 or 1: none)")
    r.add_argument("--no-stress", action="store_true", help="leave out the stress-suite section")
    _scheduler_option(r)
    r.set_defaults(run=cmd_report)
    return p


def _scheduler_option(p):
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the workers of this Dask distributed scheduler (e.g. tcp://host:8786) "
                        "instead of local processes")


def main(argv=None) -> int:
    try:
        a = parser().parse_args(argv)
        return a.run(a)
    except InputError as e:
        print(f"kinem: error: {e}", file=sys.stderr)
        return 2
    except AnalysisError as e:
        print(f"kinem: analysis failed: {e}", file=sys.stderr)
        return 1
    except KinemError as e:
        print(f"kinem: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except Exception as e:  # noqa: BLE001 - one line, never a traceback
        if os.environ.get("KINEM_DEBUG"):
            raise
        print(f"kinem: internal error: {type(e).__name__}: {e}", file=sys.stderr)
        return 3
