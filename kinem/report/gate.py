"""The baseline gate: this run's results.json against a stored one.

A regression (exit code 1) is, for a case and engine present in both:
- a status that got worse: ok < unsupported < failed;
- an error or residual that grew by more than ERROR_FACTOR, counting only
  what lies above ERROR_FLOOR (new > ERROR_FACTOR * max(old, ERROR_FLOOR));
- a deterministic cost count that grew at all (Newton iterations, Jacobian
  evaluations, factorisations; engine steps and substeps).
- a compact trajectory (positions, velocities and accelerations of every
  body coordinate and named point at fixed instants, scale-free) that
  moved: native by more than NATIVE_MOVE (positions, angles) or
  NATIVE_RATE_MOVE (rates), a regression of native naming the case, column,
  instant, size and limit; an engine by its tolerance. This sees a
  formulation change where no closed form exists;
- native disagreeing with the engines' consensus (adapters.compare.consensus);
- one verdict rule (adapters.compare.Verdict.fails): a run outside its
  tolerance (or at the cost cap) fails unless the baseline records the same
  verdict (a known state), and then only a worse figure (WORSE) fails;
- a case whose fingerprint changed: "case changed: baseline stale" (its
  runs are then not compared); an edit of the native solver's settings
  alone is compared instead, at the baseline's tolerance (SETTINGS_SLACK).
Native's figures against a closed form the baseline's run lacks are "new"
(listed, not failing). When native moved and an engine's own trajectory did not, the engine's
findings against native are "attributed" (listed, not fatal).
The same rules apply to every work-precision point both runs have (its
position and velocity errors and its counts). Wall time is only flagged: time per step more than
SLOWDOWN_FACTOR times the baseline's, each relative to the engine's median
over the run's cases (native itself: only with --fail-on-slowdown), confirmed by repeats
(slowdown.confirm), is a slowdown, fatal only with --fail-on-slowdown.

No blind spots: a case, engine run or sweep point the baseline has and this
run lacks is a "missing" finding, fatal unless the run was narrowed on
purpose (scope: case files given that are not the whole case set, --engines
without that engine, --quick for sweep points); either way it is listed in
``not_compared``. A case or run new in this run is "new": fatal in a run of
the whole case set (the baseline should hold all of it), else only listed.
"""
import dataclasses
import enum
import math
from dataclasses import asdict, dataclass

from ..fingerprint import moved
from .slowdown import SLOWDOWN_FACTOR, WALL_FLOOR, slower, typical  # noqa: F401 (the gate's constants)

# Errors and residuals are relative to L (or radians, rad/s, scaled residual
# units); below 1e-12 they are rounding noise (the reference itself is only
# converged to 1e-13) and differ between machines and BLAS builds.
ERROR_FLOOR = 1e-12
# Engines and the native solver are deterministic for pinned versions, so an
# error does not move by itself; a factor 2 leaves room for other platforms'
# rounding while catching a formulation or adapter change (those move errors
# by orders of magnitude).
ERROR_FACTOR = 2.0
STATUS_RANK = {"ok": 0, "unsupported": 1}   # outcomes; every failure kind ranks 2
# Native's answers are deterministic to rounding: its compact trajectory may
# move by this much (of L, or rad) between runs; anything more is a change
# of formulation even where no closed form exists.
NATIVE_MOVE = 1e-12
# Its velocities and accelerations (a linear solve on those positions, and
# the quadratic velocity terms): to this much of V, V / L, V^2 / L, ...
NATIVE_RATE_MOVE = 1e-9
# A case edit of the native solver's settings alone: its answers may move by
# this many times the baseline's Newton tolerance (a scaled residual, ~ / L):
# they are checked against the baseline's at the baseline's tolerance.
SETTINGS_SLACK = 1.0
# A known failing state of the baseline (outside tolerance, native off the
# consensus) fails again only when a figure is worse than this factor of its.
WORSE = 1.01
GATED = ("position_error_rel", "angle_error", "velocity_error_rel", "angular_velocity_error_rel",
         "constraint_residual")


class Verdict(str, enum.Enum):
    """A case/engine's (or equivalence group's) gate verdict; ``gate.kinds``
    holds its value, ``gate.verdicts`` the sentence for people."""
    PASS = "pass"
    SLOWER = "slower"         # passes; slower than the baseline (not failing unless --fail-on-slowdown)
    NEW = "new"               # not in the baseline (fatal in a whole-set run: then REGRESSED)
    REGRESSED = "regressed"


NO_BASELINE, UNCOMPARED = "no baseline", "not compared"   # kinds besides gate.Verdict's values


def verdict_of(doc, key):
    """(kind, sentence) of a gate verdict key ("case/engine" or
    "equivalence/group"): kind a Verdict value, or NO_BASELINE or
    UNCOMPARED."""
    g = doc.get("gate")
    if not g:
        return NO_BASELINE, "no baseline"
    if key not in g["kinds"]:
        return UNCOMPARED, "not compared"
    return g["kinds"][key], g["verdicts"][key]


@dataclass(frozen=True)
class Finding:
    case: str
    engine: str
    where: str          # "main" or the sweep point, e.g. "dt=0.0005"
    kind: str           # status | error | count | tolerance | trajectory | stale | new | slower | missing
    metric: str
    old: object
    new: object
    fatal: bool
    message: str


def rank(r):
    """ok < unsupported < every failure, by the run's typed outcome."""
    return STATUS_RANK.get(r["outcome"], 2)


def _figures(run):
    """The gated figures, and native's rates against its closed form where it has them."""
    out = {k: run.get(k) for k in GATED}
    out.update({k: run[k] for k in ("reference_velocity_error_rel", "reference_acceleration_error_rel")
                if run.get(k) is not None})
    return out


def grew(a, b) -> bool:
    """An error figure regressed from a to b (None: gone): grew beyond
    ERROR_FACTOR, counting only what lies above ERROR_FLOOR."""
    return b is None or b > ERROR_FACTOR * max(a, ERROR_FLOOR)


def _compare(case, engine, where, old, new, out):
    """old, new: {"status", "figures", "counts"}."""
    def add(kind, metric, a, b, message, fatal=True):
        out.append(Finding(case, engine, where, kind, metric, a, b, fatal, message))

    if rank(new) > rank(old):
        add("status", "status", old["status"], new["status"], f"status {old['status']!r} -> {new['status']!r}")
        return
    if rank(new) or rank(old):
        return
    for k, a in old["figures"].items():
        b = new["figures"].get(k)
        if a is None:
            continue
        if not math.isfinite(a):   # results.load rejects these; a baseline built in memory must not hide a check
            add("error", k, None, b, f"{k}: baseline figure {a} is not finite")
            continue
        if grew(a, b):
            add("error", k, a, b, f"{k} {a:.2e} -> " + ("none" if b is None else f"{b:.2e}"))
    for k, a in old["counts"].items():
        b = new["counts"].get(k)
        if b is not None and b > a:
            add("count", k, a, b, f"{k} {a} -> {b}")


@dataclass(frozen=True)
class Scope:
    """How this run was narrowed on purpose: what it may lack without failing."""
    cases: bool = False      # the case files are not the whole case set
    engines: bool = False    # --engines left some engines out
    sweeps: bool = False     # --quick: fewer work-precision points


def scope_of(doc) -> Scope:
    from adapters import ENGINES

    o = doc["options"]
    return Scope(cases=not o["whole_set"], engines=bool(set(ENGINES) - set(o["engines"])), sweeps=o["quick"])


def gate(current, baseline, path, fail_on_slowdown=False, scope: Scope | None = None, default=False) -> dict:
    """The 'gate' section of results.json: findings and a verdict per case and engine.
    scope: what the run may lack (default: from current's options); default:
    the baseline was found without --baseline."""
    scope = scope or scope_of(current)
    findings, verdicts, kinds = [], {}, {}

    def set_(key, kind, sentence):
        kinds[key], verdicts[key] = kind, sentence

    old_cases = {c["name"]: c for c in baseline["cases"]}
    not_compared = _missing(current, baseline, scope, findings)
    whole = current["options"]["whole_set"]
    typical_old, typical_new = typical(baseline), typical(current)
    for case in current["cases"]:
        name = case["name"]
        oc = old_cases.get(name)
        old_runs = {r["engine"]: r for r in oc["runs"]} if oc else {}
        if oc and oc["fingerprint"] != case["fingerprint"]:
            findings.append(Finding(name, "all", "main", "stale", "fingerprint", oc["fingerprint"],
                                    case["fingerprint"], True,
                                    f"case {name} changed: baseline stale (fingerprint {oc['fingerprint']} -> "
                                    f"{case['fingerprint']}; --update-baseline records it)"))
            for r in case["runs"]:
                set_(f"{name}/{r['engine']}", Verdict.REGRESSED, "REGRESSED: case changed: baseline stale")
            continue
        settings = _settings_changed(oc, case) if oc else None
        if settings:
            not_compared.append(f"{name}/native: cost counts and figures against the reference (solver settings "
                                f"changed: {settings}; its answers are compared at the baseline's tolerance)")
        start = len(findings)
        for run in case["runs"]:
            e = run["engine"]
            o = old_runs.get(e)
            if o is None:
                if whole:   # the whole set ran: the baseline should hold every run of it
                    findings.append(Finding(name, e, "main", "new", "run", None, run["status"], True,
                                            f"{name}/{e} is not in the baseline (--update-baseline records it)"))
                else:
                    _judged(name, None, run, findings)   # one verdict rule: outside its tolerance fails, new or not
                continue
            same = not (settings and e == "native")   # else its trajectory is what is compared
            _compare(name, e, "main",
                     {"status": o["status"], "outcome": o["outcome"], "figures": _figures(o) if same else {},
                      "counts": o["counts"] if same else {}},
                     {"status": run["status"], "outcome": run["outcome"], "figures": _figures(run),
                      "counts": run["counts"]},
                     findings)
            _trajectory(path, case, o, run, findings, settings and oc["solver"]["tolerance"])
            _new_figures(name, o, run, findings)
            skipped = _sweep(name, e, oc, case, findings, scope)
            if skipped:
                why = "--quick" if scope.sweeps else "not in this run's sweep: a regression"
                not_compared.append(f"{name}/{e}: {skipped} work-precision point(s) of the baseline ({why})")
            _judged(name, o, run, findings)
            slow = slower(name, o, run, typical_old, typical_new, fail_on_slowdown)
            if slow:
                findings.append(Finding(name, e, "main", "slower", *slow))
        _attribute(case, findings, start)
        for run in case["runs"]:
            e = run["engine"]
            mine = [f for f in findings[start:] if f.engine == e]
            if e not in old_runs and not whole:
                set_(f"{name}/{e}", *(verdict(mine) if any(f.fatal for f in mine) else (Verdict.NEW, "new")))
            else:
                set_(f"{name}/{e}", *verdict(mine))
    _equivalence(current, baseline, findings, set_, not_compared)
    for f in findings:   # a run the baseline has and this one lacks (fatal) marks its case/engine
        if f.kind == "missing" and f.fatal and f.where == "main":
            set_(f"{f.case}/{f.engine}", Verdict.REGRESSED, "REGRESSED: " + f.message)
    regressions = sum(f.fatal and f.kind != "slower" for f in findings)
    return {"baseline": str(path), "regressions": regressions,
            "slowdowns": sum(f.kind == "slower" for f in findings), "fail_on_slowdown": bool(fail_on_slowdown),
            "findings": [asdict(f) for f in findings], "verdicts": verdicts,
            "kinds": {k: v.value for k, v in kinds.items()}, "not_compared": not_compared,
            "default": bool(default)}


def _settings_changed(old_case, case) -> str:
    """'tolerance 1e-12 -> 1e-10, ...': the native solver's settings that
    differ from the baseline's (an edit of these alone is compared, not stale)."""
    a, b = old_case.get("solver") or {}, case.get("solver") or {}
    return ", ".join(f"{k} {a.get(k)} -> {b.get(k)}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k))


def _judged(name, old, new, findings):
    """One verdict rule (adapters.compare.Verdict.fails, as ``kinem compare``,
    the cells and JUnit): a run whose verdict fails (outside its tolerance,
    at the cost cap, native disagreeing with the engines' consensus) is a
    regression, unless the baseline records the same verdict (a known
    state): then only a figure worse than the baseline's fails."""
    from adapters.compare import Verdict as Judged

    try:
        v = Judged(new.get("verdict"))
    except ValueError:
        return
    if not v.fails or v is Judged.FAILED:   # a failed run is judged by its status (_compare, report._exit_code)
        return
    known = old is not None and old.get("verdict") == new.get("verdict")
    if v is Judged.DISAGREES:
        c = new["attributed"]
        was = (old or {}).get("attributed") or {}
        if known and was.get("figure") == c["figure"] and c["value"] <= WORSE * was["value"]:
            findings.append(Finding(name, "native", "main", "known", c["figure"], was["value"], c["value"], False,
                                    "known in the baseline: " + _consensus_text(dict(c, case=name))))
            return
        findings.append(Finding(name, "native", "main", "consensus", c["figure"], was.get("value"), c["value"], True,
                                _consensus_text(dict(c, case=name))))
        return
    tol = new.get("tolerance") or {}
    for k, limit in tol.items():
        b = new.get(k)
        if b is None or b <= limit:
            continue
        a = (old or {}).get(k)
        if known and a is not None and a > limit and b <= WORSE * a:
            findings.append(Finding(name, new["engine"], "main", "known", k, a, b, False,
                                    f"{name}/{new['engine']}: {k} {b:.2e} above its limit {limit:.0e}: known in the baseline ({a:.2e})"))
            continue
        was = ("within it in the baseline" if old is not None and a is not None and a <= limit
               else f"{a:.2e} in the baseline" if a is not None else "not in the baseline")
        findings.append(Finding(name, new["engine"], "main", "tolerance", k, limit, b, True,
                                f"{name}/{new['engine']} {new['verdict']}: {k} {b:.2e} above its limit {limit:.0e} ({was})"))


def _new_figures(name, old, new, findings):
    """Native's figures against a closed form the baseline's run did not
    have (a closed form new to the case, the rates against it): listed as
    new, not failing; a baseline recorded with them compares them."""
    from .runs import INDEPENDENT_KEYS

    keys = [k for k in INDEPENDENT_KEYS if k.endswith("_rel") and new.get(k) is not None and old.get(k) is None]
    if old.get("reference_kind", "native") != new.get("reference_kind", "native"):
        keys.insert(0, "position_error_rel")
    if keys and new["outcome"] == "ok":
        what = ", ".join(k.split("_")[-3] if k.startswith("reference_") else "position" for k in keys)
        findings.append(Finding(name, new["engine"], "main", "new", "figures", None, ", ".join(keys), False,
                                f"new: no baseline for its {what} against {new['reference']} "
                                "(--update-baseline records them)"))


def _consensus_text(c) -> str:
    when = "" if c.get("t") is None else f" at t = {c['t']:.6g} s"
    return (f"{c['case']}: native disagrees with the engines' consensus: {c['figure']} {c['value']:.2e} in {c['column']}{when} "
            f"against {', '.join(c['engines'])} (which agree within {c['spread']:.1e})")


def _attribute(case, findings, start):
    """Engines' findings that native explains: when native moved (its
    trajectory, or it disagrees with the engines' consensus) and an engine's
    own trajectory did not, the engine's figures against native and its
    cost counts (its first step follows native's rates) changed because
    native did. Those findings stay listed, not fatal ("attributed")."""
    mine = findings[start:]
    moved_native = [f for f in mine if f.engine == "native" and f.fatal and f.kind in ("trajectory", "consensus")]
    if not moved_native:
        return
    engines_moved = {f.engine for f in mine if f.kind == "trajectory" and f.engine != "native"}
    cause = moved_native[0]
    for k in range(start, len(findings)):
        f = findings[k]
        if f.engine in ("native", "all") or f.engine in engines_moved or f.kind not in ("error", "tolerance", "count"):
            continue
        findings[k] = dataclasses.replace(
            f, kind="attributed", fatal=False,
            message=f"{f.message}: consistent (its own trajectory did not move; native's {cause.metric} did)")


def _trajectory(path, case, old, new, findings, settings_tolerance=None):
    """Every column of the compact trajectories of two ok runs, scale-free:
    native may move by NATIVE_MOVE (positions, angles) and NATIVE_RATE_MOVE
    (velocities, accelerations), or, when only its solver settings changed,
    by SETTINGS_SLACK x the baseline's tolerance; an engine by its
    tolerance on each figure. A column or instant the baseline lacks is an
    edited baseline: InputError naming the file, the case and the key."""
    from adapters.compare import FIGURE_OF

    from ..errors import InputError
    from ..fingerprint import UNITS

    a, b = old.get("trajectory"), new.get("trajectory")
    if a is None or b is None or rank(old) or rank(new):
        return
    name, e = case["name"], new["engine"]
    where = f"baseline {path}: cases.{name}.runs.{e}.trajectory"
    if a["t"] != b["t"]:
        raise InputError(f"{where}.t: instants {a['t'][:3]}…; expected this run's {b['t'][:3]}… (re-timed)")
    lost = sorted(set(b["columns"]) - set(a["columns"]))
    if lost:
        raise InputError(f"{where}.columns: no column '{lost[0]}'" + (f" (+{len(lost) - 1} more)" if len(lost) > 1 else "")
                         + "; expected every column of the run")
    if e == "native":
        limits = {k: NATIVE_MOVE if k in ("position", "angle") else NATIVE_RATE_MOVE for k in UNITS}
        if settings_tolerance:
            limits = {k: max(v, SETTINGS_SLACK * settings_tolerance) for k, v in limits.items()}
    else:
        tol = new.get("tolerance") or {}
        limits = {k: tol[f] for k, f in FIGURE_OF.items() if f in tol}
    m = moved(a, b, case["length"], case["speed"], limits)
    if m is None:
        return
    column, d, unit, t, limit = m
    when = "" if t is None else f" at t = {t:.6g} s"
    who = "native (a regression of native)" if e == "native" else e
    findings.append(Finding(name, e, "main", "trajectory", column, limit, d, True,
                            f"{name}: {who}: {column} moved by {d:.2e} {unit}{when} (limit {limit:.0e} {unit})"))


def _equivalence(current, baseline, findings, set_, not_compared):
    """The equivalence groups' max deviation against the baseline's, as an
    error figure: a regression when it grew beyond ERROR_FACTOR x max(old,
    ERROR_FLOOR) (the gate owns this rule; equivalence.py only measures)."""
    old = {e["group"]: e for e in baseline.get("equivalence") or []}
    for e in current.get("equivalence") or []:
        o = old.get(e["group"])
        key = f"equivalence/{e['group']}"
        if o is None:
            set_(key, Verdict.NEW, "new")
            continue
        before = len(findings)
        a, b = o["max_deviation_rel"], e["max_deviation_rel"]
        if a is not None and grew(a, b):
            findings.append(Finding(e["group"], "native", "equivalence", "error", "max_deviation_rel", a, b, True,
                                    f"group {e['group']}: deviation / L {a:.2e} -> "
                                    + ("none" if b is None else f"{b:.2e}")))
        set_(key, *verdict(findings[before:]))
    names = {e["group"] for e in current.get("equivalence") or [] if e["max_deviation_rel"] is not None}
    for g in old:
        if g not in names and old[g]["max_deviation_rel"] is not None:
            not_compared.append(f"equivalence group {g}: not all of its cases in this run")


def _missing(current, baseline, scope, findings) -> list:
    """Baseline cases and engine runs this run lacks: a 'missing' finding
    each (fatal unless scope allows it); returns the not-compared lines."""
    now = {c["name"]: {r["engine"] for r in c["runs"]} for c in current["cases"]}
    engines_run = {"native", *current["options"]["engines"]}
    out, lost_cases, lost_engines = [], [], {}
    for oc in baseline["cases"]:
        name = oc["name"]
        if name not in now:
            lost_cases.append(name)
            findings.append(Finding(name, "all", "main", "missing", "case", "run", None, not scope.cases,
                                    "in the baseline, not in this run"))
            continue
        for r in oc["runs"]:
            e = r["engine"]
            if e in now[name]:
                continue
            narrowed = scope.engines and e not in engines_run
            lost_engines.setdefault(e, []).append(name)
            findings.append(Finding(name, e, "main", "missing", "run", r["status"], None, not narrowed,
                                    "in the baseline, not run" + (" (--engines)" if narrowed else "")))
    if lost_cases:
        why = "case files given" if scope.cases else "NOT RUN: a case of the whole set is gone"
        out.append(f"{len(lost_cases)} baseline case(s) ({why}): {', '.join(lost_cases)}")
    for e, names in lost_engines.items():
        why = "--engines" if scope.engines and e not in engines_run else "NOT RUN"
        out.append(f"engine {e} ({why}): {len(names)} case(s)" + (f": {', '.join(names)}" if len(names) < 5 else ""))
    return out


def _sweep(name, engine, oc, case, findings, scope) -> int:
    """Compares the work-precision points both have, matched by their full
    knob setting (dt and the engine's other knobs, or native's tolerance); a
    baseline point this run lacks is a missing finding (fatal unless --quick).
    Returns how many it lacks."""
    new = _points(case, engine)
    names = {k for key in new for k, _ in key}
    old = _points(oc, engine, names)
    lacking = sorted(set(old) - set(new), key=str)
    for key in lacking:
        findings.append(Finding(name, engine, _where(key), "missing", "point", old[key]["status"], None,
                                not scope.sweeps, "work-precision point in the baseline, not in this run"))
    for key in sorted(set(old) & set(new), key=str):
        a, b = old[key], new[key]
        _compare(name, engine, _where(key),
                 {"status": a["status"], "outcome": a["outcome"], "figures": _point_figures(a), "counts": a["counts"]},
                 {"status": b["status"], "outcome": b["outcome"], "figures": _point_figures(b), "counts": b["counts"]},
                 findings)
    return len(lacking)


def _points(case, engine, names=()):
    """{knob setting: point} of one engine's work-precision curves. A point
    without ``knobs`` (a report written before the knob families) swept its
    curve's knob alone on the defaults: its other knobs (``names``) are
    taken from the case's main run's settings."""
    main = next((r for r in case["runs"] if r["engine"] == engine), {})
    out = {}
    for curve in (case.get("work_precision") or {}).get("curves", ()):
        if curve["engine"] != engine:
            continue
        for p in curve["points"]:
            knobs = p.get("knobs")
            if knobs is None:
                knobs = {k: (main.get("settings") or {}).get(k) for k in names if k != curve["knob"]}
                knobs[curve["knob"]] = p["value"]
            out[_key(knobs)] = p
    return out


def _key(knobs):
    """A knob setting as a hashable key; numbers to 6 significant digits."""
    num = lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)   # noqa: E731
    return tuple(sorted((k, float(f"{v:.6g}") if num(v) else v) for k, v in knobs.items()))


def _where(key):
    """'dt=0.0005, integrator=RK4': the step or tolerance first."""
    first = ("dt", "tolerance")
    items = sorted(key, key=lambda kv: (kv[0] not in first, kv[0]))
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in items)


def _point_figures(p):
    return {"position_error_rel": p["error"], "velocity_error_rel": p["velocity_error_rel"]}


def verdict(findings) -> tuple:
    """(Verdict, sentence) of one case/engine's findings."""
    # the finding that says most first: a moved trajectory or the consensus names the column and instant
    fatal = sorted((f for f in findings if f.fatal), key=lambda f: f.kind not in ("trajectory", "consensus"))
    if fatal:
        f = fatal[0]
        more = f" (+{len(fatal) - 1} more)" if len(fatal) > 1 else ""
        where = "" if f.where == "main" else f"{f.where}: "
        return Verdict.REGRESSED, f"REGRESSED: {where}{f.message}{more}"
    slow = [f for f in findings if f.kind == "slower"]
    if slow:
        return Verdict.SLOWER, f"pass, slower x{slow[0].new / slow[0].old:.1f}"
    new = [f for f in findings if f.kind == "new"]
    if new:
        return Verdict.NEW, new[0].message
    return Verdict.PASS, "pass"


def failed(gate_section) -> bool:
    """Whether the gate fails the run (regressions, or slowdowns when asked)."""
    return bool(gate_section) and any(f["fatal"] for f in gate_section["findings"])
