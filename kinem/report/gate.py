"""The baseline gate: this run's results.json against a stored one.

A regression (exit code 1) is, for a case and engine present in both:
- a status that got worse: ok < unsupported < failed;
- an error or residual that grew by more than ERROR_FACTOR, counting only
  what lies above ERROR_FLOOR (new > ERROR_FACTOR * max(old, ERROR_FLOOR));
- a deterministic cost count that grew at all (Newton iterations, Jacobian
  evaluations, factorisations; engine steps and substeps).
The same rules apply to every work-precision point both runs have (its
position and velocity errors and its counts). Wall time is only flagged: time per step more than
SLOWDOWN_FACTOR times the baseline's is a slowdown, fatal only with
--fail-on-slowdown. Cases, engines or points missing from either side are
not compared (a --quick run has fewer sweep points than the full baseline).
"""
from dataclasses import asdict, dataclass

# Errors and residuals are relative to L (or radians, rad/s, scaled residual
# units); below 1e-12 they are rounding noise (the reference itself is only
# converged to 1e-13) and differ between machines and BLAS builds.
ERROR_FLOOR = 1e-12
# Engines and the native solver are deterministic for pinned versions, so an
# error does not move by itself; a factor 2 leaves room for other platforms'
# rounding while catching a formulation or adapter change (those move errors
# by orders of magnitude).
ERROR_FACTOR = 2.0
# Shared CI machines vary by up to about 1.5x from run to run.
SLOWDOWN_FACTOR = 2.0
# Baseline runs shorter than this are dominated by timer and scheduler noise.
WALL_FLOOR = 0.01
STATUS_RANK = {"ok": 0, "unsupported": 1}   # anything else ("failed: ...") ranks 2
GATED = ("position_error_rel", "angle_error", "velocity_error_rel", "angular_velocity_error", "constraint_residual")


@dataclass(frozen=True)
class Finding:
    case: str
    engine: str
    where: str          # "main" or the sweep point, e.g. "dt=0.0005"
    kind: str           # status | error | count | slower
    metric: str
    old: object
    new: object
    fatal: bool
    message: str


def rank(status):
    return STATUS_RANK.get(status.split(":", 1)[0].strip(), 2)


def _figures(run):
    return {k: run.get(k) for k in GATED}


def _compare(case, engine, where, old, new, out):
    """old, new: {"status", "figures", "counts"}."""
    def add(kind, metric, a, b, message, fatal=True):
        out.append(Finding(case, engine, where, kind, metric, a, b, fatal, message))

    if rank(new["status"]) > rank(old["status"]):
        add("status", "status", old["status"], new["status"], f"status {old['status']!r} -> {new['status']!r}")
        return
    if rank(new["status"]) or rank(old["status"]):
        return
    for k, a in old["figures"].items():
        b = new["figures"].get(k)
        if a is None:
            continue
        if b is None or b > ERROR_FACTOR * max(a, ERROR_FLOOR):
            add("error", k, a, b, f"{k} {a:.2e} -> " + ("none" if b is None else f"{b:.2e}"))
    for k, a in old["counts"].items():
        b = new["counts"].get(k)
        if b is not None and b > a:
            add("count", k, a, b, f"{k} {a} -> {b}")


def gate(current, baseline, path, fail_on_slowdown=False) -> dict:
    """The 'gate' section of results.json: findings and a verdict per case and engine."""
    findings, verdicts = [], {}
    old_cases = {c["name"]: c for c in baseline["cases"]}
    for case in current["cases"]:
        name = case["name"]
        oc = old_cases.get(name)
        old_runs = {r["engine"]: r for r in oc["runs"]} if oc else {}
        for run in case["runs"]:
            e = run["engine"]
            before = len(findings)
            o = old_runs.get(e)
            if o is None:
                verdicts[f"{name}/{e}"] = "new"
                continue
            _compare(name, e, "main",
                     {"status": o["status"], "figures": _figures(o), "counts": o["counts"]},
                     {"status": run["status"], "figures": _figures(run), "counts": run["counts"]},
                     findings)
            _sweep(name, e, oc, case, findings)
            a, b = o.get("time_per_step"), run.get("time_per_step")
            if a and b and (o.get("wall_time") or 0) >= WALL_FLOOR and b > SLOWDOWN_FACTOR * a:
                findings.append(Finding(name, e, "main", "slower", "time_per_step", a, b, bool(fail_on_slowdown),
                                        f"time per step x{b / a:.1f} ({1e6 * a:.3g} -> {1e6 * b:.3g} us)"))
            verdicts[f"{name}/{e}"] = verdict(findings[before:])
    regressions = sum(f.fatal and f.kind != "slower" for f in findings)
    return {"baseline": str(path), "regressions": regressions,
            "slowdowns": sum(f.kind == "slower" for f in findings), "fail_on_slowdown": bool(fail_on_slowdown),
            "findings": [asdict(f) for f in findings], "verdicts": verdicts}


def _sweep(name, engine, oc, case, findings):
    def points(c):
        wp = c.get("work_precision") or {}
        for curve in wp.get("curves", ()):
            if curve["engine"] == engine:
                return {(curve["knob"], float(f"{p['value']:.6g}")): p for p in curve["points"]}
        return {}

    old, new = points(oc), points(case)
    for key in sorted(set(old) & set(new)):
        a, b = old[key], new[key]
        _compare(name, engine, f"{key[0]}={key[1]:g}",
                 {"status": a["status"], "figures": _point_figures(a), "counts": a["counts"]},
                 {"status": b["status"], "figures": _point_figures(b), "counts": b["counts"]},
                 findings)


def _point_figures(p):
    return {"position_error_rel": p["error"], "velocity_error_rel": p["velocity_error_rel"]}


def verdict(findings) -> str:
    fatal = [f for f in findings if f.fatal]
    if fatal:
        f = fatal[0]
        more = f" (+{len(fatal) - 1} more)" if len(fatal) > 1 else ""
        where = "" if f.where == "main" else f"{f.where}: "
        return f"REGRESSED: {where}{f.message}{more}"
    slow = [f for f in findings if f.kind == "slower"]
    return f"pass, slower x{slow[0].new / slow[0].old:.1f}" if slow else "pass"


def failed(gate_section) -> bool:
    """Whether the gate fails the run (regressions, or slowdowns when asked)."""
    return bool(gate_section) and any(f["fatal"] for f in gate_section["findings"])
