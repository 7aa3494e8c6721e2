"""summary.md (GitHub-flavoured Markdown for a CI job summary) and junit.xml
(one test case per case x engine); the summary matrix and headline both
summary.md and index.html show."""
from .escaping import md, xml_attr, xml_text
from .gate import NO_BASELINE, UNCOMPARED, verdict_of


def fmt(x, spec=".1e"):
    return "–" if x is None else format(x, spec)


def us(x):
    return "–" if x is None else f"{1e6 * x:.3g}"


def short(status, n=60):
    return status if len(status) <= n else status[:n - 1] + "…"


def failed(r) -> bool:
    """A run or sweep point that failed in any way (its typed outcome)."""
    return r["outcome"] not in ("ok", "unsupported")


def unsupported(r) -> bool:
    return r["outcome"] == "unsupported"


def rows(doc):
    """(case, run, verdict) for every main run, in report order."""
    for c in doc["cases"]:
        for r in c["runs"]:
            yield c, r, verdict_of(doc, f"{c['name']}/{r['engine']}")


def engines_of(doc):
    return ["native"] + list(doc["options"]["engines"])


SELF = "no independent reference"
CONSENSUS = "native disagrees with the engines' consensus"
# The summary figure's candidates, scale-free (docs/engines.md), and how a cell names them.
SUMMARY = {"position_error_rel": "position / L", "angle_error": "angle, rad", "velocity_error_rel": "velocity / V",
           "angular_velocity_error_rel": "angular velocity / (V/L)"}


def verdict(run):
    """A run's adapters.compare.Verdict (the one verdict rule)."""
    from adapters.compare import Verdict

    return Verdict(run["verdict"])


def figure(run) -> tuple:
    """A run's summary figure: (value, what) with the worst scale-free error
    over positions / L, angles (rad), velocities / V and angular velocities
    / (V / L), naming which. Native's figures are against native itself
    unless the case has a closed form or an equivalence group: then (None,
    SELF), never a green 0; with one, its positions against it; when it
    disagrees with the engines' consensus, that figure."""
    from .runs import Reference

    if run["outcome"] != "ok":
        return None, ""
    if run["engine"] == "native":
        if run.get("attributed"):
            a = run["attributed"]
            return a["value"], f"{SUMMARY.get(a['figure'], a['figure'])} against the engines"
        if Reference(run["reference_kind"]) is Reference.NATIVE:
            return None, SELF
        return run["position_error_rel"], "position / L"
    shown = [(run.get(k), what) for k, what in SUMMARY.items() if run.get(k) is not None]
    return max(shown, key=lambda x: x[0]) if shown else (None, "")


def rates(run, brief=False) -> str:
    """Native's velocity and acceleration errors against its closed form,
    '' where it has none."""
    v, a = run.get("reference_velocity_error_rel"), run.get("reference_acceleration_error_rel")
    if v is None and a is None:
        return ""
    if brief:
        return f"v {fmt(v)}, a {fmt(a)} of peak"
    return f"velocity {fmt(v)}, acceleration {fmt(a)} of the peak against the closed form"


def limits_text() -> str:
    """Native's limits against a closed form, in words."""
    from adapters.references import LIMITS

    return (f"{LIMITS['position_error_rel']:.0e} of L in position, {LIMITS['reference_velocity_error_rel']:.0e} "
            f"(velocity) and {LIMITS['reference_acceleration_error_rel']:.0e} (acceleration) of the peak")


def exceeded(run) -> list:
    """(metric, value, limit) of every figure above the run's tolerance."""
    return [(k, run.get(k), limit) for k, limit in (run.get("tolerance") or {}).items()
            if run.get(k) is not None and run[k] > limit]


def exceeded_text(run) -> str:
    return "; ".join(f"{k} {v:.2e} > {limit:.0e}" for k, v, limit in exceeded(run))


def seconds(per) -> str:
    return "–" if per is None else f"{1e3 * per:.3g} ms" if per >= 1e-3 else f"{us(per)} µs"


def cost(run) -> str:
    """What the user paid, like for like: the whole run's wall time per output
    interval (the adapter's own Python included), and the engine steps per
    interval counting every attempt (refinements included)."""
    per = run.get("cost_per_interval", run.get("time_per_interval"))
    if per is None:
        return "–"
    steps = run.get("steps_per_interval") or (run.get("counts") or {}).get("substeps", 1)
    return f"{seconds(per)}/interval ({steps:.3g} step{'s' if steps != 1 else ''})"


def fails(run, kind) -> bool:
    """Whether a run fails the report: a failed run or a gate regression; and
    without a baseline, a run whose verdict fails (outside its tolerance,
    at the cost cap, native off the engines' consensus): the same rule as
    ``kinem compare`` and the gate (adapters.compare.Verdict.fails)."""
    if failed(run) or kind == "regressed":
        return True
    return kind in (NO_BASELINE, UNCOMPARED) and verdict(run).fails


def grade(run, kind) -> str:
    """A cell's class: bad (fails), skip (unsupported), warn (new, or a
    known failing state the baseline records), slow (slower than the
    baseline, not failing), self (native without an independent
    reference), ok (consistent with the engines' consensus included)."""
    if fails(run, kind):
        return "bad"
    if unsupported(run):
        return "skip"
    if kind == "new" or verdict(run).fails:
        return "warn"
    if kind == "slower":
        return "slow"
    if figure(run)[1] == SELF:   # nothing independent checked it: neither green nor a warning
        return "self"
    return "ok"


def judgement(run) -> str:
    """The run's verdict with what it rests on: the figures over their
    limits, or the engines' consensus."""
    v = verdict(run)
    if run.get("attributed") and v.value in (CONSENSUS, "consistent with the engines' consensus"):
        a = run["attributed"]
        when = "" if a.get("t") is None else f" at t = {a['t']:.6g} s"
        return (f"{v.value}: {a['figure']} {a['value']:.2e} ({a['column']}{when}) against "
                f"{', '.join(a['engines'])}")
    if exceeded(run):
        return f"{v.value}: {exceeded_text(run)}"
    return v.value


def matrix(doc):
    """The summary matrix: (engines, [(case, {engine: (run, verdict, grade)})],
    {engine: {reason: ([joint types], [cases])}} of the unsupported runs).
    Cases with a failed or regressed run come first, then the rest; each
    part by case name (never by warnings or speed: two reports of the same
    code list the cases in the same order)."""
    engines, rows, skipped = engines_of(doc), [], {}
    for c in doc["cases"]:
        cells = {}
        for r in c["runs"]:
            v = verdict_of(doc, f"{c['name']}/{r['engine']}")
            cells[r["engine"]] = (r, v, grade(r, v[0]))
            if unsupported(r) and v[0] != "regressed":
                what, why = reason(r)
                types, names = skipped.setdefault(r["engine"], {}).setdefault(why, ([], []))
                types += [what] if what not in types else []
                names.append(c["name"])
        rows.append((c, cells))
    rows.sort(key=lambda row: (all(g != "bad" for _, _, g in row[1].values()), row[0]["name"]))
    return engines, rows, skipped


def reason(run) -> tuple:
    """An unsupported run's reason as (constraint type, why without the
    constraint's own name), so that cases share it: the run's typed
    ``reason`` (adapters.base.Reason); a file written before it had one
    gives ("", its detail)."""
    return tuple(run.get("reason") or ("", run["detail"]))


def unsupported_lines(unsupported):
    """{engine: "why (types: cases); ..."} for the lines under the matrix."""
    return {e: "; ".join(f"{', '.join(t for t in types if t)}: {why} ({', '.join(names)})"
                         for why, (types, names) in reasons.items())
            for e, reasons in unsupported.items()}


def counts(doc):
    runs = [r for _, r, _ in rows(doc)]
    ok = sum(r["outcome"] == "ok" for r in runs)
    bad = sum(failed(r) for r in runs)
    return len(runs), ok, bad, len(runs) - ok - bad


def passed(doc) -> bool:
    """The headline's verdict: no failed run, regression, engine that did not
    import, nor native stress miss."""
    g = doc.get("gate")
    return not (counts(doc)[2] or (g and g["regressions"]) or (doc.get("stress") or {}).get("native_misses")
                or any(e["outcome"] != "ok" for e in doc["engines"].values())
                or any(fails(r, v[0]) for _, r, v in rows(doc)))


def headline(doc) -> str:
    """One sentence: the verdict, then what it covers."""
    n, ok, n_failed, n_unsupported = counts(doc)
    g = doc.get("gate")
    regressions = g["regressions"] if g else 0
    misses = len((doc.get("stress") or {}).get("native_misses", ()))
    verdict = "PASS" if passed(doc) else "FAILED"
    what = (f"{len(doc['cases'])} case(s) on {', '.join(engines_of(doc))}: {ok} of {n} runs ok, {n_failed} failed, "
            f"{n_unsupported} unsupported")
    if g:
        mine = sum(f["fatal"] and f["kind"] != "slower" and f["engine"] == "native" for f in g["findings"])
        base = (f"{regressions} regression(s)" + (f" ({mine} of native)" if mine else "")
                + f", {g['slowdowns']} slowdown(s) against {g['baseline']}"
                + (" (found by default; --baseline none skips it)" if g.get("default") else ""))
        if g.get("not_compared"):
            base += f"; {len(g['not_compared'])} thing(s) not compared (listed below)"
    else:
        base = "no baseline, so no regression check"
    stress = ""
    if doc.get("stress"):
        stress = "; stress suite: " + ("native met every expectation" if not misses
                                       else f"native missed {misses} expectation(s)")
    return f"{verdict}: {what}; {base}{stress}."


def provenance(doc) -> str:
    g = doc["git"]
    if not g.get("repository") and not g["revision"]:
        rev = "cases' repository: none"
    elif not g["revision"]:
        rev = "cases' repository: no commits yet"
    else:
        rev = "cases' repository: " + g["revision"][:10] + (" (dirty)" if g["dirty"] else "")
    version = doc.get("machine", {}).get("packages", {}).get("kinem")
    rev += f"; kinem {version}" if version else ""
    m = doc["machine"]
    return (f"{rev}; {m['cpu']}, {m['cores']} cores; {doc['duration']:.0f} s"
            + (" (--quick)" if doc["options"]["quick"] else ""))


def summary_md(doc) -> str:
    out = ["## kinem report", "", f"**{md(headline(doc))}**", "", md(provenance(doc)), ""]
    g = doc.get("gate")
    fatal = [f for f in (g or {}).get("findings", ()) if f["fatal"]]
    if g and g["not_compared"]:
        out += ["### Not compared (in the baseline, not in this run)", ""] + [f"- {md(x)}" for x in g["not_compared"]] + [""]
    if fatal:
        out += [f"### Regressions ({len(fatal)})", ""]
        out += [f"- **{md(f['case'])} / {md(f['engine'])}** ({md(f['where'])}): {md(f['message'])}" for f in fatal[:30]]
        out += [f"- … and {len(fatal) - 30} more (results.json)"] if len(fatal) > 30 else []
        out.append("")
    lost = {}
    for c, r, _ in rows(doc):  # one line per engine and distinct failure (an import error fails every case)
        if failed(r):
            lost.setdefault((r["engine"], r["status"]), []).append(c["name"])
    if lost:
        out += ["### Failed runs", ""]
        out += [f"- **{md(e)}** ({md(', '.join(names)) if len(names) < 4 else f'{len(names)} cases'}): {md(short(st, 200))}"
                for (e, st), names in lost.items()]
        out.append("")
    slow = [f for f in (g or {}).get("findings", ()) if f["kind"] == "slower" and not f["fatal"]]
    if slow:
        out += ["### Slower (not failing)", ""]
        out += [f"- {md(f['case'])} / {md(f['engine'])}: {md(f['message'])}" for f in slow] + [""]
    from .stress_section import line as stress_line

    if doc.get("stress"):
        out += [stress_line(doc), ""]
    from .equivalence import line as groups_line

    if doc.get("equivalence"):
        out += [groups_line(doc), ""]
    engines, table, skipped = matrix(doc)
    out += ["| case | " + " | ".join(engines) + " |", "|---|" + "---:|" * len(engines)]
    for c, cells in table:
        out.append(f"| {md(c['name'])} | " + " | ".join(_md_cell(cells.get(e)) for e in engines) + " |")
    if skipped:
        out += ["", "Not supported (–):"]
        out += [f"- **{md(e)}**: {md(text)}" for e, text in unsupported_lines(skipped).items()]
    out += ["", "Cells: the worst error over every coordinate that moves (positions / L, bodies' angles in rad; "
            "velocities / V, angular velocities / (V/L): the worst named; engines against native at tolerance "
            "1e-13; native against the closed form or equivalence group where the case has one, or the engines' "
            "consensus when it disagrees with it, else \"no independent reference\"; with a closed form also its "
            "velocities (v) and accelerations (a), each / the closed form's peak, and native fails above "
            f"{limits_text()}), then the whole run's wall "
            "time per output interval and the engine steps per interval (every attempt); ◦ native without an independent reference, ✅ pass or ok, ⚠️ new or "
            "outside the engine's tolerance (the metric, value and limit named), 🐢 slower than the baseline (not failing), ❌ failed or regressed. "
            "Details, plots and work-precision diagrams: index.html."]
    return "\n".join(out) + "\n"


MARK = {"ok": "✅", "warn": "⚠️", "slow": "🐢", "bad": "❌", "skip": "–", "self": "◦"}


def _md_cell(cell) -> str:
    if cell is None:
        return "not run"
    r, v, g = cell
    if g == "skip":
        return "–"
    if failed(r):
        return md(f"❌ {short(r['status'], 40)}")
    value, what = figure(r)
    text = f"{MARK[g]} " + (what if value is None else f"{fmt(value)} ({what})") + f", {cost(r)}"
    if rates(r) and not r.get("attributed"):
        text += f"; {rates(r, brief=True)}"
    if verdict(r).fails or r.get("attributed"):
        text += f" ({short(judgement(r), 120)})"
    kind, sentence = v
    if kind == "regressed":
        text += f" ({short(sentence, 80)})"
    elif kind in ("new", "slower"):
        text += f" ({sentence})"
    return md(text)


def junit_xml(doc) -> str:
    cases, n_failed, skips = [], 0, 0
    for c, r, v in rows(doc):
        body = ""
        if fails(r, v[0]):
            n_failed += 1
            msg = r["status"] if failed(r) else v[1] if v[0] == "regressed" else judgement(r)
            body = f"<failure message={xml_attr(msg)}/>"
        elif r["outcome"] == "ok" and (verdict(r).fails or r.get("attributed") or figure(r)[1] == SELF):
            # a known state of the baseline, consistent with the consensus, or native checked only by itself
            body = f"<system-out>{xml_text(judgement(r))}</system-out>"
        elif unsupported(r):
            skips += 1
            body = f"<skipped message={xml_attr(r['status'])}/>"
        cases.append(f'  <testcase classname={xml_attr("kinem.report." + c["name"])} name={xml_attr(r["engine"])} '
                     f'time="{r["wall_time"] or 0:.6f}">{body}</testcase>')
    head = (f'<testsuite name="kinem report" tests="{len(cases)}" failures="{n_failed}" skipped="{skips}" '
            f'errors="0" time="{doc["duration"]:.3f}">')
    return "\n".join(['<?xml version="1.0" encoding="UTF-8"?>', "<testsuites>", head, *cases,
                      "</testsuite>", "</testsuites>"]) + "\n"
