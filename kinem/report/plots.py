"""The report's figures, as base64 PNG for data: URIs (matplotlib, Agg)."""
import base64
import io

import numpy as np

COLORS = {"native": "black", "pymunk": "tab:orange", "mujoco": "tab:blue", "exudyn": "tab:green"}
TINY = 1e-16   # smaller errors (often exactly 0: the reference's own iterates) are drawn here
JOINT_MARKERS = {"revolute": "o", "translational": "s", "revolute-translational": "D"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, bbox_inches="tight")
    _plt().close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def shapes(model):
    """(body, local points as complex) of the outlines (cams, slots) and the
    circles (gears' pitch circles, rollers) the constraints put on bodies:
    each on the body named last before it among the type's keys, a circle
    about the local point given last on that body (else its origin)."""
    from kinem.casefile.keys import BodyKey, LocalKey, OutlineKey, PositiveKey
    from kinem.constraints import REGISTRY

    out, ring = [], np.exp(1j * np.linspace(0, 2 * np.pi, 73))
    for c in model.case.constraints:
        body, centre = None, 0j
        for key in REGISTRY[c.type].keys:
            v = c.get(key.name)
            if v is None:
                continue
            if isinstance(key, BodyKey):
                body, centre = v, 0j
            elif isinstance(key, LocalKey) and key.of and c.get(key.of) == body and not isinstance(v, str):
                centre = complex(*v)
            elif isinstance(key, PositiveKey) and key.name != "length" and body:
                out.append((body, centre + float(v) * ring))
            elif isinstance(key, OutlineKey) and body and hasattr(v, "point_at"):
                a, b = v.span
                out.append((body, np.asarray(v.point_at(np.linspace(a, b, 121))[0])))
    return out


def mechanism(model, times, qs) -> str:
    """Each body as the polygon of its points (sorted by angle about their
    centre), ground points as triangles, joints marked, at a few instants."""
    from adapters.base import body_points, grounded
    from kinem.casefile.keys import LocalKey
    from kinem.constraints import REGISTRY

    plt = _plt()
    pts, fixed, extra = body_points(model), grounded(model), shapes(model)
    fig, axes = plt.subplots(1, len(times), figsize=(3.2 * len(times), 3.0))
    axes = np.atleast_1d(axes)
    for ax, t, q in zip(axes, times, qs):
        q = np.asarray(q)
        for k, b in enumerate(model.body_names):
            local = np.unique(np.array(pts[b] or [(0.0, 0.0)], float), axis=0)
            w = (q[3 * k] + 1j * q[3 * k + 1]) + (local[:, 0] + 1j * local[:, 1]) * np.exp(1j * q[3 * k + 2])
            if b in fixed:
                ax.plot(w.real, w.imag, "^", color="0.4", ms=7)
                continue
            c = w.mean()
            w = w[np.argsort(np.angle(w - c))]
            ring = np.append(w, w[:1])
            ax.fill(ring.real, ring.imag, alpha=0.25, color=f"C{k % 10}")
            ax.plot(ring.real, ring.imag, "-", color=f"C{k % 10}", lw=1.5)
        for b, local in extra:
            k = model.body_names.index(b)
            w = (q[3 * k] + 1j * q[3 * k + 1]) + local * np.exp(1j * q[3 * k + 2])
            ax.plot(w.real, w.imag, "-", color="0.4" if b in fixed else f"C{k % 10}", lw=1)
        for c in model.case.constraints:  # each joint at its first local point
            key = next((k for k in REGISTRY[c.type].keys if isinstance(k, LocalKey) and c.get(k.name) is not None), None)
            if key is None or c.type == "driver":
                continue
            k = model.body_names.index(c[key.of])
            p = (q[3 * k] + 1j * q[3 * k + 1]) + complex(*c[key.name]) * np.exp(1j * q[3 * k + 2])
            ax.plot(p.real, p.imag, JOINT_MARKERS.get(c.type, "x"), mfc="white", mec="black", ms=5)
        ax.set_title(f"t = {t:.3g} s", fontsize=9)
        ax.tick_params(labelsize=7)
    lo = np.min([ax.dataLim.min for ax in axes], axis=0)
    hi = np.max([ax.dataLim.max for ax in axes], axis=0)
    pad = 0.05 * (hi - lo).max()
    for ax in axes:  # the same window in every panel
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box")
    return _png(fig)


def trajectories(t_ref, ref_cols, runs, unit="") -> str:
    """Key columns: reference (native) solid, engines dashed. runs: engine -> series."""
    plt = _plt()
    cols = list(ref_cols)
    fig, axes = plt.subplots(1, len(cols), figsize=(3.2 * len(cols), 2.6), squeeze=False)
    for ax, col in zip(axes[0], cols):
        ax.plot(t_ref, ref_cols[col], "-", color="0.7", lw=4, label="reference")
        for e, s in runs.items():
            if col in s["columns"]:
                ax.plot(s["t"], s["columns"][col], "-" if e == "native" else "--",
                        color=COLORS.get(e), lw=1.2, label=e)
        ax.set_title(f"{col} ({unit})" if unit else col, fontsize=9, parse_math=False)  # units are text, never mathtext
        ax.set_xlabel("t (s)", fontsize=8)
        ax.tick_params(labelsize=7)
    if axes[0][0].get_legend_handles_labels()[0]:
        axes[0][0].legend(fontsize=7)
    return _png(fig)


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


def work_precision(wp) -> str:
    """Error against wall time per simulated second, log-log, one curve per
    engine: position error / L (left) and relative velocity error (right)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.0))
    for ax, key, label in ((axes[0], "error", "max position error / L"),
                           (axes[1], "velocity_error_rel", "max velocity error / characteristic speed")):
        for curve in wp["curves"]:
            ok = [p for p in curve["points"] if p["status"] == "ok" and p[key] is not None and p["cost"]]
            if not ok:
                continue
            x = [p["cost"] for p in ok]
            y = [max(p[key], TINY) for p in ok]
            e = curve["engine"]
            ax.loglog(x, y, "o-", color=COLORS.get(e), label=f"{e} ({curve['knob']})")
            for p, xi, yi in zip(ok, x, y):
                ax.annotate(f"{p['value']:.0e}", (xi, yi), fontsize=6, xytext=(3, 3), textcoords="offset points")
        ax.set_xlabel("wall time per simulated second (s)", fontsize=8)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, which="major", alpha=0.3)
        ax.tick_params(labelsize=7)
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=7)
    return _png(fig)
