"""``kinem diff A.json B.json``: what moved between two results.json files
(B against A, as the gate judges a run against its baseline), then every
gated figure and cost count that changed at all, each naming the case, the
engine and the quantity."""
from . import gate, results

CHANGED = 1e-3   # a figure that moved by more than this fraction (above gate.ERROR_FLOOR) is listed


def diff(a_path, b_path) -> tuple:
    """(lines, regressions): the gate's findings of B against A (fatal ones
    first), then the figures and counts that changed without being findings."""
    a, b = results.load(a_path, "results"), results.load(b_path, "results")
    g = gate.gate(b, a, a_path, scope=gate.scope_of(b))
    found = sorted(g["findings"], key=lambda f: not f["fatal"])
    lines = [f"{'REGRESSED' if f['fatal'] else f['kind']}: {f['case']}/{f['engine']} ({f['where']}): {f['message']}"
             for f in found]
    lines += [f"not compared: {x}" for x in g["not_compared"]]
    seen = {(f["case"], f["engine"], f["metric"]) for f in found}
    old = {(c["name"], r["engine"]): r for c in a["cases"] for r in c["runs"]}
    for c in b["cases"]:
        for r in c["runs"]:
            o = old.get((c["name"], r["engine"]))
            if o is None:
                continue
            for k in gate.GATED:
                x, y = o.get(k), r.get(k)
                if (c["name"], r["engine"], k) in seen or x is None or y is None:
                    continue
                if abs(y - x) > CHANGED * max(abs(x), gate.ERROR_FLOOR):
                    lines.append(f"moved: {c['name']}/{r['engine']}: {k} {x:.3e} -> {y:.3e}")
            for k, x in (o.get("counts") or {}).items():
                y = (r.get("counts") or {}).get(k)
                if y is not None and y != x and (c["name"], r["engine"], k) not in seen:
                    lines.append(f"moved: {c['name']}/{r['engine']}: {k} {x} -> {y}")
            if o.get("verdict") != r.get("verdict"):
                lines.append(f"verdict: {c['name']}/{r['engine']}: {o.get('verdict')!r} -> {r.get('verdict')!r}")
    return lines, g["regressions"]
