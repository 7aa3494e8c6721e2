"""summary.md (GitHub-flavoured Markdown for a CI job summary) and junit.xml
(one test case per case x engine); the summary matrix and headline both
summary.md and index.html show."""
import re
from xml.sax.saxutils import quoteattr


def fmt(x, spec=".1e"):
    return "–" if x is None else format(x, spec)


def us(x):
    return "–" if x is None else f"{1e6 * x:.3g}"


def short(status, n=60):
    return status if len(status) <= n else status[:n - 1] + "…"


def verdict_of(doc, case, engine):
    g = doc.get("gate")
    if not g:
        return "no baseline"
    return g["verdicts"].get(f"{case}/{engine}", "not compared")


def rows(doc):
    """(case, run, verdict) for every main run, in report order."""
    for c in doc["cases"]:
        for r in c["runs"]:
            yield c, r, verdict_of(doc, c["name"], r["engine"])


def engines_of(doc):
    return ["native"] + list(doc["options"]["engines"])


def grade(run, verdict) -> str:
    """A cell's class: bad (failed, regressed), skip (unsupported), warn
    (new, slower, outside the adapter's tolerance), ok."""
    st = run["status"]
    if st.startswith("failed") or verdict.startswith("REGRESSED"):
        return "bad"
    if st.startswith("unsupported"):
        return "skip"
    if verdict.startswith(("new", "pass, slower")) or run["within_tolerance"] is False:
        return "warn"
    return "ok"


def matrix(doc):
    """The summary matrix: (engines, [(case, {engine: (run, verdict, grade)})],
    {engine: {reason: ([joint types], [cases])}} of the unsupported runs).
    Cases with a failed or regressed run come first, then those with a
    warning, then the rest."""
    engines, rows, unsupported = engines_of(doc), [], {}
    for c in doc["cases"]:
        cells = {}
        for r in c["runs"]:
            v = verdict_of(doc, c["name"], r["engine"])
            cells[r["engine"]] = (r, v, grade(r, v))
            if r["status"].startswith("unsupported") and not v.startswith("REGRESSED"):
                what, why = reason(r["status"])
                types, names = unsupported.setdefault(r["engine"], {}).setdefault(why, ([], []))
                types += [what] if what not in types else []
                names.append(c["name"])
        rows.append((c, cells))
    order = {"bad": 0, "warn": 1}
    rows.sort(key=lambda row: min((order.get(g, 2) for _, _, g in row[1].values()), default=2))
    return engines, rows, unsupported


def reason(status) -> tuple:
    """An unsupported status as (what, why) without the constraint's own name,
    so that cases share it: "unsupported: cam-flat ('contact'): no ..." ->
    ("cam-flat", "no ...")."""
    text = re.sub(r" \('[^']*'\)", "", status.split(":", 1)[-1].strip())
    what, _, why = text.partition(": ")
    return (what, why) if why else ("", what)


def unsupported_lines(unsupported):
    """{engine: "why (types: cases); ..."} for the lines under the matrix."""
    return {e: "; ".join(f"{', '.join(t for t in types if t)}: {why} ({', '.join(names)})"
                         for why, (types, names) in reasons.items())
            for e, reasons in unsupported.items()}


def counts(doc):
    runs = [r for _, r, _ in rows(doc)]
    ok = sum(r["status"] == "ok" for r in runs)
    failed = sum(r["status"].startswith("failed") for r in runs)
    return len(runs), ok, failed, len(runs) - ok - failed


def headline(doc) -> str:
    """One sentence: the verdict, then what it covers."""
    n, ok, failed, unsupported = counts(doc)
    g = doc.get("gate")
    regressions = g["regressions"] if g else 0
    misses = len((doc.get("stress") or {}).get("native_misses", ()))
    bad = failed or regressions or misses or any(e["status"] != "ok" for e in doc["engines"].values())
    verdict = "FAILED" if bad else "PASS"
    what = (f"{len(doc['cases'])} case(s) on {', '.join(engines_of(doc))}: {ok} of {n} runs ok, {failed} failed, "
            f"{unsupported} unsupported")
    if g:
        base = (f"{regressions} regression(s), {g['slowdowns']} slowdown(s) against {g['baseline']}"
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
    git = doc["git"]["revision"]
    rev = "no git revision" if not git else git[:10] + (" (dirty)" if doc["git"]["dirty"] else "")
    m = doc["machine"]
    return (f"{rev}; {m['cpu']}, {m['cores']} cores; {doc['duration']:.0f} s"
            + (" (--quick)" if doc["options"]["quick"] else ""))


def summary_md(doc) -> str:
    out = ["## kinem report", "", f"**{headline(doc)}**", "", provenance(doc), ""]
    g = doc.get("gate")
    fatal = [f for f in (g or {}).get("findings", ()) if f["fatal"]]
    if g and g["not_compared"]:
        out += ["### Not compared (in the baseline, not in this run)", ""] + [f"- {x}" for x in g["not_compared"]] + [""]
    if fatal:
        out += [f"### Regressions ({len(fatal)})", ""]
        out += [f"- **{f['case']} / {f['engine']}** ({f['where']}): {f['message']}" for f in fatal[:30]]
        out += [f"- … and {len(fatal) - 30} more (results.json)"] if len(fatal) > 30 else []
        out.append("")
    failed = {}
    for c, r, _ in rows(doc):  # one line per engine and distinct failure (an import error fails every case)
        if r["status"].startswith("failed"):
            failed.setdefault((r["engine"], r["status"]), []).append(c["name"])
    if failed:
        out += ["### Failed runs", ""]
        out += [f"- **{e}** ({', '.join(names) if len(names) < 4 else f'{len(names)} cases'}): {short(st, 200)}"
                for (e, st), names in failed.items()]
        out.append("")
    slow = [f for f in (g or {}).get("findings", ()) if f["kind"] == "slower" and not f["fatal"]]
    if slow:
        out += ["### Slower (not failing)", ""]
        out += [f"- {f['case']} / {f['engine']}: {f['message']}" for f in slow] + [""]
    from .stress_section import line as stress_line

    if doc.get("stress"):
        out += [stress_line(doc), ""]
    from .equivalence import line as groups_line

    if doc.get("equivalence"):
        out += [groups_line(doc), ""]
    engines, table, unsupported = matrix(doc)
    out += ["| case | " + " | ".join(engines) + " |", "|---|" + "---:|" * len(engines)]
    for c, cells in table:
        out.append(f"| {c['name']} | " + " | ".join(_md_cell(cells.get(e)) for e in engines) + " |")
    if unsupported:
        out += ["", "Not supported (–):"]
        out += [f"- **{e}**: {text}" for e, text in unsupported_lines(unsupported).items()]
    out += ["", "Cells: position error / L (native: against the closed form or equivalence group where the case "
            "has one, else native at tolerance 1e-13; engines: against native at 1e-13) and µs per step; "
            "✅ pass or ok, ⚠️ new, slower or outside the engine's tolerance, ❌ failed or regressed. "
            "Details, plots and work-precision diagrams: index.html."]
    return "\n".join(out) + "\n"


MARK = {"ok": "✅", "warn": "⚠️", "bad": "❌", "skip": "–"}


def _md_cell(cell) -> str:
    if cell is None:
        return "not run"
    r, v, g = cell
    if g == "skip":
        return "–"
    if r["status"].startswith("failed"):
        return f"❌ {short(r['status'], 40)}".replace("|", "\\|")
    text = f"{MARK[g]} {fmt(r['position_error_rel'])}, {us(r['time_per_step'])} µs"
    if v.startswith("REGRESSED"):
        text += f" ({short(v, 50)})"
    elif v.startswith(("new", "pass, slower")):
        text += f" ({v})"
    return text.replace("|", "\\|")


def junit_xml(doc) -> str:
    cases, fails, skips = [], 0, 0
    for c, r, v in rows(doc):
        body = ""
        if r["status"].startswith("failed") or v.startswith("REGRESSED"):
            fails += 1
            msg = r["status"] if r["status"].startswith("failed") else v
            body = f"<failure message={quoteattr(msg)}/>"
        elif r["status"] != "ok":
            skips += 1
            body = f"<skipped message={quoteattr(r['status'])}/>"
        cases.append(f'  <testcase classname={quoteattr("kinem.report." + c["name"])} name={quoteattr(r["engine"])} '
                     f'time="{r["wall_time"] or 0:.6f}">{body}</testcase>')
    head = (f'<testsuite name="kinem report" tests="{len(cases)}" failures="{fails}" skipped="{skips}" '
            f'errors="0" time="{doc["duration"]:.3f}">')
    return "\n".join(['<?xml version="1.0" encoding="UTF-8"?>', "<testsuites>", head, *cases,
                      "</testsuite>", "</testsuites>"]) + "\n"
