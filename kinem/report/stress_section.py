"""The stress suite as a section of the report (kinem.stress, quick sweep):
its outcomes go into results.json under "stress", a table into index.html
and one line into summary.md. Native missing its expected class fails the run."""
from html import escape


def run(engines, workers, scheduler, bar=None) -> dict:
    """The quick suite on native and engines (as kinem.stress.run), stepping bar."""
    from .. import stress
    from .progress import run_all

    tasks = [(s, e) for s in stress.scenarios(quick=True) for e in ("native",) + tuple(engines)
             if e == "native" or s.engines]
    rows = run_all(stress.run_one, tasks, [f"stress {s.name} {e}" for s, e in tasks], workers, scheduler, bar)
    want = stress.expected(quick=True)
    misses = [f"{r['scenario']}: {r['outcome']}, expected {want[r['scenario']]}"
              for r in rows if r["engine"] == "native" and r["outcome"] != want[r["scenario"]]]
    clean = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()} for r in rows]
    return {"quick": True, "rows": clean, "native_misses": misses}


def html(doc) -> str:
    s = doc.get("stress")
    if not s:
        return ""
    from ..stress import cell, grid

    engines = list(dict.fromkeys(r["engine"] for r in s["rows"]))
    names, by = grid(s["rows"])
    head = "<tr><th class=l>group</th><th class=l>scenario</th>" + "".join(f"<th>{escape(e)}</th>" for e in engines) + "</tr>"
    body = []
    for g, n in names:
        cells = []
        for e in engines:
            r = by.get((n, e))
            text = cell(r)
            good = text.split(" ")[0] in ("accurate", "singular-detected", "unsupported", "-")
            title = escape((r or {}).get("detail") or "")
            cells.append(f'<td{"" if good else " class=bad"} title="{title}">{escape(text)}</td>')
        body.append(f"<tr><td class=l>{escape(g)}</td><td class=l>{escape(n)}</td>{''.join(cells)}</tr>")
    misses = "".join(f"<li>{escape(m)}</li>" for m in s["native_misses"])
    why = doc["options"].get("stress") or "--stress"
    return ('<section id="stress"><h2>Stress suite</h2><p>The repository\'s own stress cases (cases/stress and '
            f"generated scenarios), not the cases above; it ran because of {escape(why)} (it runs with --stress or "
            "when the report covers the whole case set). Each outcome classified (kinem stress --quick; classes in "
            "kinem/stress.py): native has an expected class per scenario, and native missing it fails the run "
            "(exit 1); engines are measured only, their red cells (diverged, nan, inaccurate) do not affect the "
            "exit code. Numbers: position error / L (angles in rad) against the closed form or native.</p>"
            + (f"<p class=bad>Native missed its expectation:</p><ul>{misses}</ul>" if misses else "")
            + f"<div class=wrap><table>{head}{''.join(body)}</table></div></section>")


def line(doc) -> str:
    s = doc.get("stress")
    if not s:
        return ""
    counts = {}
    for r in s["rows"]:
        if r["engine"] != "native":
            k = "unsupported" if r["outcome"].startswith("unsupported") else r["outcome"]
            counts[k] = counts.get(k, 0) + 1
    native = "native met every expectation" if not s["native_misses"] else \
        f"**native missed {len(s['native_misses'])} expectation(s)**: " + "; ".join(s["native_misses"])
    return f"Stress suite (quick): {native}; engines: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
