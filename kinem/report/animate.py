"""``kinem animate CASE --out FILE``: the report's animation of one case.

The case runs on the native solver and on each engine asked for (the
report's main runs: adapter defaults, then the case's [engines.<name>]
table); the frames are sampled as the report samples them (runs.FRAMES).
FILE.svg is the report's animated SVG, standalone; FILE.gif and FILE.mp4
draw the same scene frame by frame with matplotlib (mp4 through the ffmpeg
binary that the imageio-ffmpeg package ships, so nothing else needs installing).
"""
import logging
import os
import subprocess
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import AnalysisError, InputError, KinemError, OutputError
from .drawing import MARK_NAMES, poses, scene, world
from .motion import BODY_COLORS, ENGINE_COLORS, duration, svg
from .runs import FRAMES, PATH_INSTANTS, sample

FORMATS = (".svg", ".gif", ".mp4")


def check_output(out, what="--out"):
    """Input errors about the output path, before anything runs, naming it
    as ``what`` (the command line's --out; the API's parameter)."""
    if not str(out):   # an unset shell variable: named as such, as every other --out ''
        raise InputError(f"{what} '': an empty path (an unset shell variable?); expected a file ending in "
                         f"{', '.join(FORMATS)}")
    ext = Path(out).suffix.lower()
    if ext not in FORMATS:
        raise InputError(f"{what} {out}: expected a file ending in {', '.join(FORMATS)}")
    if ext == ".mp4" and not ffmpeg():
        raise InputError(f"{what} {out}: mp4 needs ffmpeg, which is not installed; write .svg or .gif instead")
    if str(out).endswith(os.sep) or os.path.isdir(out):   # refused before the runs, not after them (kinem.output)
        raise InputError(f"{what} {out}: cannot write: a directory; expected a file name")
    parent = Path(out).parent
    if not parent.is_dir():
        raise InputError(f"{what} {out}: directory {parent} does not exist")
    return ext


def ffmpeg() -> bool:
    """Points matplotlib at the ffmpeg binary of imageio-ffmpeg (a dependency);
    whether an ffmpeg is available."""
    from matplotlib import animation, rcParams

    try:
        import imageio_ffmpeg

        rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):   # not installed, or no binary for this platform
        pass
    return animation.writers.is_available("ffmpeg")


def frames(model, engines, options=None):
    """(native frames {t, q}, engine -> q at the same instants, denser native q
    for the paths, engine -> why it is not drawn). ``options`` (kinem.Options;
    default the case's): native's solve, e.g. its max_seconds, which ends the
    engines' runs too (an AnalysisError past it)."""
    from adapters import case_settings, get
    from adapters.base import Status
    from adapters.compare import engines_deadline
    from kinem.budget import check_solutions
    from kinem.solver import solve

    check_solutions(model, 1 + len(engines), "animate", "fewer instants ([time] steps) or engines")
    r = solve(model, options=options)
    if not r.success:
        raise AnalysisError(f"{model.case.source}: {r.message}")
    limit = engines_deadline(options)   # the engines' runs end at options.max_seconds too, as compare's
    idx = sample(len(r.q), FRAMES)
    native = {"t": r.trajectory.t[idx], "q": r.q[idx]}
    ghosts, skipped = {}, {}
    for name in engines:
        try:
            adapter = get(name)
            why = adapter.unsupported(model)
            if why:
                skipped[name] = why
                continue
            run = adapter.run(model, r.q[0], r.qd[0], case_settings(model, name), limit=limit)
        except KinemError:
            raise                # a bad [engines.<name>] setting: the user's input
        except Exception as e:  # noqa: BLE001 - an engine that does not import or crashes is left out, named
            skipped[name] = f"failed: {type(e).__name__}: {e}"
            continue
        if run.status is Status.OUT_OF_TIME:   # the time limit, not a ghost left out
            raise AnalysisError(f"{model.case.source}: {name}: {run.detail}")
        if run.ok and len(run.q) == len(r.q):
            ghosts[name] = run.q[idx]
        else:
            skipped[name] = run.label   # "failed: why", as an engine that crashes
    return native, ghosts, r.q[sample(len(r.q), PATH_INSTANTS)], skipped


def write(model, out, engines, on_frame=None, options=None) -> dict:
    """Writes the animation to ``out``; returns engine -> why it is not drawn.
    ``on_frame(k, frames)`` after each GIF or MP4 frame drawn; ``options``:
    native's solve (`frames`)."""
    ext = check_output(out)
    native, ghosts, dense, skipped = frames(model, engines, options)
    count = len(native["t"])
    render(model, native, ghosts, dense, out, ext, (lambda k: on_frame(k, count)) if on_frame else None)
    return skipped


def render(model, native, ghosts, dense, out, ext=None, on_frame=None):
    """Draws the frames (native {t, q}, engine -> q) and the paths (dense q)
    to ``out`` in its format; ``on_frame(k)`` after each raster frame."""
    ext = ext or Path(out).suffix.lower()
    if ext == ".svg":
        data = ('<?xml version="1.0" encoding="utf-8"?>\n'
                + svg(model, native, ghosts, standalone=True, paths_q=dense) + "\n").encode()
    else:
        try:
            data = raster(model, native, ghosts, dense, ext, on_frame)
        except _ScratchError as e:   # the scratch file it is drawn into (a full temporary folder), or ffmpeg
            raise OutputError(f"{out}: write failed: {e}") from None
    save(out, data)


def save(path, data: bytes):
    """Atomically onto a regular file; a device, FIFO or symlink is written
    through, never replaced (kinem.output.Output)."""
    from ..output import write_atomic

    write_atomic(path, lambda f: f.write(data))


def raster(model, native, ghosts, dense, ext, on_frame=None) -> bytes:
    """GIF or MP4 bytes: the scene drawn by matplotlib at every frame, at the
    SVG's pace (motion.duration). The static parts (axes, grid, paths,
    legend) are rendered once; each frame draws only the moving artists over
    that background (blitting) and a GIF's frames share one palette."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon

    t, q = np.asarray(native["t"]), np.asarray(native["q"])
    sc = scene(model, dense)
    color = {b: BODY_COLORS[k % len(BODY_COLORS)] for k, b in enumerate(sc.bodies)}
    fig, ax = plt.subplots(figsize=(8, 6), dpi=90)
    ax.set_aspect("equal")
    unit = model.case.length_unit
    ax.set_xlabel(f"x ({unit})" if unit else "x", parse_math=False)   # units are text, never mathtext
    ax.set_ylabel(f"y ({unit})" if unit else "y", parse_math=False)
    ax.grid(True, alpha=0.25)
    for name, body, p in sc.points:
        w = world(model, dense, body, [p])[:, 0]
        ax.plot(w.real, w.imag, "-", color=color[body], lw=1, alpha=0.8)
    movers = []   # (artist, body, local points, layer's poses)
    layers = [(None, poses(model, q))] + [(ENGINE_COLORS.get(e, "k"), poses(model, g)) for e, g in ghosts.items()]
    for ghost, pose in layers:
        for it in sc.items:
            if ghost and (it.body in sc.fixed or it.role in ("joint", "ground")):
                continue
            movers += [(a, it.body, it.xy, pose) for a in _artists(ax, it, color[it.body], ghost, Polygon)]
        if ghost is None:
            for _, body, p in sc.points:
                movers.append((ax.plot([], [], "o", color="#111", ms=4, zorder=6)[0], body, np.array([p]), pose))
    labels = [(ax.text(0, 0, b, fontweight="bold", zorder=7), b, np.concatenate(
        [it.xy for it in sc.items if it.body == b and it.role in ("link", "disc", "circle")]).mean())
        for b in sc.bodies if b not in sc.fixed]
    labels += [(ax.text(0, 0, n, style="italic", zorder=7), b, p) for n, b, p in sc.points]
    clock = ax.set_title("")
    every = np.concatenate([world(model, q, it.body, it.xy).ravel() for it in sc.items])
    pad = 0.05 * max(np.ptp(every.real), np.ptp(every.imag), 1e-12)
    ax.set_xlim(every.real.min() - pad, every.real.max() + pad)
    ax.set_ylim(every.imag.min() - pad, every.imag.max() + pad)
    handles = [Patch(facecolor="#9467bd", alpha=0.4, label="native")]
    handles += [Line2D([], [], color=ENGINE_COLORS.get(e, "k"), ls="--", label=f"{e} (ghost)") for e in ghosts]
    marks = {it.mark for it in sc.items if it.role == "joint"}
    handles += [Line2D([], [], ls="", marker=m, mfc="white", mec="k", label=text)
                for m, text in MARK_NAMES if m in marks]
    ax.legend(handles=handles, loc="upper left", fontsize=8, framealpha=0.8)
    nudge = 0.012 * (ax.get_xlim()[1] - ax.get_xlim()[0])

    def draw(k):
        for artist, body, local, (r, phi) in movers:
            j = sc.bodies.index(body)
            w = r[k, j] + local * np.exp(1j * phi[k, j])
            if isinstance(artist, Polygon):
                artist.set_xy(np.column_stack([w.real, w.imag]))
            else:
                artist.set_data(w.real, w.imag)
        r, phi = poses(model, q[k:k + 1])
        for text, body, p in labels:
            j = sc.bodies.index(body)
            w = r[0, j] + p * np.exp(1j * phi[0, j])
            text.set_position((w.real + nudge, w.imag + nudge))
        clock.set_text(f"{model.case.name}: t = {t[k]:.3f} s")
        return []

    fps = len(t) / duration(t)
    moving = [m[0] for m in movers] + [lab[0] for lab in labels] + [clock]
    for a in moving:
        a.set_animated(True)   # left out of the background
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in range(len(t)):
        draw(k)
        fig.canvas.restore_region(background)
        for a in moving:
            fig.draw_artist(a)
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        if on_frame:
            on_frame(k)
    plt.close(fig)
    with _scratch(ext) as (path, folder):
        try:
            if ext == ".gif":
                _save_gif(path, images, fps)
            else:   # the format named: the scratch path may have no suffix
                writer = animation.FFMpegWriter(fps=fps, extra_args=["-f", "mp4"])
                _save_frames(writer, images, fig.dpi, path)
            return Path(path).read_bytes()
        except OSError as e:
            raise _ScratchError(f"{e.strerror or type(e).__name__} (its temporary file, in {folder})") from None


class _ScratchError(Exception):
    """The raster's scratch file could not be written, or ffmpeg failed (render names the output)."""


def _save_gif(path, images, fps):
    """One adaptive palette from the first frame (the scene's colours are all
    in it), every frame mapped to it without dithering."""
    from PIL import Image

    first = Image.fromarray(images[0]).quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    frames = [first] + [Image.fromarray(im).quantize(palette=first, dither=Image.Dither.NONE) for im in images[1:]]
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:], duration=int(1000 / fps), loop=0)


def _save_frames(writer, images, dpi, path):
    """Rendered frames (RGB arrays) through a matplotlib movie writer."""
    import matplotlib.pyplot as plt

    h, w = images[0].shape[:2]
    fig = plt.figure(figsize=(w / dpi, h / dpi), dpi=dpi)
    fig.figimage(images[0])
    log = logging.getLogger("matplotlib.animation")   # its warning of ffmpeg's standard error: in the error instead
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with writer.saving(fig, path, dpi):
            for im in images:
                fig.images[0].set_data(im)
                writer.grab_frame()
    except subprocess.CalledProcessError as e:
        stop = _stop_in(e)
        if stop is not None:   # Ctrl-C (SIGTERM) to the process group stopped ffmpeg too: the writer's
            raise stop from None   # finish found it stopped, and its error hid the interrupt
        lines = (e.stderr or "").strip().splitlines()
        why = lines[-1].strip() if lines else (f"died with signal {-e.returncode}" if e.returncode < 0
                                               else f"exit status {e.returncode}")
        raise _ScratchError(f"ffmpeg: {why}") from None   # ffmpeg's own: not the temporary file's
    finally:
        log.setLevel(level)
        plt.close(fig)


def _stop_in(error):
    """The KeyboardInterrupt or SystemExit (a signal's exit) that ``error``
    was raised while handling, if any."""
    e = error.__context__
    while e is not None:
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            return e
        e = e.__context__
    return None


@contextmanager
def _scratch(ext):
    """A path to render into that SIGKILL leaves nothing behind for, and its
    folder (for messages): an unnamed file (Linux O_TMPFILE in the temporary
    directory) reached through /proc/PID/fd/N, which the ffmpeg child process
    can open too; elsewhere a temporary directory, removed on any error
    Python sees."""
    fd, folder = None, None
    if hasattr(os, "O_TMPFILE"):
        # the temporary directory as tempfile.gettempdir chooses it, without its probe (a named file
        # made and removed: SIGKILL between the two would leave it); the unnamed file is the probe
        for folder in _temporary_folders():
            try:
                fd = os.open(folder, os.O_TMPFILE | os.O_RDWR | os.O_CLOEXEC, 0o600)
                break
            except OSError:
                fd = None
    path = f"/proc/{os.getpid()}/fd/{fd}" if fd is not None else None
    if path is not None and os.path.exists(path):
        try:
            yield path, folder
        finally:
            os.close(fd)
        return
    if fd is not None:
        os.close(fd)
    with tempfile.TemporaryDirectory() as tmp:
        yield os.path.join(tmp, "out" + ext), tmp


def _temporary_folders():
    """tempfile.gettempdir's candidates in its order: tempfile.tempdir when
    set, TMPDIR, TEMP, TMP, then the platform's folders."""
    if tempfile.tempdir is not None:
        yield tempfile.tempdir
    for name in ("TMPDIR", "TEMP", "TMP"):
        if os.environ.get(name):
            yield os.environ[name]
    yield from ("/tmp", "/var/tmp", "/usr/tmp")


def _artists(ax, it, color, ghost, Polygon):
    """The matplotlib artists of one scene item (data set per frame)."""
    r = it.role
    if ghost:
        if r == "disc":
            return ax.plot([], [], "o", mfc="none", mec=ghost, ms=8, zorder=5)
        closed = r in ("link", "circle", "cam") and len(it.xy) > 2
        return ax.plot([], [], "--", color=ghost, lw=1.2, zorder=5) if not closed else \
            [ax.add_patch(Polygon(np.zeros((1, 2)), closed=True, fill=False, ec=ghost, ls="--", lw=1.2, zorder=5))]
    from matplotlib.colors import to_rgba

    if r == "link" and len(it.xy) > 2:
        return [ax.add_patch(Polygon(np.zeros((1, 2)), closed=True, fc=to_rgba(color, 0.35), ec=color, lw=2))]
    if r in ("circle", "cam"):
        return [ax.add_patch(Polygon(np.zeros((1, 2)), closed=True, fc=to_rgba(color, 0.12), ec=color, lw=1.2))]
    styles = {"link": dict(color=color, lw=5, alpha=0.75, solid_capstyle="round"),
              "disc": dict(marker="o", color=color, ms=8, ls=""),
              "spoke": dict(color=color, lw=2), "face": dict(color=color, lw=3.5),
              "rack": dict(color=color, lw=1.2),
              "rail": dict(color="#666", lw=2.5),
              "ground": dict(marker="^", color="#666", ms=9, ls=""),
              "joint": dict(marker=it.mark, mfc="white", mec="k", color="k", ms=6, ls="", zorder=6)}
    if r == "slot":
        return ax.plot([], [], color="#555", lw=9, solid_capstyle="round") + \
            ax.plot([], [], color="white", lw=5, solid_capstyle="round")
    return ax.plot([], [], **styles.get(r, dict(color=color)))

