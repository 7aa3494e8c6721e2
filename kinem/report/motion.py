"""The mechanism's motion as SVG: one drawing (drawing.py's scene), either at
one frame (a snapshot) or animated over all frames with SMIL
(animateTransform: no script, so it plays inside the report's page and in
any browser). Native is drawn solid, each engine's pose as a dashed ghost of
its colour over it, the named points' paths (coupler curves) under both;
bodies and points are labelled, a bar shows the time, a legend the symbols
and a scale bar the length unit.

Frames are time-major coordinates (frames, n) at the same instants for
native and the engines (runs.py samples them).
"""

import numpy as np

from .escaping import escape
from .drawing import MARK_NAMES, poses, scene, world

BODY_COLORS = ("#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#d62728", "#7f7f7f")
ENGINE_COLORS = {"pymunk": "#ff7f0e", "mujoco": "#1f77b4", "exudyn": "#2ca02c"}
HALO = 'paint-order="stroke" stroke="#fff" stroke-width="3" stroke-linejoin="round"'
BODY_SIDES = ((8, -8), (8, 20), (-8, -8), (-8, 20), (8, -24), (-8, -24), (8, 36), (-8, 36))  # label offsets, px
PAD = 28                      # px: margin round the drawing
TOP = 36                      # px: band above it (time of a snapshot, scale bar)


def duration(t):
    """Seconds one loop of the animation lasts: the run's own time, kept within 4-12 s."""
    return float(np.clip(t[-1] - t[0], 4.0, 12.0))


class _View:
    """World to screen: uniform scale, y up, the whole motion in view."""

    def __init__(self, pts, width, max_height):
        lo, hi = np.array([pts.real.min(), pts.imag.min()]), np.array([pts.real.max(), pts.imag.max()])
        span = np.maximum(hi - lo, 1e-9 * max(np.abs(hi - lo).max(), 1e-300))
        self.s = min((width - 2 * PAD) / span[0], (max_height - TOP - PAD) / span[1])
        self.x0 = lo[0] - ((width - 2 * PAD) / self.s - span[0]) / 2
        self.y1 = hi[1]
        self.width, self.height = width, int(np.ceil(span[1] * self.s + TOP + PAD))

    def px(self, w):
        w = np.asarray(w, complex)
        return PAD + self.s * (w.real - self.x0), TOP + self.s * (self.y1 - w.imag)

    def local(self, z):
        """A body's local points in px before its rotation and translation (y flipped)."""
        z = np.asarray(z, complex)
        return self.s * z.real, -self.s * z.imag


def _pts(x, y):
    return " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(np.atleast_1d(x), np.atleast_1d(y)))


def _item(v, it, color, ghost=None):
    """SVG of one scene item in its body's px frame; ghost: an engine colour (outline only)."""
    x, y = v.local(it.xy)
    p = _pts(x, y)
    if ghost:
        if it.role in ("joint", "ground"):
            return ""
        if it.role == "disc":
            return f'<circle cx="{x[0]:.1f}" cy="{y[0]:.1f}" r="6" fill="none" stroke="{ghost}"/>'
        return f'<polyline points="{p}" fill="none" stroke="{ghost}" stroke-width="1.5" stroke-dasharray="5 3"/>'
    r = it.role
    if r == "link":
        if len(x) == 2:
            return (f'<polyline points="{p}" stroke="{color}" stroke-width="7" stroke-linecap="round" '
                    f'stroke-opacity=".75" fill="none"/>')
        return f'<polygon points="{p}" fill="{color}" fill-opacity=".3" stroke="{color}" stroke-width="2.5"/>'
    if r == "disc":
        return f'<circle cx="{x[0]:.1f}" cy="{y[0]:.1f}" r="6" fill="{color}" fill-opacity=".6" stroke="{color}"/>'
    if r in ("circle", "cam"):
        return f'<polygon points="{p}" fill="{color}" fill-opacity=".1" stroke="{color}" stroke-width="1.5"/>'
    if r == "spoke":
        return f'<polyline points="{p}" stroke="{color}" stroke-width="2.5"/>'
    if r == "face":
        return f'<polyline points="{p}" stroke="{color}" stroke-width="4"/>'
    if r == "rack":
        return f'<polyline points="{p}" fill="none" stroke="{color}" stroke-width="1.5"/>'
    if r == "slot":
        return (f'<polyline points="{p}" fill="none" stroke="#555" stroke-width="11" stroke-linecap="round"/>'
                f'<polyline points="{p}" fill="none" stroke="#fff" stroke-width="7" stroke-linecap="round"/>')
    if r == "rail":
        return f'<polyline points="{p}" stroke="#666" stroke-width="3"/>'
    if r == "ground":
        return (f'<polygon points="{x[0]:.1f},{y[0]:.1f} {x[0] - 6:.1f},{y[0] + 10:.1f} '
                f'{x[0] + 6:.1f},{y[0] + 10:.1f}" fill="#666"/>')
    return _mark(x[0], y[0], it.mark)


def _mark(x, y, mark):
    style = 'fill="#fff" stroke="#000" stroke-width="1.5"'
    if mark == "o":
        return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="4.5" {style}/>'
    if mark == "s":
        return f'<rect x="{x - 4.5:.1f}" y="{y - 4.5:.1f}" width="9" height="9" {style}/>'
    if mark == "D":
        return (f'<polygon points="{x:.1f},{y - 6:.1f} {x + 6:.1f},{y:.1f} {x:.1f},{y + 6:.1f} '
                f'{x - 6:.1f},{y:.1f}" {style}/>')
    if mark == "dot":
        return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3.5" fill="#111"/>'
    return f'<path d="M{x - 4:.1f},{y - 4:.1f}l8,8m0,-8l-8,8" stroke="#000" stroke-width="1.5"/>'


class _Clock:
    """Transforms at one frame (a snapshot) or animated over all of them."""

    def __init__(self, t, at, dur):
        self.at, self.dur = at, dur
        t = np.asarray(t, float)
        self.keys = ";".join(f"{k:.4f}" for k in (t - t[0]) / max(t[-1] - t[0], 1e-300))

    def _anim(self, kind, values, additive=False):
        return (f'<animateTransform attributeName="transform" type="{kind}" values="{values}" '
                f'keyTimes="{self.keys}" dur="{self.dur:.2f}s" repeatCount="indefinite"'
                f'{" additive=" + chr(34) + "sum" + chr(34) if additive else ""}/>')

    def group(self, x, y, angle=None, attrs=""):
        """<g ...> opening tag with its transform (and animation) for px
        positions x, y and angles in degrees per frame."""
        k = self.at or 0
        static = f"translate({x[k]:.1f} {y[k]:.1f})" + (f" rotate({angle[k]:.2f})" if angle is not None else "")
        head = f'<g{attrs} transform="{static}">'
        if self.at is not None:
            return head
        head += self._anim("translate", ";".join(f"{a:.1f} {b:.1f}" for a, b in zip(x, y)))
        if angle is not None:
            head += self._anim("rotate", ";".join(f"{a:.2f}" for a in angle), additive=True)
        return head


def svg(model, native, ghosts=None, at=None, width=820, max_height=520, standalone=False, paths_q=None) -> str:
    """The drawing as an <svg> element. native: {"t", "q"} frames; ghosts:
    engine -> q at the same frames; at: a frame index for a snapshot (None:
    animate); paths_q: denser native coordinates for the point paths
    (default: the frames)."""
    t, q = np.asarray(native["t"], float), np.asarray(native["q"], float)
    dense = q if paths_q is None else np.asarray(paths_q, float)
    sc = scene(model, dense)
    ghosts = {e: np.asarray(g, float) for e, g in (ghosts or {}).items() if len(g) == len(q)}
    paths = {name: world(model, dense, body, [p])[:, 0] for name, body, p in sc.points}
    everything = [world(model, q, it.body, it.xy).ravel() for it in sc.items] + list(paths.values())
    v = _View(np.concatenate(everything), width, max_height)
    clock = _Clock(t, at, duration(t))
    r, phi = poses(model, q)
    color = {b: BODY_COLORS[k % len(BODY_COLORS)] for k, b in enumerate(sc.bodies)}
    out = []
    for name, w in paths.items():                       # coupler curves, under everything
        body = next(b for n, b, _ in sc.points if n == name)
        x, y = v.px(w)
        out.append(f'<polyline data-path="{escape(name)}" points="{_pts(x, y)}" fill="none" '
                   f'stroke="{color[body]}" stroke-width="1.3" stroke-opacity=".8"/>')
    layers = [("native", None, r, phi)] + [(e, ENGINE_COLORS.get(e, "#000"), *poses(model, g))
                                            for e, g in ghosts.items()]
    for layer, ghost, rr, pp in layers:
        for k, b in enumerate(sc.bodies):
            if ghost and b in sc.fixed:
                continue
            mine = [it for it in sc.items if it.body == b]
            if ghost is None:  # joints on top of their bodies
                mine.sort(key=lambda it: it.role == "joint")
            x, y = v.px(rr[:, k])
            body = "".join(_item(v, it, color[b], ghost) for it in mine)
            for name, pb, p in sc.points if ghost is None else ():
                if pb == b:
                    (px,), (py,) = v.local([p])
                    body += f'<circle data-point="{escape(name)}" cx="{px:.1f}" cy="{py:.1f}" r="3.5" fill="#111"/>'
            attrs = f' data-layer="{escape(layer)}" data-body="{escape(b)}"'
            out.append(clock.group(x, y, -np.degrees(np.unwrap(pp[:, k])), attrs) + body + "</g>")
    out += _labels(sc, v, clock, q, model)
    out.append(_scale_bar(v, model.case.length_unit))
    if at is None:
        out.append(_time_bar(v, clock, t))
        legend, h = _legend(v, sc, list(ghosts))
        out.append(legend)
    else:
        out.append(f'<text x="{PAD}" y="20" font-weight="bold">t = {t[at]:.3g} s</text>')
        h = v.height
    ns = ' xmlns="http://www.w3.org/2000/svg"' if standalone else ""
    return (f'<svg{ns} class="motion" width="{v.width}" height="{h}" viewBox="0 0 {v.width} {h}" '
            f'font-family="sans-serif" font-size="13" role="img" style="max-width:100%;height:auto"><title>{escape(model.case.name)}: '
            f'{"motion" if at is None else f"t = {t[at]:.3g} s"}</title>'
            + "".join(out) + "</svg>")


def _labels(sc, v, clock, q, model):
    """Each named point's name beside it, each moving body's name at one of
    its points (or their mean, or an edge's middle); upright, following their
    body. Each label takes, in turn, the anchor and side whose box overlaps
    the labels placed before it at the fewest frames (snapshot: at its frame)."""
    frames = slice(None) if clock.at is None else slice(clock.at, clock.at + 1)
    placed, out = [], []

    def place(text, anchors, offsets, style):
        w = 7.5 * len(text) + 2
        best = None
        for x, y in anchors:
            for dx, dy in offsets:
                dx = dx if dx >= 0 else dx - w
                box = np.stack([x[frames] + dx, y[frames] + dy - 11, x[frames] + dx + w, y[frames] + dy + 3])
                cost = sum(int(np.sum((box[0] < o[2]) & (o[0] < box[2]) & (box[1] < o[3]) & (o[1] < box[3])))
                           for o in placed)
                if best is None or cost < best[0]:
                    best = (cost, box, x, y, dx, dy)
        cost, box, x, y, dx, dy = best
        placed.append(box)
        out.append(clock.group(x, y) + f'<text x="{dx:.0f}" y="{dy}" {style} {HALO}>{escape(text)}</text></g>')

    for name, b, p in sc.points:
        place(name, [v.px(world(model, q, b, [p])[:, 0])], ((6, 16), (6, -6), (-6, 16), (-6, -6)),
              'font-style="italic"')
    anchors = {}
    for b in sc.bodies:
        if b in sc.fixed:
            continue
        mine = [it.xy for it in sc.items if it.body == b and it.role in ("link", "disc", "circle")]
        ring = mine[0][:-1] if len(mine[0]) > 2 and mine[0][0] == mine[0][-1] else mine[0]
        edges = (ring + np.roll(ring, -1)) / 2 if len(ring) > 1 else ring
        cands = np.array(list(dict.fromkeys(np.concatenate([[np.concatenate(mine).mean()], edges, ring]))))
        anchors[b] = cands[np.linspace(0, len(cands) - 1, min(len(cands), 12)).astype(int)]
    for b in sorted(anchors, key=lambda b: len(anchors[b])):    # the least choice first
        place(b, [v.px(w) for w in world(model, q, b, anchors[b]).T], BODY_SIDES, 'font-weight="bold"')
    return out


def _time_bar(v, clock, t):
    """A bar filling over each loop, the run's first and last instants at its ends."""
    y, w = v.height + 2, v.width - 2 * PAD
    return (f'<rect x="{PAD}" y="{y}" width="{w}" height="5" fill="#eee"/>'
            f'<text x="{PAD}" y="{y + 18}" font-size="11">t = {t[0]:.3g} s</text>'
            f'<text x="{PAD + w}" y="{y + 18}" font-size="11" text-anchor="end">{t[-1]:.3g} s</text>'
            f'<rect x="{PAD}" y="{y}" width="0" height="5" fill="#444"><animate attributeName="width" '
            f'values="0;{w}" keyTimes="0;1" dur="{clock.dur:.2f}s" repeatCount="indefinite"/></rect>'
            f'<text x="{PAD + w / 2:.0f}" y="{y + 18}" font-size="11" text-anchor="middle" fill="#555">'
            f'{speed_label(clock.dur, t[-1] - t[0])}</text>')


def speed_label(dur, span) -> str:
    """How the loop's dur seconds play the run's span seconds: "slowed x1.6",
    "x2.5 faster" or "real time"."""
    ratio = dur / max(span, 1e-300)
    if abs(ratio - 1.0) < 0.005:
        return "real time"
    return f"slowed x{ratio:.2g}" if ratio > 1 else f"x{1 / ratio:.2g} faster"


def _scale_bar(v, unit):
    """A 1-2-5 length about a quarter of the width, in the top right corner."""
    bar = _nice(0.25 * (v.width - 2 * PAD) / v.s)
    x0, x1, y = v.width - PAD - bar * v.s, v.width - PAD, 16
    return (f'<polyline points="{x0:.1f},{y} {x1},{y}" stroke="#000" stroke-width="2"/>'
            f'<polyline points="{x0:.1f},{y - 4} {x0:.1f},{y + 4}" stroke="#000"/>'
            f'<polyline points="{x1},{y - 4} {x1},{y + 4}" stroke="#000"/>'
            f'<text x="{x0 - 6:.1f}" y="{y + 4}" text-anchor="end">{bar:g} {escape(unit)}</text>')


def _legend(v, sc, engines):
    """native, the ghosts and the symbols in use, wrapped to the width.
    Returns (svg, its bottom in px)."""
    line = 'stroke="#666" stroke-width="3"'
    entries = [(lambda x, y: f'<rect x="{x}" y="{y - 9}" width="14" height="9" fill="#9467bd" fill-opacity=".3" '
                             f'stroke="#9467bd" stroke-width="2"/>', "native")]
    entries += [(lambda x, y, c=ENGINE_COLORS.get(e, "#000"): f'<polyline points="{x},{y - 4} {x + 14},{y - 4}" '
                 f'stroke="{c}" stroke-width="1.5" stroke-dasharray="5 3"/>', f"{e} (ghost)") for e in engines]
    keys = [(m, text, lambda x, y, m=m: _mark(x + 5, y - 4, m)) for m, text in MARK_NAMES]
    keys += [("ground", "ground", lambda x, y: f'<polygon points="{x + 5},{y - 9} {x - 1},{y + 1} {x + 11},{y + 1}" '
                                               f'fill="#666"/>'),
             ("spoke", "rotation mark", lambda x, y: f'<polyline points="{x},{y - 4} {x + 12},{y - 4}" {line}/>'),
             ("slot", "slot", lambda x, y: f'<polyline points="{x + 2},{y - 4} {x + 10},{y - 4}" stroke="#555" '
                                           f'stroke-width="9" stroke-linecap="round"/><polyline points="{x + 2},'
                                           f'{y - 4} {x + 10},{y - 4}" stroke="#fff" stroke-width="5"/>'),
             ("rail", "guide", lambda x, y: f'<polyline points="{x},{y - 4} {x + 12},{y - 4}" {line}/>'),
             ("rack", "rack teeth", lambda x, y: f'<polyline points="{x},{y - 1} {x + 3},{y - 7} {x + 6},{y - 1} '
                                                 f'{x + 9},{y - 7} {x + 12},{y - 1}" fill="none" stroke="#666"/>')]
    used = {it.role for it in sc.items} | {it.mark for it in sc.items}
    entries += [(sym, text) for key, text, sym in keys if key in used]
    if sc.points:
        entries.append((lambda x, y: _mark(x + 3, y - 4, "dot") + f'<polyline points="{x + 7},{y - 4} '
                        f'{x + 15},{y - 4}" stroke="#555"/>', "named point and its path"))
    out, x, y = [], PAD, v.height + 42
    for sym, text in entries:
        w = 28 + 6.3 * len(text)
        if x + w > v.width - PAD + 10:
            x, y = PAD, y + 17
        out.append(sym(x, y) + f'<text x="{x + 19}" y="{y}" font-size="12">{escape(text)}</text>')
        x += w
    return "".join(out), y + 8


def _nice(x):
    """The largest of 1, 2, 5 x 10^k not above x."""
    e = 10.0 ** np.floor(np.log10(x))
    return float(max(m for m in (1, 2, 5) if m * e <= x * (1 + 1e-9)) * e)
