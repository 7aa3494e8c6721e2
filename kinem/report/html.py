"""index.html: one self-contained page (inline CSS, plots as data: URIs, no
script, no external URL): the headline and summary matrix, what was not
compared, the equivalent models, one section per case, the stress suite
(when it ran) and the run's provenance."""
import json

from . import plots
from .escaping import escape
from .runs import Reference, sample
from .text import (SELF, cost, failed, figure, fmt, headline, judgement, limits_text, matrix, passed, provenance, rates,
                   reason, seconds, short, unsupported, unsupported_lines, verdict)

SNAPSHOTS = 4   # instants of the static mechanism drawings
CSS = """body{font:14px/1.4 system-ui,sans-serif;margin:1.5em auto;max-width:1250px;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0 1em}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}
td:not(.l){white-space:nowrap}table.matrix td{white-space:normal}
td.l,th.l{text-align:left}th{background:#f3f3f3}.ok{color:#176b1a}.bad{color:#b00020;font-weight:bold}
.skip{color:#777}img{max-width:100%;display:block;margin:.3em 0}section{border-top:2px solid #ddd;margin-top:2em}
code,pre{font-size:12px}pre{background:#f7f7f7;padding:.5em;overflow-x:auto;white-space:pre-wrap}
p.head{font-size:17px;padding:.4em .6em;border-left:6px solid #176b1a;background:#eef7ee}
p.head.bad{border-color:#b00020;background:#fbeaea;color:#222;font-weight:normal}
table.matrix{table-layout:fixed;width:100%}table.matrix td{text-align:left;vertical-align:top;white-space:normal}
table.matrix th:first-child{width:11em}ol.notes{font-size:13px}table.matrix td.c-ok{background:#e3f4e3}
table.matrix td.c-warn{background:#fff3cd}table.matrix td.c-slow{background:#e3ecf8}
table.matrix td.c-self{background:#fff;color:#555}table.matrix td.c-bad{background:#f8d7da;font-weight:bold}
table.matrix td.c-skip{background:#f4f4f4;color:#999;text-align:center}td small{color:#555}
details{margin:.3em 0 1em}summary{cursor:pointer;color:#335}.wrap{overflow-x:auto;max-width:100%}"""


def _cls(r):
    """A run's or point's class by its typed outcome."""
    return {"ok": "ok", "unsupported": "skip"}.get(r["outcome"], "bad")


def _td(text, cls="", left=False):
    c = " ".join(x for x in (cls, "l" if left else "") if x)
    return f"<td{f' class={chr(34)}{c}{chr(34)}' if c else ''}>{escape(str(text))}</td>"


def summary_matrix(doc):
    """One row per case (failed or regressed first), one column per engine:
    each cell coloured by its verdict, with the summary figure and the cost;
    what a cell's verdict rests on (a regression, the figures over their
    limits, the engines' consensus) is a numbered note below the table, so
    the table keeps to the page's width; unsupported engines collapsed
    below into one line per engine."""
    engines, table, skipped = matrix(doc)
    notes = []
    out = ["<table class=matrix><tr><th class=l>case</th>" + "".join(f"<th class=l>{escape(e)}</th>" for e in engines)
           + "</tr>"]
    for c, cells in table:
        out.append(f'<tr><th class=l><a href="#case-{escape(c["name"])}">{escape(c["name"])}</a></th>'
                   + "".join(_matrix_cell(cells.get(e), notes, c["name"]) for e in engines) + "</tr>")
    out.append("</table>")
    if notes:
        out.append("<ol class=notes>" + "".join(f"<li>{escape(n)}</li>" for n in notes) + "</ol>")
    if skipped:
        items = "".join(f"<li><b>{escape(e)}</b>: {escape(text)}</li>" for e, text in unsupported_lines(skipped).items())
        out.append(f"<p>Not supported (grey cells):</p><ul>{items}</ul>")
    return "\n".join(out)


# a cell's short tag (its note below the table says the rest)
TAGS = {"regressed": "regressed", "new": "new", "slower": "slower"}
SHORT = {"native disagrees with the engines' consensus": "off the engines' consensus",
         "consistent with the engines' consensus": "consistent with the engines",
         "cannot reach the tolerance within the cost cap": "at the cost cap"}


def _matrix_cell(cell, notes, case):
    if cell is None:
        return "<td class=c-bad>not run</td>"
    r, v, g = cell
    if g == "skip":
        return f'<td class=c-skip title="{escape(": ".join(x for x in reason(r) if x))}">–</td>'
    tip = escape(f"{r['status']}; position error / L {fmt(r['position_error_rel'])}; angle error "
                 f"{fmt(r['angle_error'])} rad; velocity error / V {fmt(r['velocity_error_rel'])}; residual "
                 f"{fmt(r['constraint_residual'])}; verdict: {v[1]}; position error against {r['reference']}"
                 + (f"; {rates(r)}" if rates(r) else ""))
    said = []
    if v[0] in TAGS:
        said.append((TAGS[v[0]], v[1]))
    if r["outcome"] == "ok" and (verdict(r).fails or r.get("attributed")):
        said.append((SHORT.get(verdict(r).value, verdict(r).value), judgement(r)))
    tags = ""
    for tag, text in said:
        notes.append(f"{case} / {r['engine']}: {text}")
        tags += f"<br><small>{escape(tag)} <sup>{len(notes)}</sup></small>"
    if failed(r):
        return f'<td class=c-bad title="{tip}">{escape(short(r["status"], 40))}{tags}</td>'
    mark = "" if r.get("attributed") else {Reference.CLOSED_FORM: "ᶜ", Reference.GROUP: "ᵍ"}.get(
        Reference(r["reference_kind"]), "")
    value, what = figure(r)
    shown = (f"<i>{escape(what)}</i>" if value is None
             else f"{fmt(value)}{mark} <small>{escape(what)}</small>")
    return f'<td class=c-{g} title="{tip}">{shown}<br>{escape(cost(r))}{tags}</td>'



def _counts(r):
    return ", ".join(f"{k} {v}" for k, v in r["counts"].items())


def _per_step(r):
    k = r["counts"]
    if "instants" in k:
        n = max(k["instants"], 1)
        return (f"Newton {k['newton_iterations'] / n:.2f}, Jacobians {k['jacobian_evaluations'] / n:.2f}, "
                f"LU {k['factorizations'] / n:.2f}")
    return f"steps {k.get('steps', 0)}, substeps {k.get('substeps', 1)} (as the adapter counts them)" if k else "–"


def case_table(case):
    head = ["engine", "status", "pos. error", "pos. / L", "pos. error against", "angle (rad)", "velocity / V",
            "omega / (V/L)", "residual", "wall (s)", "cost / interval", "stepping / interval", "steps / interval",
            "counts (native per instant)", "verdict"]
    out = ["<div class=wrap><table><tr>" + "".join(f"<th class=l>{h}</th>" for h in head) + "</tr>"]
    for r in case["runs"]:
        if unsupported(r):   # one cell: the reason, no row of dashes
            out.append("<tr>" + _td(r["engine"], left=True)
                       + f'<td class="l skip" colspan={len(head) - 1}>{escape(r["status"])}</td></tr>')
            continue
        if r["outcome"] == "ok" and figure(r)[1] == SELF:   # native against itself: no figure, never a zero
            figures = (f'<td class=l colspan=6><i>{SELF}</i> (native at the reference tolerance is the same '
                       f'solver)</td>')
        else:
            figures = ("".join(_td(fmt(r[k])) for k in ("position_error", "position_error_rel"))
                       + _td(r["reference"], left=True)
                       + "".join(_td(fmt(r[k])) for k in ("angle_error", "velocity_error_rel",
                                                            "angular_velocity_error_rel")))
        steps = r.get("steps_per_interval")
        out.append("<tr>" + _td(r["engine"], left=True) + _td(short(r["status"], 60), _cls(r), True) + figures
                   + _td(fmt(r["constraint_residual"]))
                   + _td(fmt(r["wall_time"], ".3g")) + _td(seconds(r.get("cost_per_interval")))
                   + _td(seconds(r["time_per_interval"])) + _td(fmt(steps, ".3g"))
                   + _td(_per_step(r), left=True) + _td(judgement(r) if r["outcome"] == "ok" else "–", left=True)
                   + "</tr>")
    out.append("</table></div>")
    settings = "".join(f"<li><b>{escape(r['engine'])}</b> {escape(r['version'])}: "
                       f"<code>{escape(json.dumps(r['settings'], separators=(', ', ': ')))}</code></li>"
                       for r in case["runs"])
    out.append(f"<details><summary>versions and settings</summary><ul>{settings}</ul></details>")
    return "\n".join(out)


def wp_table(wp):
    out = ["<table><tr><th class=l>engine</th><th class=l>knob</th><th>value</th><th class=l>other knobs</th>"
           "<th class=l>front</th><th class=l>status</th>"
           "<th>error / L</th><th>wall s / sim. s</th><th class=l>counts</th></tr>"]
    for curve in wp["curves"]:
        held = ", ".join(f"{k}={v}" for k, v in (curve.get("family") or {}).items())
        for p in curve["points"]:
            out.append("<tr>" + _td(curve["engine"], left=True) + _td(curve["knob"], left=True)
                       + _td(fmt(p["value"], ".1e")) + _td(held, left=True)
                       + _td("Pareto" if p.get("front") else "", left=True)
                       + _td(short(p["status"]), _cls(p), True)
                       + _td(fmt(p["error"])) + _td(fmt(p["cost"], ".3g")) + _td(_counts(p), left=True) + "</tr>")
    return "\n".join(out) + "</table>"


def case_section(case, model, series):
    name = case["name"]
    out = [f'<section id="case-{escape(name)}"><h2>{escape(name)}</h2>',
           f"<p>{escape(case['description'])}<br>{escape(case['path'])}: L = {case['length']:.4g} "
           f"{escape(case['unit'])}, t = 0 … {case['end']:g} s in {case['steps']} steps, "
           f"{case['coordinates']} coordinates. References: engines' errors and the plots against native at "
           f"tolerance {fmt(case['reference_tolerance'], '.0e')}; native: {escape(_native_reference(case))}.</p>"]
    native = series.get("native")
    if native and "frames" in native:
        out += motion_section(model, series)
        img, flat = plots.trajectories(native["t"], native["reference"], series, case["unit"], case["length"])
        out.append("<h3>Named points against time</h3>" if model.case.points else "<h3>Bodies against time</h3>")
        if img:
            out.append(plots.img(img, f"{name} trajectories"))
        if flat:
            out.append("<p>Constant over the run (within 1e-9 L, or 1e-9 rad): " + ", ".join(
                f"{escape(c)} = {v:.6g} {'rad' if c.endswith('.phi') else escape(case['unit'])}"
                for c, v in flat.items()) + ".</p>")
        out.append("<h3>Position error against time</h3>")
        if max(max(s["error"], default=0.0) for s in series.values()) <= plots.TINY:
            out.append(f"<p>Below {plots.TINY:.0e} L at every instant for every run drawn "
                       f"({', '.join(series)}): not plotted.</p>")
        else:
            out.append(plots.img(plots.errors(series), f"{name} errors"))
    out.append("<h3>Comparison</h3>" + case_table(case))
    from .design import section

    engines = [r["engine"] for r in case["runs"] if r["engine"] != "native" and r.get("outcome") == "ok"]
    if any(r["engine"] == "native" and r.get("outcome") == "ok" for r in case["runs"]):
        out += section(model, engines)   # [report] sensitivity, [tolerances]: docs/design.md
    elif model.case.report.get("sensitivity") or model.case.tolerances:   # they start from native's solve
        out.append("<h3>Design sensitivities and tolerance bands</h3><p>Not computed: native's run of the case "
                   "failed (the comparison above says why).</p>")
    wp = case["work_precision"]
    if wp:
        out.append("<h3>Work-precision</h3><p>Each point is one run, labelled with its native Newton tolerance "
                   "or engine time step; errors are maxima over the run against the reference, those below "
                   "1e-16 drawn at 1e-16. Each engine is swept over its time step in each family of its own "
                   "accuracy knobs (integrator, iterations: one marker and line style each, the defaults' family "
                   "solid); the pale band joins the engine's Pareto front (no other of its runs is both cheaper "
                   "and more accurate in position).</p>" + plots.img(plots.work_precision(wp), f"{name} work-precision")
                   + "<details><summary>points</summary><div class=wrap>" + wp_table(wp) + "</div></details>")
    return "\n".join(out) + "</section>"


def _native_reference(case):
    """What native's figures are against: its closed form or equivalence
    group, or no independent reference (the engines' consensus, when it
    disagrees with it, is in its verdict)."""
    native = next((r for r in case["runs"] if r["engine"] == "native"), None)
    if native is None:
        return "–"
    if Reference(native["reference_kind"]) is Reference.NATIVE:
        return f"{SELF} (its figures against native at the reference tolerance are the same solver's)"
    what = "position, velocity and acceleration errors" if rates(native) else "position error"
    return f"{what} against {native['reference']}"


def motion_section(model, series):
    """The animation (native solid, engines' ghosts, point paths) and the
    mechanism at SNAPSHOTS instants, drawn by motion.py."""
    from .motion import duration, svg

    native = series["native"]
    frames = native["frames"]
    ghosts = {e: s["frames"]["q"] for e, s in series.items()
              if e != "native" and "frames" in s and s["frames"]["t"] == frames["t"]}
    anim = svg(model, frames, ghosts, paths_q=native.get("path_q"))
    n = len(frames["t"])
    what = (f"engines' poses ({', '.join(ghosts)}) dashed over it" if ghosts
            else "no engine's run to draw over it (see the comparison below)")
    pts = "named points' paths in the plane (coupler curves)" if model.case.points else "no named points"
    out = [f"<h3>Motion</h3><p>Native solid, {what}; {pts}. {n} frames over t = {frames['t'][0]:g} … "
           f"{frames['t'][-1]:g} s, looping every {duration(frames['t']):.3g} s.</p>", anim,
           "<h3>Mechanism at four instants</h3><div style=\"display:flex;flex-wrap:wrap;gap:6px\">"]
    for k in sample(n, SNAPSHOTS):
        out.append(svg(model, frames, None, at=int(k), width=300, max_height=260, paths_q=native.get("path_q")))
    out.append("</div>")
    return out


def render_section(job) -> str:
    """case_section of (case entry of results.json, its series); runs in a worker."""
    from kinem.case import load
    from kinem.model import compile

    case, series = job
    return case_section(case, compile(load(case["path"])), series)


def index_html(doc, sections, curves=None) -> str:
    """The page: sections are the per-case HTML (render_section); curves the
    equivalence groups' deviation over time (results.build's series)."""
    from .equivalence import html as equivalence_html
    from .stress_section import html as stress_html

    g = doc.get("gate")
    fatal = [f for f in (g or {}).get("findings", ()) if f["fatal"]]
    head = headline(doc)
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8"><title>kinem report</title>',
             f"<style>{CSS}</style></head><body>", "<h1>kinem report</h1>",
             f'<p class="head{"" if passed(doc) else " bad"}">{escape(head)}</p>',
             f"<p><small>{escape(provenance(doc))}</small></p>"]
    if fatal:
        items = "".join(f"<li><b>{escape(f['case'])} / {escape(f['engine'])}</b> ({escape(f['where'])}): "
                        f"{escape(f['message'])}</li>" for f in fatal)
        parts.append(f"<h2 class=bad>Regressions ({len(fatal)})</h2><ul>{items}</ul>")
    if g and g["not_compared"]:
        items = "".join(f"<li>{escape(x)}</li>" for x in g["not_compared"])
        parts.append(f"<h3>Not compared (in the baseline {escape(g['baseline'])}, not in this run)</h3><ul>{items}</ul>")
    parts.append("<h2>Summary</h2>" + summary_matrix(doc))
    parts.append("<p><small>Each cell: the worst scale-free error over instants and every coordinate that moves "
                 "(positions of bodies and named points / L, bodies' angles in rad, velocities / V, angular "
                 "velocities / (V/L); which one is named), then the whole run's wall time per output interval "
                 "(the adapter's own Python included; the stepping alone is in each case's table) and the engine "
                 "steps per interval counting every attempt (native: one solve per instant), the same unit in "
                 "every column; a numbered note below the table says what a tagged cell's verdict rests on; hover for the other figures and the verdict. References: engines against the "
                 "native solution at tolerance 1e-13; native against the case's closed form (ᶜ, kinem.reference) "
                 "or its equivalence group (ᵍ) where it has one, else \"no independent reference\" (white). Against a "
                 "closed form native's velocities and accelerations are checked too (hover: each error / the closed "
                 f"form's peak); native fails (red) above {limits_text()}. Green: ok and "
                 "no regression; yellow: new, or outside the engine's documented tolerance (the metric, its value "
                 "and its limit named); blue: slower than the baseline relative to the engine's other cases in the same run (shown, "
                 "not failing unless --fail-on-slowdown); red: failed or regressed. Rows: cases with a red cell "
                 "first, then by name. Work-precision: max position error / L against wall time per simulated "
                 "second.</small></p>")
    parts.append(equivalence_html(doc, (curves or {})))
    parts += sections
    parts.append(stress_html(doc))
    meta = {k: doc[k] for k in ("git", "machine", "options", "engines", "created")}
    parts.append("<section><h2>Run</h2><details><summary>versions, machine and options</summary><pre>"
                 + escape(json.dumps(meta, indent=1)) + "</pre></details></section>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
