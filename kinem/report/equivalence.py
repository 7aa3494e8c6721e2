"""Equivalent models: cases that declare the same [equivalent] group model one
mechanism, and the named points they list must coincide (docs/case-format.md).

The report compares each group's reference solutions (native at the
reference tolerance): per instant, the largest distance between a member's
points and the first member's, over the points the members share, divided by
the first member's L. That is the group's agreement; results.json keeps it
under "equivalence" and the gate holds it to the baseline like an error.
A member without a closed form (adapters.references) also gets its
native row's position error against the group.
"""

import numpy as np

from ..outcome import Kind
from .escaping import escape
from .gate import verdict_of
from .runs import Reference

LABEL = "native at the reference tolerance of each case"


class Agreement(Kind):
    """An equivalence group's status (results.json "status"; "detail" the specifics)."""
    OK = ("ok", "compared")
    ONE_CASE = ("one-case", "not compared: one case of the group in this run")
    NO_SHARED_POINT = ("no-shared-point", "failed: the cases share no named point", True)
    NO_REFERENCE = ("no-reference", "failed: no reference solution", True)


def status_text(entry) -> str:
    """A group's status for people: its message and detail."""
    a = Agreement(entry["status"])
    return f"{a.message} of {entry['detail']}" if entry.get("detail") else a.message


def build(cases, series) -> tuple:
    """cases: results.json case entries (their native rows may be updated);
    series: {case: {engine: series}}. Returns (the "equivalence" list of
    results.json, {group: {case: (t, deviation / L)}} for the plots)."""
    groups = {}
    for c in cases:
        pts = series.get(c["name"], {}).get("native", {}).get("points")
        if c.get("equivalent"):
            groups.setdefault(c["equivalent"]["group"], []).append((c, pts))
    out, curves = [], {}
    for name, members in groups.items():
        entry, curve = _group(name, members)
        out.append(entry)
        curves[name] = curve
    return out, curves


def _xy(pts, which, n):
    x, y = pts[which][n]
    return np.asarray(x) + 1j * np.asarray(y)


def _group(name, members):
    first, p0 = members[0]
    shared = [n for n in first["equivalent"]["points"]
              if all(n in c["equivalent"]["points"] for c, _ in members[1:])]
    entry = {"group": name, "cases": [c["name"] for c, _ in members], "points": shared, "reference": LABEL,
             "length": first["length"], "members": [], "max_deviation_rel": None, "status": Agreement.OK.value, "detail": ""}
    if len(members) < 2:
        entry["status"] = Agreement.ONE_CASE.value
        return entry, {}
    if not shared:
        entry["status"] = Agreement.NO_SHARED_POINT.value
        return entry, {}
    if any(p is None for _, p in members):
        entry["status"] = Agreement.NO_REFERENCE.value
        entry["detail"] = ", ".join(c["name"] for c, p in members if p is None)
        return entry, {}
    t0, length, curves = np.asarray(p0["t"]), first["length"], {}
    for c, p in members[1:]:
        t = np.asarray(p["t"])
        keep = (t0 >= t[0] - 1e-12) & (t0 <= t[-1] + 1e-12)      # the first member's instants both cover
        d = np.stack([np.abs(_interp(t, _xy(p, "reference", n), t0[keep]) - _xy(p0, "reference", n)[keep])
                      for n in shared])
        k = np.unravel_index(int(np.argmax(d)), d.shape)
        entry["members"].append({"case": c["name"], "max_deviation": float(d.max()),
                                 "max_deviation_rel": float(d.max() / length), "point": shared[k[0]],
                                 "t": float(t0[keep][k[1]])})
        curves[c["name"]] = (t0[keep].tolist(), (d.max(axis=0) / length).tolist())
    entry["max_deviation_rel"] = max(m["max_deviation_rel"] for m in entry["members"])
    for c, p in members:   # members without a closed form: their native row against the group
        native = next((r for r in c["runs"] if r["engine"] == "native"), None)
        if native is None or native["outcome"] != "ok" or native["reference_kind"] != Reference.NATIVE.value:
            continue
        worst, other = _against_group(c, p, members, shared)
        native.update(position_error=worst, position_error_rel=worst / c["length"],
                      reference=f"equivalence group {name} (points {', '.join(shared)} of {other})",
                      reference_kind=Reference.GROUP.value)
    return entry, curves


def _interp(t, z, at):
    return np.interp(at, t, z.real) + 1j * np.interp(at, t, z.imag)


def _against_group(case, pts, members, shared):
    """Max distance of case's native run points to the other members'
    reference points; and the names of those members."""
    t = np.asarray(pts["t"])
    worst, others = 0.0, []
    for c, p in members:
        if c is case:
            continue
        tt = np.asarray(p["t"])
        keep = (t >= tt[0] - 1e-12) & (t <= tt[-1] + 1e-12)
        for n in shared:
            d = np.abs(_xy(pts, "run", n)[keep] - _interp(tt, _xy(p, "reference", n), t[keep]))
            worst = max(worst, float(d.max()))
        others.append(c["name"])
    return worst, ", ".join(others)


def html(doc, curves) -> str:
    """The "Equivalent models" section: a table and one plot per group."""
    groups = doc.get("equivalence") or []
    if not groups:
        return ""
    rows = []
    for e in groups:
        kind, verdict = verdict_of(doc, f"equivalence/{e['group']}")
        dev = "–" if e["max_deviation_rel"] is None else f"{e['max_deviation_rel']:.1e}"
        worst = max(e["members"], key=lambda m: m["max_deviation_rel"], default=None)
        where = "" if worst is None else f"{worst['case']} point {worst['point']} at t = {worst['t']:.3g} s"
        status = Agreement(e["status"])
        cls = "bad" if status.failure or kind == "regressed" else ""
        rows.append(f"<tr><td class=l>{escape(e['group'])}</td><td class=l>{escape(', '.join(e['cases']))}</td>"
                    f"<td class=l>{escape(', '.join(e['points']))}</td><td>{dev}</td><td class=l>{escape(where)}</td>"
                    f"<td class='l {cls}'>{escape(verdict if status is Agreement.OK else status_text(e))}</td></tr>")
    imgs = []
    for e in groups:
        if curves.get(e["group"]):
            imgs.append(f'<img alt="agreement of group {escape(e["group"])}" '
                        f'src="{plot(e, curves[e["group"]])}">')
    return ('<section id="equivalence"><h2>Equivalent models</h2><p>Cases that declare the same '
            "<code>[equivalent]</code> group model one mechanism; the named points they list must coincide. "
            "Deviation: the largest distance between a case's points and the first case's, per instant, over the "
            "shared points, / L of the first case; both solutions are native at the reference tolerance.</p>"
            "<table><tr><th class=l>group</th><th class=l>cases (first: the one compared against)</th>"
            "<th class=l>points</th><th>max deviation / L</th><th class=l>worst</th><th class=l>verdict</th></tr>"
            + "".join(rows) + "</table>" + "".join(imgs) + "</section>")


def plot(entry, curve) -> str:
    from .plots import TINY, _plt, _png

    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.0, 2.8))
    first = entry["cases"][0]
    for k, (name, (t, d)) in enumerate(curve.items()):
        ax.semilogy(t, np.maximum(d, TINY), color=f"C{k}", lw=1.4, label=f"{name} vs {first}")
    # a fixed floor and at least up to 1e-10, so agreement to rounding looks like it: a flat band at the bottom
    top = max([max(d) for _, d in curve.values()] + [1e-10])
    ax.set_ylim(TINY / 10, 10 * top)
    ax.axhspan(TINY / 10, 1e-13, color="0.9", zorder=0, label="rounding (< 1e-13 L)")
    ax.set_xlabel("t (s)", fontsize=9)
    ax.set_ylabel("deviation / L", fontsize=9)
    ax.set_title(f"group {entry['group']}: points {', '.join(entry['points'])}; "
                 f"max {entry['max_deviation_rel']:.1e} L", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    ax.tick_params(labelsize=8)
    return _png(fig)


def line(doc) -> str:
    """One Markdown line per group for summary.md."""
    out = []
    for e in doc.get("equivalence") or []:
        dev = "–" if e["max_deviation_rel"] is None else f"{e['max_deviation_rel']:.1e}"
        v = ((doc.get("gate") or {}).get("verdicts") or {}).get(f"equivalence/{e['group']}", "")
        out.append(f"- Equivalent models **{e['group']}** ({', '.join(e['cases'])}; points {', '.join(e['points'])}): "
                   f"max deviation / L {dev}" + (f"; {status_text(e)}" if Agreement(e["status"]) is not Agreement.OK else "")
                   + (f"; {v}" if v else ""))
    return "\n".join(out)
