"""The report's design section of a case that asks for it (docs/design.md):
``[report] sensitivity = [paths]`` gives a table and a plot of the exact
sensitivities of the named points, each checked against central
differences of native's own solves; a ``[tolerances]`` section gives the
tolerance bands against time and along the first point's path."""

import numpy as np

from .escaping import escape
from .plots import _plt, _png, img

SAMPLES = 200      # Monte Carlo samples of the report's bands
STEP = 5e-4        # central differences' step, of the parameter's scale (as tests/test_sensitivity.py)
FLOOR = 1e-9       # of a row's largest peak: below it a column's peak is rounding, not its scale


def section(model, engines=()) -> list:
    """HTML pieces: empty for a case that asks for neither. ``engines``: the
    engines whose run of the case was ok; their central differences are
    judged beside native's (adapters.sensitivity, docs/design.md (X1))."""
    out = []
    paths = model.case.report.get("sensitivity", ())
    fixed = {c["body"] for c in model.case.constraints if c.type == "ground"}
    body = {p.name: p.body for p in model.case.points}
    points = [p for p in model.case.report.get("points") or body if body[p] not in fixed]   # the moving ones
    columns = [f"{p}.{k}" for p in points for k in ("x", "y")]
    if (paths or model.case.tolerances) and not columns:   # asked for, nothing to draw: said, not left out unseen
        out.append("<h3>Design sensitivities and tolerance bands</h3><p>Not drawn: they are the named points' on "
                   "moving bodies, and the case has none (its [points], or the [report] points listed).</p>")
    if paths and columns:
        out += _sensitivity(model, paths, columns, engines)
    if model.case.tolerances and columns:
        out += _bands(model, columns[-2:])   # the last moving point: its path and its band
    return out


def _sensitivity(model, paths, columns, engines=()):
    from ..parameters import resolve
    from ..sensitivity import differenced, sensitivity
    from ..solver import solve

    case = model.case
    sens = sensitivity(model, paths)
    rows, fig_cols = [], []
    listed = resolve(case, paths)   # a name of [parameters] as its path, each parameter once
    for p in listed:
        h, models, failed = differenced(model, p, STEP)
        moved = [solve(m, outputs=("positions",)) for m in (models or {}).values()]
        failed = failed or next((r.message for r in moved if not r.success), None)   # past an assembly limit
        runs = [r.trajectory for r in moved]
        exact = {c: sens.of(c, p.path) for c in columns}
        peaks = [float(np.max(np.abs(exact[c]))) for c in columns]
        floor = FLOOR * max(peaks, default=0.0)   # a column the parameter does not move: its peak is rounding
        worst = 0.0
        for c, peak in zip(columns, peaks):
            fd = None if failed else (4 * (runs[0][c] - runs[1][c]) / (2 * h)
                                      - (runs[2][c] - runs[3][c]) / (4 * h)) / 3
            if fd is not None:
                worst = max(worst, float(np.max(np.abs(exact[c] - fd))) / max(peak, floor, 1e-300))
            fig_cols.append((p.path, c, exact[c], fd))
        rows.append((p, peaks, f"not computed: native at p +- h: {failed}" if failed else worst))
    checks = _engines(model, paths, engines)
    unit = escape(case.length_unit)
    head = "".join(f"<th>max |d({escape(c)})/dp|</th>" for c in columns)
    body = "".join(
        f"<tr><td class=l><code>{escape(p.path)}</code></td><td>{p.value:.6g} {escape(p.unit)}</td>"
        + "".join(f"<td>{v:.4g}</td>" for v in peaks) + (f"<td>{escape(w)}</td>" if isinstance(w, str) else
                                                          f"<td>{w:.1e}</td>")
        + "".join(_cell(checks.get((e, p.path))) for e in engines) + "</tr>" for p, peaks, w in rows)
    head_e = "".join(f"<th>{escape(e)} differences</th>" for e in engines)
    said = ("Each engine's column: its central differences at p +- h (the step settings it chose on the nominal "
            "case) against the exact ones, the largest ratio to the limit eps L/h + (2/3) max|D_n(2h) - D_n(h)| "
            "(docs/design.md, X1; above 1 is outside, the figure named); in the plot, crosses. "
            if engines else "")
    text = (f"<h3>Design sensitivities</h3><p>Exact derivatives of the named points' positions ({unit} per unit "
            "of the parameter) by direct differentiation (docs/design.md, Eqs. S1-S3); the last column is the "
            "largest difference from native's own extrapolated central differences, relative to the peak. "
            f"{said}"
            f"{'Phi_q is singular at some instants: ' + escape(sens.message) if sens.singular.any() else ''}</p>"
            f"<table><tr><th class=l>parameter</th><th>value</th>{head}<th>native differences</th>{head_e}</tr>{body}"
            "</table>")
    return [text, _sensitivity_plot(sens.trajectory.t, [p.path for p in listed], columns, fig_cols, checks)]


def _engines(model, paths, engines) -> dict:
    """(engine, path) -> adapters.sensitivity.Check of each engine's differences."""
    if not engines:
        return {}
    from adapters.sensitivity import check

    _, checks = check(model, paths, list(engines))
    return {(c.engine, c.parameter): c for c in checks}


def _cell(c) -> str:
    if c is None:
        return "<td>–</td>"
    if c.within is None or c.status.value != "ok":
        return f"<td>{escape(c.text)}</td>"
    text = f"{c.ratio:.2g}" if c.within else f"<b>{c.ratio:.2g}: {escape(c.figure)}</b>"
    return f"<td title=\"{escape(c.text)}\">{text}</td>"


def _sensitivity_plot(t, paths, columns, curves, checks=None):
    plt = _plt()
    fig, axes = plt.subplots(1, len(paths), figsize=(4.2 * len(paths), 3.0), squeeze=False)
    every = max(1, len(t) // 25)
    for ax, path in zip(axes[0], paths):
        for (p, c, exact, fd) in curves:
            if p == path:
                line, = ax.plot(t, exact, lw=1.2, label=f"d({c})")
                if fd is not None:
                    ax.plot(t[::every], fd[::every], "o", ms=3, mfc="none", color=line.get_color())
                for (e, q), k in (checks or {}).items():
                    if q == path and c in k.curves:
                        ax.plot(t[::every], k.curves[c][::every], "x", ms=3, color=line.get_color())
        ax.set_title(path, fontsize=9)
        ax.set_xlabel("t [s]")
    axes[0][0].legend(fontsize=7, title="lines exact, circles native's differences, crosses engines'", title_fontsize=7)
    fig.tight_layout()
    return img(_png(fig), "design sensitivities")


def _bands(model, outputs):
    from ..tolerance import tolerance

    b = tolerance(model, samples=SAMPLES, outputs=outputs, seed=0, chunk=1)   # sections run in forked workers
    plt = _plt()
    t = b.table.t
    fig, axes = plt.subplots(1, len(outputs) + 1, figsize=(4.2 * (len(outputs) + 1), 3.0))
    for ax, c in zip(axes, outputs):
        v = b[c]
        ax.fill_between(t, b[f"{c}.worst-"] - v, b[f"{c}.worst+"] - v, color="0.85", label="worst case")
        ax.plot(t, b[f"{c}.rss+"] - v, "b--", lw=1, label="root-sum-square")
        ax.plot(t, b[f"{c}.rss-"] - v, "b--", lw=1)
        ax.plot(t, b[f"{c}.mc+"] - v, "r-", lw=1, label=f"Monte Carlo ({SAMPLES})")
        ax.plot(t, b[f"{c}.mc-"] - v, "r-", lw=1)
        ax.set_title(f"{c} - nominal", fontsize=9)
        ax.set_xlabel("t [s]")
    axes[0].legend(fontsize=7)
    x, y = outputs[0], outputs[1] if len(outputs) > 1 else outputs[0]
    ax = axes[-1]
    ax.plot(b[x], b[y], "k-", lw=1)
    k = slice(None, None, max(1, len(t) // 24))
    ex, ey = (b[f"{x}.worst+"] - b[x])[k], (b[f"{y}.worst+"] - b[y])[k]
    extent = max(np.ptp(b[x]), np.ptp(b[y]), 1e-300)
    big = max(float(np.max(ex)), float(np.max(ey)), 1e-300)
    zoom = 10.0 ** max(0, round(np.log10(0.04 * extent / big)))   # bars drawn magnified to be seen
    ax.errorbar(b[x][k], b[y][k], xerr=zoom * ex, yerr=zoom * ey, fmt="none", ecolor="tab:red", lw=0.8)
    ax.set_title(f"{x[:-2]}'s path, worst-case band x{zoom:g}", fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    fig.tight_layout()
    left = (f"{len(b.rejected)} of {b.samples} samples left the nominal's branch or could not assemble and are "
            "not in the band. " if b.rejected else "")
    excess = ("Largest excess of the Monte Carlo band over the linear one: "
              + "; ".join(f"{escape(c)}: {a:.2g} at t = {s:.3g}" for c, a, s in b.excess) if b.accepted
              else "No Monte Carlo band: no sample is in it")   # not an excess of 0 over a band that is not there
    return ["<h3>Tolerance bands</h3><p>The case's [tolerances]: worst-case linear band (grey), root-sum-square "
            f"(dashed), Monte Carlo over {SAMPLES} seeded samples on the nominal's branch (red); {left}"
            f"{excess}.</p>",
            img(_png(fig), "tolerance bands")]
