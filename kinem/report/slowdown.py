"""The gate's wall-time check: a slowdown is flagged only when a same-run
reference and repeats confirm it, so that reruns of identical code flag
nothing (docs/report.md, "The baseline gate")."""

# Shared CI machines vary by up to about 1.5x from run to run, and load
# moves every case alike: a case's time relative to the run's median is
# steadier (the flag compares that ratio, see slower).
SLOWDOWN_FACTOR = 2.0
# Baseline runs shorter than this are dominated by timer and scheduler noise.
WALL_FLOOR = 0.01
REPEATS = 3   # a suspected slowdown is timed again this many times, in turn with a reference case


def typical(doc) -> dict:
    """{engine: {case: time per engine step}} of the run's ok main runs: the
    same-run reference a case's time is measured against."""
    per = {}
    for c in doc["cases"]:
        for r in c["runs"]:
            if r.get("time_per_step") and r["outcome"] == "ok":
                per.setdefault(r["engine"], {})[c["name"]] = r["time_per_step"]
    return per


def _others(per, engine, case):
    """The engine's median time per step over the run's other cases (None without any)."""
    import statistics

    rest = [v for k, v in per.get(engine, {}).items() if k != case]
    return statistics.median(rest) if rest else None


def _ratios(name, old, new, typical_old, typical_new):
    """(baseline ratio, this run's ratio, reference) of an engine run's time
    per step to the engine's median over the run's other cases; the
    reference is this run's confirming repeat (``confirm``) when it has one:
    its ratio to a reference case timed alternately with it in one process."""
    a, b = old.get("time_per_step"), new.get("time_per_step")
    if not (a and b) or (old.get("wall_time") or 0) < WALL_FLOOR:
        return None
    e = new["engine"]
    na, nb = _others(typical_old, e, name), _others(typical_new, e, name)
    if not (na and nb):
        return None
    rep = new.get("retimed")
    if rep:   # the repeats: both min over alternating runs; the baseline's ratio to the same reference case
        ref_old = typical_old.get(e, {}).get(rep["reference_case"])
        if ref_old:
            return a / ref_old, rep["time_per_step"] / rep["reference_time_per_step"], rep
    return a / na, b / nb, None


def suspects(current, baseline) -> list:
    """(case, engine) of the engine runs a first look flags as slower (their
    ratio to the engine's median grew beyond SLOWDOWN_FACTOR): the report
    times each again against a reference case before the gate judges it."""
    old = {(c["name"], r["engine"]): r for c in baseline["cases"] for r in c["runs"]}
    typical_old, typical_new = typical(baseline), typical(current)
    out = []
    for c in current["cases"]:
        for r in c["runs"]:
            o = old.get((c["name"], r["engine"]))
            if r["engine"] == "native" or o is None or r["outcome"] != "ok":
                continue
            got = _ratios(c["name"], o, r, typical_old, typical_new)
            if got and got[1] > SLOWDOWN_FACTOR * got[0]:
                out.append((c["name"], r["engine"]))
    return out


def reference_case(current, engine, case):
    """The engine's case whose time per step is the median of the others' (the same-run reference)."""
    per = sorted((v, k) for k, v in typical(current).get(engine, {}).items() if k != case)
    return per[len(per) // 2][1] if per else None


def slower(name, old, new, typical_old, typical_new, fail_on_slowdown):
    """A slowdown, measured so that machine load cancels: an engine's time
    per step on this case relative to its median over the run's other cases
    (the same run, the same machine load), against the same ratio in the
    baseline; confirmed by repeats (the report times a suspect again, in
    turn with a reference case, and keeps the fastest of each; the fastest
    must also be slower than the baseline's own time), so that reruns of
    identical code flag nothing. (Native's time is no reference
    for the engines: it moves 10-20x between runs.) Native's own time is
    compared as it is, only with --fail-on-slowdown. Returns the gate's
    Finding fields after (case, engine, where, kind): (metric, old, new,
    fatal, message), or None."""
    a, b = old.get("time_per_step"), new.get("time_per_step")
    if not (a and b) or (old.get("wall_time") or 0) < WALL_FLOOR:
        return None
    e = new["engine"]
    if e == "native":
        if fail_on_slowdown and b > SLOWDOWN_FACTOR * a:
            return ("time_per_step", a, b, True, f"time per step x{b / a:.1f} ({1e6 * a:.3g} -> {1e6 * b:.3g} us)")
        return None
    got = _ratios(name, old, new, typical_old, typical_new)
    if not got:
        return None
    ra, rb, rep = got
    # a repeat must also be slower than the baseline's own time: the baseline's times are single runs (the
    # first run of an engine in a process pays its warm-up), so its ratio alone can flag identical code
    if rb > SLOWDOWN_FACTOR * ra and (not rep or rep["time_per_step"] > SLOWDOWN_FACTOR * a):
        against = (f"{rep['reference_case']} timed in turn with it, fastest of {rep['repeats']}" if rep
                   else f"{e}'s median over the run's other cases")
        return ("time_per_step / the engine's median", ra, rb, bool(fail_on_slowdown),
                f"time per step relative to {against} x{rb / ra:.1f} ({ra:.3g} -> {rb:.3g}, same run)")
    return None


def confirm(doc, old, cases):
    """Times each engine run the gate suspects of a slowdown (``suspects``)
    again, REPEATS times in this process in turn with the engine's reference
    case (``reference_case``), and records the fastest of each as the run's
    ``retimed``: the gate judges the ratio of the two, so that the load of
    the run's other work cancels and reruns of identical code flag nothing."""
    from .runs import Task, run_task

    paths = {c.name: p for p, c, _ in cases}
    by_name = {c["name"]: c for c in doc["cases"]}
    for name, engine in suspects(doc, old):
        ref = reference_case(doc, engine, name)
        if ref is None:
            continue
        mine, theirs = [], []
        for _ in range(REPEATS):
            for path, into in ((paths[name], mine), (paths[ref], theirs)):
                r = run_task(Task(path, engine))
                if r["outcome"] == "ok" and r.get("time_per_step"):
                    into.append(r["time_per_step"])
        if mine and theirs:
            run = next(r for r in by_name[name]["runs"] if r["engine"] == engine)
            run["retimed"] = {"reference_case": ref, "time_per_step": min(mine),
                              "reference_time_per_step": min(theirs), "repeats": len(mine)}
