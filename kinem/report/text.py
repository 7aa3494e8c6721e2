"""summary.md (GitHub-flavoured Markdown for a CI job summary) and junit.xml
(one test case per case x engine)."""
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


def headline(doc) -> str:
    runs = [r for _, r, _ in rows(doc)]
    ok = sum(r["status"] == "ok" for r in runs)
    failed = sum(r["status"].startswith("failed") for r in runs)
    g = doc.get("gate")
    git = doc["git"]["revision"]
    rev = "no git revision" if not git else git[:10] + (" (dirty)" if doc["git"]["dirty"] else "")
    gate = (f"baseline `{g['baseline']}`: {g['regressions']} regression(s), {g['slowdowns']} slowdown(s)"
            if g else "no baseline")
    m = doc["machine"]
    return (f"{len(doc['cases'])} cases, {len(runs)} runs: {ok} ok, {failed} failed, "
            f"{len(runs) - ok - failed} unsupported; {gate}. {rev}; {m['cpu']}, {m['cores']} cores; "
            f"{doc['duration']:.0f} s" + (" (--quick)" if doc["options"]["quick"] else ""))


def summary_md(doc) -> str:
    out = ["## kinem report", "", headline(doc), ""]
    g = doc.get("gate")
    fatal = [f for f in (g or {}).get("findings", ()) if f["fatal"]]
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
    out += ["| case | engine | status | pos. error / L | angle error (rad) | residual | µs/step | verdict |",
            "|---|---|---|---:|---:|---:|---:|---|"]
    unsupported = {}
    for c, r, v in rows(doc):
        if r["status"].startswith("unsupported") and not v.startswith("REGRESSED"):
            unsupported.setdefault(r["engine"], []).append(c["name"])  # listed below the table
            continue
        cells = [c["name"], r["engine"], short(r["status"], 48), fmt(r["position_error_rel"]),
                 fmt(r["angle_error"]), fmt(r["constraint_residual"]), us(r["time_per_step"]), v]
        out.append("| " + " | ".join(s.replace("|", "\\|") for s in cells) + " |")
    if unsupported:
        out += ["", "Not supported (the case uses a joint the engine cannot represent; reasons in index.html): "
                + "; ".join(f"{e}: {', '.join(names)}" for e, names in unsupported.items()) + "."]
    out += ["", "Errors against the native solution at tolerance 1e-13; residual: max scaled residual of the "
            "kinematic constraints; µs/step: wall time per engine step (native: per output instant). "
            "Details, plots and work-precision diagrams: index.html."]
    return "\n".join(out) + "\n"


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
