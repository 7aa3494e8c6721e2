"""index.html: one self-contained page (inline CSS, plots as data: URIs, no
script, no external URL): the summary table, then one section per case."""
import json
from html import escape

from . import plots
from .runs import sample
from .text import fmt, headline, rows, short, us

SNAPSHOTS = 4   # instants of the static mechanism drawings
CSS = """body{font:14px/1.4 system-ui,sans-serif;margin:1.5em auto;max-width:1250px;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0 1em}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}
td.l,th.l{text-align:left}th{background:#f3f3f3}.ok{color:#176b1a}.bad{color:#b00020;font-weight:bold}
.skip{color:#777}img{max-width:100%;display:block;margin:.3em 0}section{border-top:2px solid #ddd;margin-top:2em}
code,pre{font-size:12px}pre{background:#f7f7f7;padding:.5em;overflow-x:auto}"""


def _cls(text):
    if text.startswith(("failed", "REGRESSED")):
        return "bad"
    if text.startswith(("ok", "pass")):
        return "ok"
    return "skip"


def _td(text, cls="", left=False):
    c = " ".join(x for x in (cls, "l" if left else "") if x)
    return f"<td{f' class={chr(34)}{c}{chr(34)}' if c else ''}>{escape(str(text))}</td>"


def _img(uri, alt):
    return f'<img alt="{escape(alt)}" src="{uri}">'


def summary_table(doc):
    out = ["<table><tr><th class=l>case</th><th class=l>engine</th><th class=l>status</th><th>pos. error / L</th>"
           "<th>angle error (rad)</th><th>residual</th><th>µs/step</th><th class=l>verdict</th></tr>"]
    for c, r, v in rows(doc):
        out.append(f'<tr><td class=l><a href="#case-{escape(c["name"])}">{escape(c["name"])}</a></td>'
                   + _td(r["engine"], left=True) + _td(short(r["status"]), _cls(r["status"]), True)
                   + _td(fmt(r["position_error_rel"])) + _td(fmt(r["angle_error"]))
                   + _td(fmt(r["constraint_residual"])) + _td(us(r["time_per_step"])) + _td(v, _cls(v), True)
                   + "</tr>")
    return "\n".join(out) + "</table>"


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
    head = ["engine", "status", "pos. error", "pos. / L", "angle", "velocity (rel.)", "omega", "residual",
            "wall (s)", "µs/step", "cost (deterministic; native per instant)", "within tol.", "version", "settings"]
    out = ["<table><tr>" + "".join(f"<th class=l>{h}</th>" for h in head) + "</tr>"]
    for r in case["runs"]:
        wt = {True: "yes", False: "NO", None: "–"}[r["within_tolerance"]]
        out.append("<tr>" + _td(r["engine"], left=True) + _td(short(r["status"], 90), _cls(r["status"]), True)
                   + "".join(_td(fmt(r[k])) for k in ("position_error", "position_error_rel", "angle_error",
                                                        "velocity_error_rel", "angular_velocity_error",
                                                        "constraint_residual"))
                   + _td(fmt(r["wall_time"], ".3g")) + _td(us(r["time_per_step"])) + _td(_per_step(r), left=True)
                   + _td(wt) + _td(r["version"], left=True)
                   + f"<td class=l><code>{escape(json.dumps(r['settings'], separators=(',', ':')))}</code></td></tr>")
    return "\n".join(out) + "</table>"


def wp_table(wp):
    out = ["<table><tr><th class=l>engine</th><th class=l>knob</th><th>value</th><th class=l>status</th>"
           "<th>error / L</th><th>wall s / sim. s</th><th class=l>counts</th></tr>"]
    for curve in wp["curves"]:
        for p in curve["points"]:
            out.append("<tr>" + _td(curve["engine"], left=True) + _td(curve["knob"], left=True)
                       + _td(fmt(p["value"], ".1e")) + _td(short(p["status"]), _cls(p["status"]), True)
                       + _td(fmt(p["error"])) + _td(fmt(p["cost"], ".3g")) + _td(_counts(p), left=True) + "</tr>")
    return "\n".join(out) + "</table>"


def case_section(case, model, series):
    name = case["name"]
    out = [f'<section id="case-{escape(name)}"><h2>{escape(name)}</h2>',
           f"<p>{escape(case['description'])}<br>{escape(case['path'])}: L = {case['length']:.4g} "
           f"{escape(case['unit'])}, t = 0 … {case['end']:g} s in {case['steps']} steps, "
           f"{case['coordinates']} coordinates; reference: native at tolerance "
           f"{fmt(case['reference_tolerance'], '.0e')}.</p>"]
    native = series.get("native")
    if native and "frames" in native:
        out += motion_section(model, series)
        img, flat = plots.trajectories(native["t"], native["reference"], series, case["unit"], case["length"])
        out.append("<h3>Named points against time</h3>" if model.case.points else "<h3>Bodies against time</h3>")
        if img:
            out.append(_img(img, f"{name} trajectories"))
        if flat:
            out.append("<p>Constant over the run (within 1e-9 L, or 1e-9 rad): " + ", ".join(
                f"{escape(c)} = {v:.6g} {'rad' if c.endswith('.phi') else escape(case['unit'])}"
                for c, v in flat.items()) + ".</p>")
        out.append("<h3>Position error against time</h3>")
        if max(max(s["error"], default=0.0) for s in series.values()) <= plots.TINY:
            out.append(f"<p>Below {plots.TINY:.0e} L at every instant for every run drawn "
                       f"({', '.join(series)}): not plotted.</p>")
        else:
            out.append(_img(plots.errors(series), f"{name} errors"))
    out.append("<h3>Comparison</h3>" + case_table(case))
    wp = case["work_precision"]
    if wp:
        out.append("<h3>Work-precision</h3><p>Each point is one run, labelled with its native Newton tolerance "
                   "or engine time step; errors are maxima over the run against the reference, those below "
                   "1e-16 drawn at 1e-16.</p>" + _img(plots.work_precision(wp), f"{name} work-precision")
                   + "<details><summary>points</summary>" + wp_table(wp) + "</details>")
    return "\n".join(out) + "</section>"


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


def index_html(doc, sections) -> str:
    g = doc.get("gate")
    fatal = [f for f in (g or {}).get("findings", ()) if f["fatal"]]
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8"><title>kinem report</title>',
             f"<style>{CSS}</style></head><body>", "<h1>kinem report</h1>", f"<p>{escape(headline(doc))}</p>"]
    if fatal:
        items = "".join(f"<li><b>{escape(f['case'])} / {escape(f['engine'])}</b> ({escape(f['where'])}): "
                        f"{escape(f['message'])}</li>" for f in fatal)
        parts.append(f"<h2 class=bad>Regressions ({len(fatal)})</h2><ul>{items}</ul>")
    parts.append(summary_table(doc))
    parts.append("<p>Errors: against the native solution at tolerance 1e-13, max over instants, bodies and "
                 "named points; residual: max scaled residual of the kinematic constraints on the run's "
                 "trajectory; µs/step: wall time per engine step (native: per output instant). "
                 "Work-precision: max position error / L against wall time per simulated second.</p>")
    parts += sections
    from .stress_section import html as stress_html

    parts.append(stress_html(doc))
    meta = {k: doc[k] for k in ("git", "machine", "options", "engines", "created")}
    parts.append("<section><h2>Run</h2><pre>" + escape(json.dumps(meta, indent=1)) + "</pre></section>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
