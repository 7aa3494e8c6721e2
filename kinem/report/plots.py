"""The report's plots as data: URIs (matplotlib, Agg): SVG or PNG, whichever is lighter.
The mechanism's drawings and animation are motion.py's."""
import base64
import io

import numpy as np

from .escaping import escape

COLORS = {"native": "black", "pymunk": "tab:orange", "mujoco": "tab:blue", "exudyn": "tab:green"}
TINY = 1e-16   # smaller errors (often exactly 0: the reference's own iterates) are drawn here
SVG_VERTICES = 1000  # a 500-instant trajectory figure: 52 kB SVG against 32 kB PNG
CONSTANT = 1e-9  # a column whose range is below this x L (or rad) is constant: the reference is converged
                 # to 1e-13, so this is far above its rounding and far below anything a plot could show


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> str:
    """The figure as a data: URI: SVG (text kept as text) when that is
    lighter than the PNG, else the PNG. Figures with more than SVG_VERTICES
    line vertices are always heavier as SVG (measured), so only the PNG is made."""
    png, svg = io.BytesIO(), io.BytesIO()
    fig.savefig(png, format="png", dpi=80, bbox_inches="tight")
    if sum(len(line.get_xdata()) for ax in fig.axes for line in ax.lines) > SVG_VERTICES:
        _plt().close(fig)
        return "data:image/png;base64," + base64.b64encode(png.getvalue()).decode("ascii")
    with _plt().rc_context({"svg.fonttype": "none"}):
        fig.savefig(svg, format="svg", bbox_inches="tight", metadata={"Date": None})
    _plt().close(fig)
    kind, data = min((("image/svg+xml", svg.getvalue()), ("image/png", png.getvalue())), key=lambda k: len(k[1]))
    return f"data:{kind};base64," + base64.b64encode(data).decode("ascii")


def img(uri, alt) -> str:
    """An <img> of a figure's data: URI (``_png``)."""
    return f'<img alt="{escape(alt)}" src="{uri}">'


def constant(values, scale, rel=CONSTANT):
    """True when ``values`` vary by no more than rel x scale (rounding, not motion)."""
    v = np.asarray(values, float)
    return bool(v.size) and bool(np.all(np.isfinite(v))) and float(np.ptp(v)) <= rel * scale


def trajectories(t_ref, ref_cols, runs, unit="", length=1.0):
    """Key columns, four panels a row: reference thick grey, native solid,
    engines dashed. runs: engine -> series. Columns of the reference that
    are constant (positions within CONSTANT x L, angles within CONSTANT rad)
    are not drawn. Returns (data: URI or None, {column: its constant value})."""
    plt = _plt()
    flat = {c: float(np.mean(v)) for c, v in ref_cols.items()
            if constant(v, 1.0 if c.endswith(".phi") else length)}
    cols = [c for c in ref_cols if c not in flat]
    if not cols:
        return None, flat
    ncols = min(4, len(cols))
    nrows = -(-len(cols) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.3 * ncols, 2.5 * nrows), squeeze=False)
    for ax in axes.flat[len(cols):]:
        ax.set_visible(False)
    for ax, col in zip(axes.flat, cols):
        ax.plot(t_ref, ref_cols[col], "-", color="0.7", lw=4, label="reference")
        for e, s in runs.items():
            if col in s["columns"]:
                ax.plot(s["t"], s["columns"][col], "-" if e == "native" else "--",
                        color=COLORS.get(e), lw=1.2, label=e)
        u = "rad" if col.endswith(".phi") else unit
        ax.set_title(f"{col} ({u})" if u else col, fontsize=10, parse_math=False)  # units are text, never mathtext
        ax.set_xlabel("t (s)", fontsize=9)
        ax.tick_params(labelsize=8)
    if axes[0][0].get_legend_handles_labels()[0]:
        axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    return _png(fig), flat


def errors(runs) -> str:
    """Position error / L against time, one line per run, log scale."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 2.8))
    for e, s in runs.items():
        ax.semilogy(s["t"], np.maximum(s["error"], TINY), color=COLORS.get(e), lw=1.2, label=e)
    ax.set_xlabel("t (s)", fontsize=8)
    ax.set_ylabel("position error / L", fontsize=8)
    ax.grid(True, which="major", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    ax.tick_params(labelsize=7)
    return _png(fig)


STYLES = (("o", "-"), ("s", "--"), ("^", ":"), ("D", "-."), ("v", (0, (5, 1))), ("P", (0, (1, 3))))   # per family


def family_label(curve) -> str:
    """'mujoco dt, integrator=Euler': the engine, the swept knob, the knobs held."""
    held = ", ".join(f"{k}={v}" for k, v in (curve.get("family") or {}).items())
    return f"{curve['engine']} {curve['knob']}" + (f", {held}" if held else "")


def work_precision(wp) -> str:
    """Error against wall time per simulated second, log-log: position error
    / L (left) and relative velocity error (right). One line per engine and
    knob family: the engine's colour, a marker and line style per family (the
    defaults' family solid with circles). The engine's Pareto front (points
    with ``front``, on position error) is outlined by a wide pale band on the
    left panel. The defaults' family and the front points are labelled with
    their dt (or tolerance); every point's values are in the table below."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.4))
    for ax, key, label in ((axes[0], "error", "max position error / L"),
                           (axes[1], "velocity_error_rel", "max velocity error / characteristic speed")):
        labels, others, fronts, nth = [], [], {}, {}
        for curve in wp["curves"]:
            e = curve["engine"]
            k = nth[e] = nth.get(e, -1) + 1
            ok = [p for p in curve["points"] if p["outcome"] == "ok" and p[key] is not None and p["cost"]]
            if not ok:
                continue
            x = [p["cost"] for p in ok]
            y = [max(p[key], TINY) for p in ok]
            marker, line = STYLES[k % len(STYLES)]
            ax.loglog(x, y, marker=marker, linestyle=line, color=COLORS.get(e), ms=4 if k else 5, lw=1.1,
                      label=family_label(curve))
            for p, xi, yi in zip(ok, x, y):
                if k == 0 or p.get("front"):
                    labels.append((f"{p['value']:.0e}", xi, yi, COLORS.get(e)))
                else:
                    others.append((xi, yi))
                if p.get("front") and key == "error":
                    fronts.setdefault(e, []).append((xi, yi))
        for e, pts in fronts.items():
            ax.plot(*zip(*sorted(pts)), "-", color=COLORS.get(e), lw=7, alpha=0.2, solid_capstyle="round",
                    label=f"{e} Pareto front")
        _place_labels(ax, labels, others)
        ax.set_xlabel("wall time per simulated second (s)", fontsize=8)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, which="major", alpha=0.3)
        ax.tick_params(labelsize=7)
    if axes[0].get_legend_handles_labels()[0]:
        fig.legend(*axes[0].get_legend_handles_labels(), fontsize=7, loc="upper center",
                   ncol=4, bbox_to_anchor=(0.5, 0.0), frameon=False)
    fig.tight_layout()
    return _png(fig)


OFFSETS = ((4, 4), (4, -11), (-34, 4), (-34, -11), (4, 12), (-34, 12))   # points, tried in turn


def _place_labels(ax, labels, others=()):
    """Annotates (text, x, y, colour) points at the first offset where the
    label overlaps no label placed before it and no other point (of labels
    or the unlabelled (x, y) ``others``); a label with no free place is left
    out (its point's value is in the table below the plot)."""
    ax.autoscale_view()
    renderer = ax.figure.canvas.get_renderer()
    pts = [ax.transData.transform((x, y)) for _, x, y, _ in labels]
    pts += [ax.transData.transform(xy) for xy in others]
    placed = []
    for k, (text, x, y, color) in enumerate(labels):
        for off in OFFSETS:
            a = ax.annotate(text, (x, y), fontsize=7, xytext=off, textcoords="offset points", color=color)
            box = a.get_window_extent(renderer).expanded(1.05, 1.1)
            if not (any(box.overlaps(b) for b in placed)
                    or any(box.contains(*p) for j, p in enumerate(pts) if j != k)):
                placed.append(box)
                break
            a.remove()
