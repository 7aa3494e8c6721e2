"""Which branch an assembly reached, where the estimates decide it, and the
pins a case may put on it (docs/case-format.md, "Pinning the branch").

- A revolute joint's relative angle phi_j - phi_i, wrapped to (-pi, pi]:
  its sign is the loop's closure orientation (elbow up or down); the key
  ``sign = "positive" | "negative"`` pins it.
- A cam roller's side (Eq. 4.28): the roller's centre Q_j is outside the
  cam's outline when it is farther from the outline's centre Q than the
  outline's radius s(theta) at the contact, inside when nearer; the key
  ``side = "outside" | "inside"`` pins it.

The solver checks the pins on the configuration it assembled from the
estimates (``violation``; kinem.solver), so ``kinem solve`` and ``kinem
info`` honour them alike; ``kinem info`` shows the branch (``sides``, and
kinem.info's relative angles).
"""
from dataclasses import dataclass
import weakref

import numpy as np

_PINS = weakref.WeakKeyDictionary()  # model -> its pins, found once


@dataclass(frozen=True)
class Side:
    """A cam roller's side at an assembly."""
    constraint: str
    side: str             # "outside" or "inside"
    distance: float       # |Q_j - Q|: the roller's centre from the outline's centre
    radius: float         # s(theta) at the contact


def relative_angle(model, q, c) -> float:
    """phi_j - phi_i of a revolute joint, wrapped to (-pi, pi]."""
    k = {b: 3 * n + 2 for n, b in enumerate(model.body_names)}
    d = float(q[k[c["j"]]] - q[k[c["i"]]])
    return float(np.pi - (np.pi - d) % (2 * np.pi))


def cam_side(model, q, c) -> Side:
    """The side of cam-roller constraint c's roller at coordinates q."""
    from .outline import OutlineSet

    names = model.body_names
    nb = len(names)
    theta = float(q[3 * nb + model.artificial.index(f"{c.name}.theta")])

    def world(body, local):
        x, y, phi = q[3 * names.index(body): 3 * names.index(body) + 3]
        return complex(x, y) + np.exp(1j * phi) * complex(*local)

    centre = world(c["cam"], c["outline"].center)
    roller = world(c["follower"], c["sj"])
    radius = float(OutlineSet([c["outline"]]).radius(np.array([theta]))[0][0])
    distance = abs(roller - centre)
    return Side(c.name, "outside" if distance > radius else "inside", distance, radius)


def sides(model, q) -> tuple:
    """Every cam roller's Side at q."""
    return tuple(cam_side(model, q, c) for c in model.case.constraints if c.type == "cam-roller")


def pins(model) -> tuple:
    """(constraint, the branch it pins) of every pinned constraint, looked
    for once per model (a solve asks at every call)."""
    found = _PINS.get(model)
    if found is None:
        found = _PINS[model] = tuple(
            (c, want) for c in model.case.constraints
            if (want := c.get("sign") if c.type == "revolute" else c.get("side") if c.type == "cam-roller" else None)
            is not None)
    return found


def violation(model, q):
    """The first pin (``sign`` of a revolute, ``side`` of a cam roller) that
    the assembled q does not meet: (constraint name, one-line message naming
    the constraint, the key, what was expected and what was found), or None."""
    for c, want in pins(model):
        if c.type == "revolute":
            a = relative_angle(model, q, c)
            found = "positive" if a > 0 else "negative" if a < 0 else "zero"
            if found != want:
                return c.name, (f"{c.where}: key 'sign': the assembly reached phi_j - phi_i = {a:+.6g} rad "
                                f"({found}); expected {want} (the estimates chose the other branch: "
                                "change the bodies' q or the pin)")
        else:
            s = cam_side(model, q, c)
            if s.side != want:
                return c.name, (f"{c.where}: key 'side': the assembly reached the roller {s.side} the outline "
                                f"(its centre {s.distance:.6g} from the outline's centre, outline radius "
                                f"{s.radius:.6g} at the contact); expected {want} (the estimates chose the other "
                                "branch: change theta, the bodies' q or the pin)")
    return None
