"""The command line's parser: every command, its options and its help."""
import argparse
import math

from ..errors import InputError, KinemError
from ..result import OUTPUTS
from .args import Parser
from .commands import (cmd_animate, cmd_compare, cmd_diff, cmd_engines, cmd_export, cmd_info, cmd_report,
                       cmd_sensitivity, cmd_stress, cmd_sweep, cmd_tolerance)
from .solve import MAX_SECONDS, MAX_WORK, cmd_solve


def parser():
    from .. import __version__
    from ..stream import SUBSTEP_WORK

    p = Parser(prog="kinem", description="Planar kinematics in Cartesian coordinates (Nikravesh, Ch. 4).",
                epilog="kinem COMMAND --help for a command's options; README.md and docs/ for more.")
    p.add_argument("--version", action="version", version=f"kinem {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)

    s = sub.add_parser("solve", help="solve a case; write its trajectory")
    s.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    s.add_argument("--out", help="output file (default: CSV to standard output)")
    s.add_argument("--format", choices=("csv", "npz"),
                   help="csv (default; to standard output without --out) or npz (needs --out); must agree with "
                        "--out's suffix")
    s.add_argument("--outputs", default=",".join(OUTPUTS),
                   help="any of positions,velocities,accelerations,margins (margins: the smallest singular value "
                        "of the dimensionless Jacobian and the transmission angles, docs/design.md)")
    time_options(s)
    s.add_argument("--diagnostics", nargs="?", const="-", metavar="FILE",
                   help="write the full trace (Newton iterations, rejected sub-steps, conditioning) as CSV "
                        "to FILE, or to standard error")
    errors_option(s)
    s.add_argument("--partial", action="store_true",
                   help="when the analysis fails, still write the instants solved, marked partial "
                        "(CSV: a last line '# partial: REASON'; NPZ: arrays partial and message)")
    s.add_argument("--max-work", type=number_option, metavar="N",
                   help=f"refuse runs above N output instants x coordinates (default {MAX_WORK:g}); each step "
                        f"attempt beyond one per output interval counts as {SUBSTEP_WORK} instants")
    max_seconds_option(s)
    set_option(s)
    s.set_defaults(run=cmd_solve)

    i = sub.add_parser("info", help="coordinates, equations, Jacobian non-zeros, degrees of freedom")
    i.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    i.add_argument("--json", action="store_true", help="the same figures as JSON")
    i.add_argument("--parameters", action="store_true",
                   help="list the case's design parameters instead: path, value, unit, what it is")
    i.add_argument("--blocks", action="store_true",
                   help="the structural decomposition instead: the blocks solved in order, each its coordinates "
                        "and the constraints that close it (docs/solver.md)")
    set_option(i)
    errors_option(i)
    i.set_defaults(run=cmd_info)

    sw = sub.add_parser("sweep", help="solve a case over a grid of its design parameters; one table "
                                      "(variant, parameters, t, outputs)")
    sw.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    sw.add_argument("--set", action="append", metavar="NAME=START:STOP:COUNT",
                    help="a named dimension's or design parameter path's values (repeatable: every combination): "
                         "COUNT values from START to STOP, or A,B,C")
    sw.add_argument("--outputs", metavar="COLUMNS", help="comma-separated trajectory columns (default: all)")
    sw.add_argument("--out", help="output CSV file (default: standard output)")
    errors_option(sw)
    sw.set_defaults(run=cmd_sweep)


    se = sub.add_parser("sensitivity", help="exact d/dp of every output column for design parameters p")
    se.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    se.add_argument("--parameters", required=True, metavar="P,...",
                    help="comma-separated parameter paths (kinem info CASE --parameters lists them)")
    se.add_argument("--out", help="output file (default: CSV to standard output)")
    se.add_argument("--format", choices=("csv", "npz"), help="csv (default) or npz (needs --out)")
    se.add_argument("--outputs", default=",".join(OUTPUTS), help="any of positions,velocities,accelerations")
    time_options(se)
    se.set_defaults(run=cmd_sensitivity)

    tl = sub.add_parser("tolerance", help="tolerance bands: linear worst case, root-sum-square, Monte Carlo")
    tl.add_argument("case", help="the case file, with a [tolerances] section")
    tl.add_argument("--samples", type=whole_option, default=1000, help="Monte Carlo samples (default 1000)")
    tl.add_argument("--outputs", help="comma-separated output columns (default: every named point's x and y)")
    tl.add_argument("--seed", type=whole_option, default=0, help="the samples' seed (default 0)")
    tl.add_argument("--out", help="output file (default: CSV to standard output)")
    tl.add_argument("--format", choices=("csv", "npz"), help="csv (default) or npz (needs --out)")
    time_options(tl)
    tl.set_defaults(run=cmd_tolerance)

    st = sub.add_parser("stress", help="the stress suite on native and the engines, each outcome classified")
    st.add_argument("--engines", help="comma-separated: native and engines (default: all)")
    st.add_argument("--quick", action="store_true", help="fewer sweep points and a 100-turn long run")
    st.add_argument("--jobs", type=whole_option, help="worker processes (default: the core count; 0 or 1: none)")
    scheduler_option(st)
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
    c.add_argument("--dt", type=number_option, help="engine time step (overrides every engine's dt)")
    c.add_argument("--set", action="append", metavar="ENGINE.KEY=VALUE", help="an engine setting (repeatable)")
    scheduler_option(c)
    c.add_argument("--json", action="store_true", help="the error figures as JSON instead of the table")
    time_options(c)
    max_seconds_option(c, " (native's solves and the engines' runs)")
    c.add_argument("--sensitivity", nargs="?", const=True, metavar="P[,P...]",   # True: alone, the case's
                   help="check the exact sensitivities to these parameter paths (default: the case's [report] "
                        "sensitivity) against native's and the engines' central differences")
    errors_option(c)
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
    r.add_argument("--jobs", type=whole_option, help="worker processes (default: CPU count; 0 or 1: none)")
    r.add_argument("--stress", action="store_true",
                   help="also run kinem's own stress suite as a section (never by default)")
    r.add_argument("--no-stress", action="store_true", help="no stress suite (the default; kept for old scripts)")
    r.add_argument("--work-precision", action="store_true",
                   help="work-precision diagrams for every case (default: cases with [report] work_precision = true)")
    scheduler_option(r)
    r.set_defaults(run=cmd_report)

    an = sub.add_parser("animate", help="the report's animation of one case: native solid, engines as ghosts, "
                                        "the named points' paths (.svg, .gif, or .mp4 with ffmpeg)")
    an.add_argument("case", help="the case file (TOML; docs/case-format.md)")
    an.add_argument("--out", required=True, help="FILE.svg (animated SVG), FILE.gif, or FILE.mp4")
    an.add_argument("--engines", default="native,pymunk,mujoco,exudyn",
                    help="engines drawn as ghosts over the native solution")
    max_seconds_option(an, " (native's solve and the engines' runs)")
    an.set_defaults(run=cmd_animate)

    d = sub.add_parser("diff", help="what moved between two results.json files of kinem report (B against A, "
                                    "judged as the gate judges a run against its baseline)")
    d.add_argument("a", metavar="A.json", help="the earlier results.json (or baseline)")
    d.add_argument("b", metavar="B.json", help="the later results.json")
    errors_option(d)
    d.set_defaults(run=cmd_diff)

    co = sub.add_parser("completion", help="print the shell's tab-completion script (needs shtab): "
                                           "eval \"$(kinem completion bash)\"")
    co.add_argument("shell", choices=("bash", "zsh", "tcsh"), help="the shell")
    co.set_defaults(run=cmd_completion)
    return p


def set_option(p):
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="a named dimension of the case's [parameters] or a design parameter path (repeatable): "
                        "--set crank=55, --set constraints.B.si.0=0.31")


def time_options(p):
    p.add_argument("--end", help="end time (overrides the case; the case file's range)")
    p.add_argument("--steps", help="number of output intervals (overrides the case; the case file's range)")


def max_seconds_option(p, what=""):
    p.add_argument("--max-seconds", type=number_option, metavar="S",
                   help=f"stop a run after S seconds, naming what took the time (default {MAX_SECONDS:g}){what}")


def errors_option(p):
    p.add_argument("--errors", choices=("first", "all"), default="first",
                   help="bad input: the first few problems on one line (default) or every problem, one a line")


def number_option(text):
    """A number option's value read as a case file's numbers are (kinem.casefile.checks.toml_float: 0.5,
    1e-3, 1_000, inf; not .5, infinity, nan or 1__0), as --end, --steps and --set read theirs."""
    from ..casefile.checks import TOML_NUMBERS, toml_float

    try:
        v = toml_float(text)
    except ValueError:
        v = math.nan
    if math.isnan(v):   # NaN: never a bound, a step or a time
        raise argparse.ArgumentTypeError(f"got {text!r}; expected a number as a case file writes it "
                                         f"({TOML_NUMBERS})")
    return v


def whole_option(text):
    """A whole-number option's value (--samples, --seed, --jobs) read as --steps reads its: a case file's
    number that is whole (10, 1_000, 1e3, 0x10; not 2.5, a digit of another script such as '٣' (Python's
    int takes it), nan or 10**400's digits)."""
    from ..casefile.checks import TOML_NUMBERS, digits, toml_number

    v = toml_number(text)
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if not isinstance(v, int):
        raise argparse.ArgumentTypeError(f"got {text!r}; expected a whole number as a case file writes it "
                                         f"({TOML_NUMBERS})")
    if abs(v).bit_length() > 10_000:   # past Python's digits, toml_number keeps only their count
        raise argparse.ArgumentTypeError(f"got a whole number of {digits(v)} digits; expected one of at most "
                                         "3,000")
    return v


def scheduler_option(p):
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the workers of this Dask distributed scheduler (e.g. tcp://host:8786) "
                        "instead of local processes")
    p.add_argument("--timeout", type=number_option, metavar="SECONDS", action=_Timeout,
                   help="with --scheduler: stop the run after this long (default 6 h; kinem/parallel.py)")


MIN_TIMEOUT = 1.0   # seconds: --timeout's least (kinem.parallel's watchdog looks every 0.5 s)


class _Timeout(argparse.Action):
    """--timeout sets kinem.parallel.RUN_TIMEOUT for this command."""

    def __call__(self, parser, namespace, value, option_string=None):
        from .. import parallel

        from ..options import MOST_SECONDS

        # the watchdog looks every half second, so less than a second would end the run at its first look;
        # inf (or 1e400) no bound at all, which --timeout is for (kinem/parallel.py)
        if not MIN_TIMEOUT <= value <= MOST_SECONDS:   # NaN too
            raise InputError(f"--timeout: got {value:g}; expected a number of seconds from {MIN_TIMEOUT:g} to "
                             f"{MOST_SECONDS:g}")
        parallel.RUN_TIMEOUT = value
        setattr(namespace, self.dest, value)


def cmd_completion(a):
    """kinem completion SHELL: the tab-completion script (shtab, optional)."""
    try:
        import shtab
    except ImportError:
        raise KinemError("completion needs shtab, which is not installed: pip install shtab") from None
    print(shtab.complete(parser(), shell=a.shell), end="")
    return 0
