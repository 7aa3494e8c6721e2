"""The stress suite as a section of the report (kinem.stress, quick sweep):
its outcomes go into results.json under "stress", a table into index.html
and one line into summary.md. Native missing its expected class fails the run."""

from .escaping import escape
from .results import clean


def run(engines, workers, scheduler, bar=None) -> dict:
    """The quick suite on native and engines (as kinem.stress.run), stepping bar."""
    from .. import stress
    from .progress import run_all

    tasks = [(s, e) for s in stress.scenarios(quick=True) for e in ("native",) + tuple(engines)
             if e == "native" or s.engines]
    outcomes = run_all(stress.run_one, tasks, [f"stress {s.name} {e}" for s, e in tasks], workers, scheduler, bar)
    misses = [f"{o.value.scenario}: {o.status.value} ({o.message}), expected {want.value}"
              for o, want in stress.misses(outcomes, quick=True)]
    return {"quick": True, "rows": clean([stress.as_dict(o) for o in outcomes]), "native_misses": misses}


def html(doc) -> str:
    s = doc.get("stress")
    if not s:
        return ""
    from ..stress import cell, from_dict, grid

    outcomes = [from_dict(r) for r in s["rows"]]
    engines = list(dict.fromkeys(o.value.engine for o in outcomes))
    names, by = grid(outcomes)
    head = "<tr><th class=l>group</th><th class=l>scenario</th>" + "".join(f"<th>{escape(e)}</th>" for e in engines) + "</tr>"
    body = []
    for g, n in names:
        cells = []
        for e in engines:
            o = by.get((n, e))
            title = escape("" if o is None else o.message)
            cells.append(f'<td{" class=bad" if o is not None and o.status.failure else ""} title="{title}">'
                         f"{escape(cell(o))}</td>")
        body.append(f"<tr><td class=l>{escape(g)}</td><td class=l>{escape(n)}</td>{''.join(cells)}</tr>")
    misses = "".join(f"<li>{escape(m)}</li>" for m in s["native_misses"])
    why = doc["options"].get("stress") or "--stress"
    return ('<section id="stress"><h2>Stress suite</h2><p>The repository\'s own stress cases (cases/stress and '
            f"generated scenarios), not the cases above; it ran because of {escape(why)} (it runs with --stress or "
            "when the report covers the whole case set). Each outcome classified (kinem stress --quick; classes in "
            "kinem/stress.py): native has an expected class per scenario, and native missing it fails the run "
            "(exit 1); engines are measured only, their red cells (diverged, nan, inaccurate) do not affect the "
            "exit code. Engines are judged on every figure of the scale-free tolerance table (docs/engines.md); "
            "a cell outside it names the figure farthest over its limit (pos: position / L, angle: rad, vel: / V, "
            "omega: / (V / L), resid: loop closure), else shows the position error / L (angles in rad) against "
            "the closed form or native. Hover for the class's message and the figures over their limits.</p>"
            + (f"<p class=bad>Native missed its expectation:</p><ul>{misses}</ul>" if misses else "")
            + f"<div class=wrap><table>{head}{''.join(body)}</table></div></section>")


def line(doc) -> str:
    s = doc.get("stress")
    if not s:
        return ""
    from ..stress import Class

    counts = {}
    for r in s["rows"]:
        if r["engine"] != "native":
            k = Class(r["outcome"])
            counts[k] = counts.get(k, 0) + 1
    native = "native met every expectation" if not s["native_misses"] else \
        f"**native missed {len(s['native_misses'])} expectation(s)**: " + "; ".join(s["native_misses"])
    return f"Stress suite (quick): {native}; engines: " + ", ".join(f"{v} {k.value}" for k, v in sorted(counts.items()))
