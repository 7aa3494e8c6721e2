"""Joints where they are drawn: points given in the global frame at the
drawing's pose (``[points] B = { at = [x, y], frame = "global" }``) and
bodies named by the points they carry (``[bodies] crank = { points = ["O",
"B"] }``).

A body without ``q`` takes its frame from its points: origin at its first
point, x axis towards the next one drawn elsewhere (angle 0 when there is
none). A body with ``q`` keeps it as its frame at the drawn pose. Every
drawn point a body carries gets that body's local coordinates, s' =
A(phi)^T (r^P - r) (Eq. 4.3 solved for s'), and the estimates are the drawn
pose itself, so link lengths are the distances between the points as drawn.
A drawn point's trajectory columns follow its ``body`` key, or else the first
body that lists it.
"""
import math

from dataclasses import replace

from ..spec import Point
from .checks import show


def carried(bodies, drawn) -> dict:
    """body -> the drawn points it carries: those it lists, then those whose ``body`` key names it."""
    return {b.name: [n for n in b.carries if n in drawn]
            + [n for n, (owner, _) in drawn.items() if owner == b.name and n not in b.carries]
            for b in bodies.values()}


def place(ck, bodies, points, drawn, order):
    """(bodies, points) with every body's frame and carried points' local
    coordinates derived; ``order``: the [points] table's names, the order kept."""
    bad_lists = set()   # bodies whose points list names a point that is not drawn: reported once, there
    for b in bodies.values():
        for n in b.carries:
            if n in points:
                ck.bad(f"body {show(b.name)}", "points", f"point {show(n)} is given in body '{points[n].body}''s "
                       "frame", 'points drawn in the global frame (frame = "global")')
                bad_lists.add(b.name)
            elif n not in drawn:
                ck.choice(f"body {show(b.name)}", "points", n, drawn, "point drawn in the global frame")
                bad_lists.add(b.name)
    on = carried(bodies, drawn)
    placed = {}
    for name, b in bodies.items():
        q = b.q if b.q is not None else _frame([drawn[n][1] for n in on[name]])
        if q is None and name in bad_lists:
            ck.knock_on()
            ck.rejected.add(name)
            continue
        if q is None:
            ck.bad(f"body {show(name)}", "q", "missing, and no point drawn in the global frame places it",
                   'q = [x, y, phi], or points = [...] of points with frame = "global"')
            ck.rejected.add(name)
            continue
        c, s = math.cos(q[2]), math.sin(q[2])
        local = []
        for n in on[name]:
            dx, dy = drawn[n][1][0] - q[0], drawn[n][1][1] - q[1]
            at = (c * dx + s * dy, -s * dx + c * dy)
            if b.q is None and n == on[name][0]:
                at = (0.0, 0.0)
            elif b.q is None and abs(math.atan2(dy, dx) - q[2]) == 0 and (dx or dy):
                at = (math.hypot(dx, dy), 0.0)   # the point that gave the axis: on it exactly
            local.append((n, at))
        placed[name] = replace(b, q=tuple(q), carries=tuple(local), derived=b.q is None)
    out = {}
    for n in order:
        if n in points:
            out[n] = points[n]
        elif n in drawn:
            owner = drawn[n][0] or next((b for b in placed if n in dict(placed[b].carries)), None)
            if owner is None and bad_lists:   # the list that was to carry it is wrong
                ck.knock_on()
                ck.rejected.add(n)
            elif owner is None and not any(n in on[b] for b in bodies):
                ck.bad(f"point {show(n)}", None, "carried by no body",
                       'a body key, or the point in a body\'s points = [...]')
                ck.rejected.add(n)
            elif owner in placed:
                out[n] = Point(n, owner, dict(placed[owner].carries)[n], tuple(drawn[n][1]))
    return placed, out


def _frame(at):
    """(x, y, phi) of a frame at the first point, its x axis towards the next point elsewhere."""
    if not at:
        return None
    x0, y0 = at[0]
    phi = next((math.atan2(y - y0, x - x0) for x, y in at[1:] if (x, y) != (x0, y0)), 0.0)
    return (x0, y0, phi)
