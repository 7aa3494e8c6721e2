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


def plot(result, columns=None):
    """A matplotlib Figure of a SolveResult's (or a Trajectory's) columns
    against t: by default the positions that move (x and y in one axes,
    angles in another); ``columns``: names to draw instead, in one axes."""
    import matplotlib.pyplot as plt

    traj = _trajectory(result)
    if columns is not None:
        columns = [columns] if isinstance(columns, str) else columns
        if not isinstance(columns, (list, tuple)):
            raise InputError(f"plot: columns {columns!r:.60}: expected a list of column names")
        missing = [c for c in columns if c not in traj]
        if missing:
            raise InputError(f"plot: no column {missing[0]!r}; columns: {', '.join(traj.columns[:12])}...")
        groups = [("", list(columns))]
    else:
        moving = [c for c in traj.columns if np.ptp(traj[c]) > 0] if len(traj) else []
        groups = [(label, [c for c in moving if c.rsplit(".", 1)[1] in quantities])
                  for label, quantities in (("position", ("x", "y", "theta")), ("angle (rad)", ("phi",)))]
        groups = [g for g in groups if g[1]]
    fig, axes = plt.subplots(max(len(groups), 1), 1, sharex=True, squeeze=False, figsize=(8, 3 * max(len(groups), 1)))
    for ax, (label, names) in zip(axes[:, 0], groups):
        for c in names:
            ax.plot(traj.t, traj[c], label=c)
        ax.set_ylabel(label, parse_math=False)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axes[-1, 0].set_xlabel("t (s)")
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


def animate(result, path, model=None):
    """Writes the animation of a SolveResult's motion to ``path`` (.svg, .gif
    or .mp4, as ``kinem animate``; written whole or not at all) and returns
    it as a Path. ``model``: the Model it was solved from (the drawing's
    bodies, joints and points); found by itself for a result of kinem.solve."""
    from .report.animate import check_output, render
    from .report.runs import FRAMES, PATH_INSTANTS, sample
    from .result import SolveResult

    if not isinstance(result, SolveResult):
        raise InputError(f"animate: expected a SolveResult; got {type(result).__name__}")
    model = model if model is not None else _model_of(result)
    if model is None:
        raise InputError("animate: cannot tell which model this result is of: pass model=")
    if not len(result.q):
        raise InputError(f"animate: the result has no instants ({result.message})")
    if result.q.shape[1] != model.n:
        raise InputError(f"animate: the result has {result.q.shape[1]} coordinates, the model {model.n}")
    check_output(str(path), "animate: path")
    idx = sample(len(result.q), FRAMES)
    native = {"t": result.trajectory.t[idx], "q": result.q[idx]}
    render(model, native, {}, result.q[sample(len(result.q), PATH_INSTANTS)], str(path))
    return Path(path)
