"""The report's drawings: the animated SVG (SMIL transforms put every named
point on its drawn path; engines as ghost layers), the scene's shapes (gears'
rotation marks, racks, slots, guides), the [report] points key, constant
columns, work-precision labels that do not overlap, and `kinem animate`."""
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from kinem.solver import solve
from kinem.case import load, loads
from kinem.cli import main
from kinem.errors import InputError
from kinem.model import compile
from kinem.report import motion, plots
from kinem.report.drawing import scene, world
from kinem.report.runs import key_columns

ROOT = Path(__file__).resolve().parents[1]


def short(name, end=None, steps=40):
    case = load(ROOT / "cases" / f"{name}.toml")
    return compile(case.with_time(end or case.end, steps))


def frames_of(model):
    r = solve(model)
    assert r.success
    return {"t": r.trajectory.t, "q": r.q}


def _screen(group, k):
    """The px transform of an animated body group at frame k: (translate, rotate in degrees)."""
    anims = group.findall("animateTransform")
    tx, ty = map(float, anims[0].get("values").split(";")[k].split())
    a = float(anims[1].get("values").split(";")[k])
    return tx, ty, np.radians(a)


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "quick_return_2"])
def test_each_named_point_rides_on_its_path(name):
    """The dot drawn in a body's group, moved by the group's SMIL translate
    and rotate, lands on the path drawn from the same coordinates: checks the
    y flip and the rotation's sign and unwrapping together."""
    model = short(name)
    native = frames_of(model)
    root = ET.fromstring(motion.svg(model, native))        # as in the page: no namespace
    paths = {p.get("data-path"): p for p in root.findall("polyline[@data-path]")}
    assert set(paths) == {p.name for p in model.case.points}
    for pt in model.case.points:
        drawn = np.array([[float(c) for c in xy.split(",")] for xy in paths[pt.name].get("points").split()])
        assert len(drawn) == len(native["t"])
        group = root.find(f"g[@data-layer='native'][@data-body='{pt.body}']")
        dot = group.find(f"circle[@data-point='{pt.name}']")
        cx, cy = float(dot.get("cx")), float(dot.get("cy"))
        for k in range(0, len(drawn), 7):
            tx, ty, a = _screen(group, k)
            x, y = tx + np.cos(a) * cx - np.sin(a) * cy, ty + np.sin(a) * cx + np.cos(a) * cy
            # every coordinate is written to 0.1 px, so the two routes differ by rounding only
            assert abs(x - drawn[k, 0]) < 0.2 and abs(y - drawn[k, 1]) < 0.2, (pt.name, k)


def test_engines_are_ghost_layers_over_native():
    model = short("slider_crank")
    native = frames_of(model)
    ghost = native["q"] + 1e-3
    text = motion.svg(model, native, {"pymunk": ghost, "mujoco": ghost})
    layers = re.findall(r'data-layer="(\w+)" data-body="(\w+)"', text)
    moving = [b for b in model.body_names if b != "ground"]
    assert [b for e, b in layers if e == "pymunk"] == moving == [b for e, b in layers if e == "mujoco"]
    assert [b for e, b in layers if e == "native"] == list(model.body_names)
    assert text.count(f'stroke="{motion.ENGINE_COLORS["pymunk"]}" stroke-width="1.5" stroke-dasharray') >= 3
    assert "pymunk (ghost)" in text and "mujoco (ghost)" in text
    assert text.count("<animateTransform") == 2 * len(layers) + len(moving) + 2   # bodies; labels of bodies, points
    # a snapshot has the same drawing without animation
    snap = motion.svg(model, native, at=3, width=300)
    assert "<animate" not in snap and 't = 0.375 s' in snap


def test_scene_draws_gears_racks_slots_and_guides():
    roles = {name: {it.role for it in scene(short(name), frames_of(short(name))["q"]).items}
             for name in ("gear_pair", "rack_pinion", "pin_in_slot", "slider_crank", "quick_return_2")}
    assert {"circle", "spoke"} <= roles["gear_pair"]
    assert {"circle", "spoke", "rack", "rail"} <= roles["rack_pinion"]
    assert "slot" in roles["pin_in_slot"] and "slot" in roles["quick_return_2"]
    assert "rail" in roles["slider_crank"]
    # the rack's teeth span the pinion's travel along it at every frame
    model = short("rack_pinion")
    q = frames_of(model)["q"]
    rack = next(it for it in scene(model, q).items if it.role == "rack")
    centre = world(model, q, "pinion", [0j])[:, 0]
    r, u = world(model, q, "rack", [0j])[:, 0], np.exp(1j * np.radians(30))
    along = ((centre - r) / u).real
    teeth = ((rack.xy - 0j) / 1.0).real        # the rack's pitch line is its xi axis
    assert teeth.min() < along.min() and teeth.max() > along.max()


def test_report_points_key_selects_what_is_drawn_and_plotted():
    text = (ROOT / "cases" / "slider_crank.toml").read_text().split("\n[report]")[0]  # its own [report] replaced
    model = compile(loads(text + '\n[report]\npoints = ["A"]\n'))
    assert key_columns(model) == ["A.x", "A.y"]
    assert [p[0] for p in scene(model, frames_of(short("slider_crank"))["q"][:3]).points] == ["A"]
    assert key_columns(compile(loads(text))) == ["B.x", "B.y", "A.x", "A.y"]
    with pytest.raises(InputError, match=r"\[report\]: key 'points': unknown point 'Z'"):
        loads(text + '\n[report]\npoints = ["Z"]\n')
    # no named point: every moving body's x, y and phi
    assert key_columns(short("gear_pair")) == [f"gear{k}.{c}" for k in (1, 2) for c in ("x", "y", "phi")]


def test_constant_columns_are_stated_not_plotted():
    model = short("slider_crank")
    r = solve(model)
    cols = {c: r.trajectory[c] for c in key_columns(model)}
    cols["wobble"] = r.trajectory["A.y"] + 1e-6 * model.length * np.sin(r.trajectory.t)  # visible motion
    img, flat = plots.trajectories(r.trajectory.t, cols, {}, "mm", model.length)
    assert list(flat) == ["A.y"] and abs(flat["A.y"]) < 1e-9 * model.length
    assert img.startswith("data:image/")
    assert plots.trajectories(r.trajectory.t, {"A.y": cols["A.y"]}, {}, "mm", model.length)[0] is None


def test_work_precision_labels_do_not_overlap():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3))
    x = np.geomspace(1e-3, 1e-2, 12)
    labels = [(f"{v:.0e}", xi, 1e-8 * (1 + 0.05 * k), "k") for k, (v, xi) in enumerate(zip(x, x))]
    labels += [(f"{v:.0e}", xi * 1.02, 1.1e-8, "r") for v, xi in zip(x, x)]   # a second curve on the first
    for _, xi, yi, _ in labels:
        ax.loglog([xi], [yi], "o")
    plots._place_labels(ax, labels)
    r = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(r) for t in ax.texts]
    assert len(boxes) >= 6
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    plt.close(fig)


def test_animate_writes_svg_gif_and_mp4_and_refuses_mp4_without_ffmpeg(tmp_path, monkeypatch, capsys):
    case = tmp_path / "four_bar.toml"
    case.write_text(re.sub(r"\[time\][^\[]*", "[time]\nend = 0.5\nsteps = 10\n\n",
                           (ROOT / "cases" / "four_bar.toml").read_text(), count=1))
    assert main(["animate", str(case), "--out", str(tmp_path / "a.svg"), "--engines", "native"]) == 0
    root = ET.parse(tmp_path / "a.svg").getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg" and len(root.findall(".//{*}animateTransform")) > 0
    assert main(["animate", str(case), "--out", str(tmp_path / "a.gif"), "--engines", "native"]) == 0
    from PIL import Image

    with Image.open(tmp_path / "a.gif") as im:
        assert im.format == "GIF" and im.n_frames == 11
    # mp4 through the ffmpeg binary of imageio-ffmpeg (a dependency): an ISO media file ('ftyp' box)
    assert main(["animate", str(case), "--out", str(tmp_path / "a.mp4"), "--engines", "native"]) == 0
    assert (tmp_path / "a.mp4").read_bytes()[4:8] == b"ftyp"
    (tmp_path / "a.mp4").unlink()
    from matplotlib import animation

    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    capsys.readouterr()
    assert main(["animate", str(case), "--out", str(tmp_path / "a.mp4")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mp4 needs ffmpeg" in err and not (tmp_path / "a.mp4").exists()
    assert main(["animate", str(case), "--out", str(tmp_path / "a.png")]) == 2


@pytest.mark.parametrize("at", [None, 0, 20, 39])
def test_labels_do_not_overlap_in_a_crowded_drawing(at):
    """quick_return_1 has six bodies and three named points in a small
    drawing; no two label boxes overlap (boxes as motion.py estimates them:
    7.5 px a character, 14 px high; checked at frame 0 of the animation)."""
    model = short("quick_return_1", steps=39)
    text = motion.svg(model, frames_of(model), at=at, width=300 if at is not None else 820)
    boxes = []
    for tx, ty, x, y, label in re.findall(r'<g transform="translate\(([-\d.]+) ([-\d.]+)\)">(?:<animateTransform'
                                          r'[^>]*>)?<text x="([-\d.]+)" y="([-\d.]+)"[^>]*>([^<]*)</text>', text):
        x0, y0 = float(tx) + float(x), float(ty) + float(y)
        boxes.append((x0, y0 - 11, x0 + 7.5 * len(label) + 2, y0 + 3))
    assert len(boxes) == 5 + 3                    # the moving bodies and the named points
    assert not any(a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
                   for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_animate_leaves_out_an_engine_that_does_not_import(tmp_path, monkeypatch, capsys):
    import adapters

    def get(name):
        raise ImportError(f"no module named {name}_sim (test)")

    monkeypatch.setattr(adapters, "get", get)
    case = tmp_path / "slider_crank.toml"
    case.write_text(re.sub(r"\[time\][^\[]*", "[time]\nend = 0.2\nsteps = 4\n\n",
                           (ROOT / "cases" / "slider_crank.toml").read_text(), count=1))
    assert main(["animate", str(case), "--out", str(tmp_path / "a.svg"), "--engines", "pymunk"]) == 0
    assert "pymunk: not drawn: failed: ImportError" in capsys.readouterr().err
    assert "ghost" not in (tmp_path / "a.svg").read_text()
