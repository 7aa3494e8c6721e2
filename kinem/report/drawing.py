"""The mechanism as a drawing: a scene of items fixed in bodies, built once
from the compiled model, then drawn at any pose (motion.py draws it as SVG
or with matplotlib).

Each moving body is the polygon of its points (sorted by angle about their
mean; a bar for two, a disc for one); constraints add their shapes: pitch
circles, rollers and cams with a rotation mark (a spoke along the body's xi
axis; a cam's from its outline's centre to the outline's first point), cam
outlines, flat followers' faces, curved slots (point-follower), straight slots
(revolute-translational), guide rails (translational) and racks (toothed
pitch lines). Straight slots, rails and racks span the travel seen in the
frames they are built from. Joints are marked (o revolute, square
translational, diamond pin in slot), ground points are triangles, and named
points dots with the paths they trace.

Planar vectors are complex x + iy, as in the constraint families.
"""
from dataclasses import dataclass

import numpy as np

MARKS = {"revolute": "o", "translational": "s", "revolute-translational": "D", "point-follower": "D",
         "revolute-revolute": "x", "distance-driver": "x"}   # joints marked at their first local point
MARK_NAMES = (("o", "revolute"), ("s", "translational"), ("D", "pin in slot"), ("x", "distance"))  # legends


@dataclass(frozen=True, eq=False)
class Item:
    body: str
    role: str          # link | disc | circle | spoke | cam | face | slot | rail | rack | joint | ground
    xy: np.ndarray     # local points (complex)
    mark: str = ""     # joint: a MARKS value


@dataclass(frozen=True, eq=False)
class Scene:
    bodies: tuple      # body names, in the model's order
    fixed: frozenset   # grounded bodies
    items: tuple       # Item
    points: tuple      # (name, body, local point) of the named points drawn
    unit: str
    length: float      # the model's characteristic length


def poses(model, q):
    """(frames, bodies) complex origins and angles from (frames, n) coordinates."""
    q = np.atleast_2d(np.asarray(q, float))[:, :3 * len(model.body_names)].reshape(len(q), -1, 3)
    return q[..., 0] + 1j * q[..., 1], q[..., 2]


def world(model, q, body, local):
    """Local points of ``body`` in the plane at every frame: (frames, points)."""
    r, phi = poses(model, q)
    k = model.body_names.index(body)
    return r[:, k, None] + np.asarray(local, complex)[None, :] * np.exp(1j * phi[:, k, None])


def plotted_points(model):
    """The named points the report draws and plots: the case's ``[report]
    points`` list when it has one, else every named point."""
    listed = model.case.report.get("points")
    names = list(listed) if listed else [p.name for p in model.case.points]
    by_name = {p.name: p for p in model.case.points}
    return [by_name[n] for n in names if n in by_name]


def scene(model, q) -> Scene:
    """The scene of ``model``; q: native coordinates (frames, n) over the run,
    which size the straight slots, rails and racks."""
    from adapters.base import body_points, grounded
    from kinem.casefile.keys import LocalKey
    from kinem.constraints import REGISTRY

    q = np.atleast_2d(np.asarray(q, float))
    fixed, pts, items = grounded(model), body_points(model), []
    for b in model.body_names:
        local = np.unique(np.round(np.array(pts[b] or [(0.0, 0.0)], float), 12), axis=0)
        z = local[:, 0] + 1j * local[:, 1]
        if b in fixed:
            items += [Item(b, "ground", np.array([p])) for p in z]
        elif len(z) == 1:
            items.append(Item(b, "disc", z))
        else:
            items.append(Item(b, "link", z[np.argsort(np.angle(z - z.mean()))] if len(z) > 2 else z))
    for c in model.case.constraints:
        items += _shapes(model, c, q)
        key = next((k for k in REGISTRY[c.type].keys if isinstance(k, LocalKey) and c.get(k.name) is not None), None)
        if key is not None and c.type in MARKS:
            items.append(Item(c[key.of], "joint", np.array([complex(*c[key.name])]), MARKS[c.type]))
    named = tuple((p.name, p.body, complex(*p.at)) for p in plotted_points(model))
    return Scene(tuple(model.body_names), frozenset(fixed), tuple(items), named, model.case.length_unit,
                 model.length)


def _shapes(model, c, q):
    ring = np.exp(1j * np.linspace(0, 2 * np.pi, 73))
    t = c.type
    if t == "gear":
        return _wheel(c["i"], 0j, c["ri"], ring) + _wheel(c["j"], 0j, c["rj"], ring)
    if t == "rack-pinion":
        centre = complex(*c["center"]) if c.get("center") is not None else 0j
        return _wheel(c["pinion"], centre, c["radius"], ring) + [_rack(model, c, centre, q)]
    if t in ("cam-point", "cam-roller", "cam-flat"):
        o = c["outline"]
        rim = _outline(o)
        out = [Item(c["cam"], "cam", rim), Item(c["cam"], "spoke", np.array([complex(*o.center), rim[0]]))]
        sj = complex(*c["sj"])
        if t == "cam-roller":
            out += _wheel(c["follower"], sj, c["radius"], ring)
        if t == "cam-flat":  # the follower's face: through sj, normal to its normal, as wide as the cam
            n = complex(*c["normal"]) if c.get("normal") is not None else 1j
            half = 1j * n / abs(n) * np.max(np.abs(rim - complex(*o.center)))
            out.append(Item(c["follower"], "face", np.array([sj - half, sj + half])))
        return out
    if t == "point-follower":
        return [Item(c["j"], "slot", _outline(c["outline"]))]
    if t == "revolute-translational":
        s, d = complex(*c["sj"]), complex(*c["qj"]) - complex(*c["sj"])
        return [Item(c["j"], "slot", _travel(model, q, c["i"], complex(*c["si"]), c["j"], s, d, 0.06))]
    if t == "translational":
        s = complex(*c["sj"]) if not isinstance(c["sj"], str) else _named(model, c["sj"])
        si = complex(*c["si"])
        k_i, k_j = model.body_names.index(c["i"]), model.body_names.index(c["j"])
        turn = np.exp(1j * (q[0, 3 * k_i + 2] - q[0, 3 * k_j + 2]))
        d = (complex(*c["qi"]) - si) * turn            # the sliding direction in j's frame
        return [Item(c["j"], "rail", _travel(model, q, c["i"], si, c["j"], s, d, 0.1))]
    return []


def _named(model, name):
    return next(complex(*p.at) for p in model.case.points if p.name == name)


def _outline(o):
    a, b = o.span
    return np.asarray(o.point_at(np.linspace(a, b, 121))[0])


def _wheel(body, centre, radius, ring):
    return [Item(body, "circle", centre + radius * ring), Item(body, "spoke", np.array([centre, centre + radius]))]


def _travel(model, q, mover, local, body, s, d, margin):
    """The segment of the line s + u d (in ``body``) that ``local`` of
    ``mover`` sweeps over the frames, lengthened by margin L at each end."""
    d = d / abs(d) if abs(d) > 0 else 1.0
    p = world(model, q, mover, [local])[:, 0]
    r, phi = poses(model, q)
    k = model.body_names.index(body)
    u = ((p - r[:, k]) * np.exp(-1j * phi[:, k]) - s) / d     # mover's point in body's frame, along d
    lo, hi = u.real.min() - margin * model.length, u.real.max() + margin * model.length
    return np.array([s + lo * d, s + hi * d])


def _rack(model, c, centre, q):
    """The rack's pitch line (through sj along u) as a zigzag of teeth
    (pitch 2 pi r / 20) over the pinion centre's travel plus a radius."""
    u = complex(*c["u"]) if c.get("u") is not None else 1 + 0j
    u /= abs(u)
    s, r = complex(*c["sj"]), float(c["radius"])
    seg = _travel(model, q, c["pinion"], centre, c["rack"], s, u, 0.0)
    a, b = ((seg - s) / u).real
    pitch = 2 * np.pi * r / 20
    n = max(2, int(np.ceil((b - a + 2 * r) / pitch)))
    along = a - r + pitch * np.arange(2 * n + 1) / 2
    side = np.where(np.arange(len(along)) % 2, 0.25, -0.25) * pitch * 1j
    return Item(c["rack"], "rack", s + (along + side) * u)
