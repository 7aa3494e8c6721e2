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
    r = solve(model, _outputs(a.outputs))
    if not r.success:
        raise AnalysisError(f"{a.case}: {r.message}")
    if a.out:
        write_trajectory(r.trajectory, a.out, fmt)
    else:
        sys.stdout.write(csv_text(r.trajectory))
    return 0


def cmd_info(a):
    from .info import describe, info

    i = info(_load(a.case))
    print(json.dumps(i.as_dict(), indent=2) if a.json else describe(i))
    return 0


def _settings(items, dt):
    """--set engine.key=value (repeatable) and --dt into engine -> overrides."""
    from adapters import ENGINES

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
    return out


def cmd_compare(a):
    from adapters import ENGINES
    from adapters.compare import run_case, table

    engines = [e.strip() for e in a.engines.split(",") if e.strip()]
    bad = [e for e in engines if e not in ("native",) + ENGINES]
    if bad or not engines:
        raise InputError(f"--engines: got {a.engines!r}; expected a comma-separated list of native, {', '.join(ENGINES)}")
    model = _load(a.case)
    native, rows = run_case(model, engines, _settings(a.set, a.dt))
    if a.json:
        print(json.dumps({"case": model.case.name, "length": model.length, "unit": model.case.length_unit,
                          "engines": {r.engine: r.as_dict() for r in rows}}, indent=2, default=float))
    else:
        print(table(model.case.name, model.length, model.case.length_unit, rows))
    return 0 if all(r.within_tolerance is not False for r in rows) else 1


def cmd_report(a):
    from .analysis import solve

    paths = a.cases or sorted(str(p) for p in Path("cases").glob("*.toml"))
    if not paths:
        raise InputError("no case files given and none in cases/")
    worst = 0
    for path in paths:
        try:
            model = _load(path)
            r = solve(model)
        except InputError as e:
            print(f"{path}: input error: {e}")
            worst = max(worst, 2)
            continue
        its = r.iterations[1:] if len(r.iterations) > 1 else r.iterations
        status = "ok" if r.success else "FAILED"
        print(f"{model.case.name:24s} {status:6s} {len(r.trajectory):6d} instants {model.n:5d} coords "
              f"Newton/step mean {its.mean():.2f} max {its.max()}  residual max {r.residual.max():.1e}  "
              f"{1e3 * r.wall_time / max(1, len(r.iterations)):.3f} ms/instant"
              + ("" if r.success else f"  {r.message}"))
        if not r.success:
            worst = max(worst, 1)
    return worst


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
    s.set_defaults(run=cmd_solve)

    i = sub.add_parser("info", help="coordinates, equations, Jacobian non-zeros, degrees of freedom")
    i.add_argument("case")
    i.add_argument("--json", action="store_true")
    i.set_defaults(run=cmd_info)

    c = sub.add_parser("compare", help="run the case on the native solver and the engines; compare")
    c.add_argument("case")
    c.add_argument("--engines", default="native,pymunk,mujoco,exudyn")
    c.add_argument("--dt", type=float, help="engine time step (overrides every engine's dt)")
    c.add_argument("--set", action="append", metavar="ENGINE.KEY=VALUE", help="an engine setting (repeatable)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_compare)

    r = sub.add_parser("report", help="solve every case (default: cases/*.toml) and summarise")
    r.add_argument("cases", nargs="*")
    r.set_defaults(run=cmd_report)
    return p


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
