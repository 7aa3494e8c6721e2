"""Plots and animations of a solve's result, for notebooks and scripts:
``kinem.plot(result)`` (a matplotlib Figure) and ``kinem.animate(result,
path)`` (the report's animation of the result's own motion: svg, gif or mp4)."""
from pathlib import Path

import numpy as np

from .errors import InputError


def _trajectory(result):
    from .result import SolveResult, Trajectory

    if isinstance(result, SolveResult):
        return result.trajectory
    if isinstance(result, Trajectory):
        return result
    raise InputError(f"expected a SolveResult or a Trajectory; got {type(result).__name__}")


# quantity -> (what it measures, power of time): the unit of a panel
QUANTITY = {"x": ("length", 0), "y": ("length", 0), "vx": ("length", 1), "vy": ("length", 1),
            "ax": ("length", 2), "ay": ("length", 2), "phi": ("angle", 0), "theta": ("angle", 0),
            "omega": ("angle", 1), "dtheta": ("angle", 1), "alpha": ("angle", 2), "ddtheta": ("angle", 2)}
STYLES = ("-", "--", "-.", ":")


NAMES = {("length", 0): "length", ("length", 1): "velocity", ("length", 2): "acceleration",
         ("angle", 0): "angle", ("angle", 1): "angular velocity", ("angle", 2): "angular acceleration"}


def _unit(column, length_unit, angles):
    """A column's panel label, the unit in it: 'length (mm)', 'angular velocity (rad/s)'."""
    what, power = QUANTITY.get(column.rsplit(".", 1)[-1], ("value", 0))
    base = length_unit if what == "length" else angles if what == "angle" else ""
    name = NAMES.get((what, power), "value")
    return f"{name} ({base}{('', '/s', '/s^2')[power]})" if base else name


def _default_columns(traj, model):
    """The positions that move: the case's [report] points (every named point
    if it lists none; bodies' x, y when it has none), then the angles."""
    moving = [c for c in traj.columns if len(traj) and np.ptp(traj[c]) > 0]
    if model is not None and model.case.points:
        from .report.drawing import plotted_points

        named = [p.name for p in plotted_points(model)]
        lengths = [f"{n}.{q}" for n in named for q in ("x", "y") if f"{n}.{q}" in moving]
    else:
        named_points = {p.name for p in model.case.points} if model is not None else set()
        lengths = [c for c in moving if c.rsplit(".", 1)[1] in ("x", "y") and c.rsplit(".", 1)[0] not in named_points]
    angles = [c for c in moving if c.rsplit(".", 1)[1] in ("phi", "theta")]
    return lengths + angles


def plot(result, columns=None, kind="time", angles="rad", at=0):
    """A matplotlib Figure of a SolveResult (or a Trajectory).

    ``kind="time"``: columns against t, one panel per unit (lengths in the
    case's unit, angles in ``angles``, "rad" or "deg"; rates per second),
    each line its own colour and line style; by default the moving x, y of
    the case's ``[report] points`` (or of every named point) and the moving
    angles. ``kind="path"``: the x-y paths of those points (or ``columns``:
    point names) over the mechanism drawn at instant ``at`` (an index)."""
    import matplotlib.pyplot as plt

    if angles not in ("rad", "deg"):
        raise InputError(f"plot: angles {angles!r}: expected 'rad' or 'deg'")
    traj = _trajectory(result)
    model = getattr(result, "model", None)
    if kind == "path":
        return _path(result, model, columns, at)
    if kind != "time":
        raise InputError(f"plot: kind {kind!r}: expected 'time' or 'path'")
    if columns is not None:
        columns = [columns] if isinstance(columns, str) else columns
        if not isinstance(columns, (list, tuple)):
            raise InputError(f"plot: columns {columns!r:.60}: expected a list of column names")
        from .result import missing_column

        missing = [c for c in columns if c not in traj]
        if missing:
            raise InputError(f"plot: {missing_column(missing[0], traj.columns)}")
        names = list(columns)
    else:
        names = _default_columns(traj, model)
    unit = model.case.length_unit if model is not None else ""
    panels = {}
    for c in names:
        panels.setdefault(_unit(c, unit, angles), []).append(c)
    n = max(len(panels), 1)
    fig, axes = plt.subplots(n, 1, sharex=True, squeeze=False, figsize=(8, 2.8 * n))
    k = 0
    for ax, (label, cols) in zip(axes[:, 0], panels.items()):
        for c in cols:
            y = traj[c]
            if angles == "deg" and QUANTITY.get(c.rsplit(".", 1)[-1], ("",))[0] == "angle":
                y = np.degrees(y)
            ax.plot(traj.t, y, color=f"C{k % 10}", ls=STYLES[(k // 10) % len(STYLES)], label=c)
            k += 1
        ax.set_ylabel(label, parse_math=False)   # units are text, never mathtext
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best", ncol=1 + len(cols) // 8)
    axes[-1, 0].set_xlabel("t (s)")
    return fig


def _path(result, model, points, at):
    """The x-y paths of named points over the mechanism drawn at instant ``at``."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    from .report.animate import _artists
    from .report.drawing import plotted_points, poses, scene, world
    from .report.motion import BODY_COLORS
    from .result import SolveResult

    if not isinstance(result, SolveResult) or model is None:
        raise InputError("plot(kind='path'): expected a SolveResult of kinem.solve (its model draws the mechanism)")
    if not len(result.q):
        raise InputError(f"plot(kind='path'): the result has no instants ({result.message})")
    if not -len(result.q) <= at < len(result.q):
        raise InputError(f"plot(kind='path'): at = {at}: expected an instant index below {len(result.q)}")
    by_name = {p.name: p for p in model.case.points}
    if points is None:
        chosen = plotted_points(model)
    else:
        from .casefile.checks import suggest

        for n in points:
            if n not in by_name:
                guess = suggest(n, by_name)
                raise InputError(f"plot(kind='path'): no point {n!r}" + (f"; did you mean '{guess}'?" if guess else
                                 f"; named points: {', '.join(by_name) or '(none)'}"))
        chosen = [by_name[n] for n in points]
    q = result.q
    sc = scene(model, q)
    color = {b: BODY_COLORS[k % len(BODY_COLORS)] for k, b in enumerate(sc.bodies)}
    fig, ax = plt.subplots(figsize=(8, 6))
    ax.set_aspect("equal")
    r, phi = poses(model, q[at:at + 1 if at != -1 else None])
    for it in sc.items:
        j = sc.bodies.index(it.body)
        w = r[0, j] + it.xy * np.exp(1j * phi[0, j])
        for artist in _artists(ax, it, color[it.body], None, Polygon):
            if isinstance(artist, Polygon):
                artist.set_xy(np.column_stack([w.real, w.imag]))
            else:
                artist.set_data(w.real, w.imag)
    for k, p in enumerate(chosen):
        w = world(model, q, p.body, [complex(*p.at)])[:, 0]
        ax.plot(w.real, w.imag, color=f"C{k % 10}", ls=STYLES[(k // 10) % len(STYLES)], label=f"{p.name} path")
    unit = model.case.length_unit
    ax.set_xlabel(f"x ({unit})" if unit else "x", parse_math=False)
    ax.set_ylabel(f"y ({unit})" if unit else "y", parse_math=False)
    ax.set_title(f"{model.case.name}: paths, the mechanism at t = {result.trajectory.t[at]:.4g} s", parse_math=False)
    ax.grid(True, alpha=0.25)
    ax.relim()
    ax.autoscale_view()
    if chosen:
        ax.legend(fontsize=8, loc="best")
    return fig


def _model_of(result):
    """The Model a SolveResult was solved from, while it lives: the one whose
    column layout its trajectory shares (kinem.result.trajectory), or None."""
    from . import result as r

    index = result.trajectory._index
    for model, per in list(r._LAYOUTS.items()):
        if any(layout[2] is index for layout in per.values()):
            return model
    return None


def animate(result, path, model=None, frames=None, progress=None):
    """Writes the animation of a SolveResult's motion to ``path`` (.svg, .gif
    or .mp4, as ``kinem animate``; written whole or not at all) and returns
    it as a Path. ``model``: the Model it was solved from (default: the
    result's own); ``frames``: how many instants to draw (default as the
    report, 120; at most the result's); ``progress``: a bar on standard
    error while GIF or MP4 frames are drawn, True or False (default None:
    when standard error is a terminal or the caller a Jupyter kernel)."""
    from .report.animate import check_output, render
    from .report.runs import FRAMES, PATH_INSTANTS, sample
    from .result import SolveResult

    if not isinstance(result, SolveResult):
        raise InputError(f"animate: expected a SolveResult; got {type(result).__name__}")
    model = model if model is not None else result.model if result.model is not None else _model_of(result)
    if model is None:
        raise InputError("animate: cannot tell which model this result is of: pass model=")
    if not len(result.q):
        raise InputError(f"animate: the result has no instants ({result.message})")
    if result.q.shape[1] != model.n:
        raise InputError(f"animate: the result has {result.q.shape[1]} coordinates, the model {model.n}")
    if frames is not None and (isinstance(frames, bool) or not isinstance(frames, int) or frames < 2):
        raise InputError(f"animate: frames = {frames!r}: expected a whole number of at least 2")
    if progress is not None and not isinstance(progress, (bool, np.bool_)):
        raise InputError(f"animate: progress = {progress!r:.80}: expected True, False or None (when standard error "
                         "is a terminal or the caller a Jupyter kernel)")
    check_output(str(path), "animate: path")
    idx = sample(len(result.q), frames or FRAMES)
    native = {"t": result.trajectory.t[idx], "q": result.q[idx]}
    import sys

    if progress is None:
        progress = sys.stderr.isatty() or "ipykernel" in sys.modules
    bar = frame_bar(len(idx)) if progress else None
    try:
        render(model, native, {}, result.q[sample(len(result.q), PATH_INSTANTS)], str(path),
               on_frame=(lambda k: bar(k, len(idx))) if bar else None)
    finally:
        if bar:
            bar.close()
    return Path(path)


def frame_bar(total):
    """on_frame(k, total) drawing a progress bar on standard error, some 50 redraws; ``.close()``."""
    import sys

    from .report.progress import Progress

    bar = Progress(total, stream=sys.stderr, enabled=True)

    def on_frame(k, count):
        bar.total, bar.done = count, k + 1
        if (k + 1) % max(1, count // 50) == 0 or k + 1 == count:
            bar.show(f"frame {k + 1} of {count} drawn")
    on_frame.close = bar.close
    return on_frame


def trajectory_html(traj) -> str:
    """A Trajectory in Jupyter: its summary line and its first and last instants (up to 8 columns)."""
    from html import escape

    cols = traj.columns[:8]
    rows = sorted(set(range(min(3, len(traj)))) | set(range(max(len(traj) - 2, 0), len(traj))))
    head = "".join(f"<th>{escape(c)}</th>" for c in ("t",) + cols) + ("<th>...</th>" if len(traj.columns) > 8 else "")
    body = "".join("<tr>" + "".join(f"<td>{v:.6g}</td>" for v in [traj.t[k], *(traj[c][k] for c in cols)])
                   + "</tr>" for k in rows)
    return f"<div><p>{escape(repr(traj))}</p><table><tr>{head}</tr>{body}</table></div>"


def result_html(result) -> str:
    """A SolveResult in Jupyter: the summary line and the mechanism's motion
    (the report's animated SVG of its own instants), when it has instants."""
    from html import escape

    line = (f"<p><b>{escape(result.model.case.name if result.model is not None else 'result')}</b>: "
            f"{escape(str(result.status))}, {escape(result.message)}; {len(result.trajectory)} instants, "
            f"{len(result.trajectory.columns)} columns, {result.wall_time:.3g} s</p>")
    if result.model is None or not len(result.q):
        return line
    from .report.motion import svg
    from .report.runs import FRAMES, PATH_INSTANTS, sample

    idx = sample(len(result.q), FRAMES)
    try:
        drawing = svg(result.model, {"t": result.trajectory.t[idx], "q": result.q[idx]},
                      paths_q=result.q[sample(len(result.q), PATH_INSTANTS)])
    except Exception as e:  # noqa: BLE001 - a display never raises: the summary stands alone
        drawing = f"<p>(not drawn: {escape(type(e).__name__)}: {escape(str(e))})</p>"
    return f"<div>{line}{drawing}</div>"


def _register():
    from . import result

    result.HTML.update(trajectory=trajectory_html, result=result_html)


_register()
