"""The kinds of key a case-file constraint type declares, one class each.

A key parses and checks its value (``parse``), says in words what it
accepts (``accepts``: docs/case-format.md's tables are generated from it) and
answers what other modules ask of it: whether it names a body, the length it
contributes to the mechanism's size. A new kind is a new class here; no
module switches on a kind's name.
"""
import math
from dataclasses import dataclass

import numpy as np

from .. import functions as fn
from .checks import show
from .curves import function, outline

COORDS = ("x", "y", "phi")
DEGREE = math.pi / 180


@dataclass(frozen=True)
class Scope:
    """What a key's value may refer to: the case's bodies and points, its end
    time, and the constraint table the key is in."""
    bodies: dict
    points: dict
    end: float
    table: dict


@dataclass(frozen=True)
class Key:
    """One key of a constraint type: its name, whether it is required, and a
    line of documentation."""
    name: str
    required: bool = True
    doc: str = ""
    angle: bool = False      # an angle: given in degrees where the case has units = { angle = "deg" }
    accepts = ""  # what a value looks like, in the docs' words

    def parse(self, ck, where, v, scope: Scope):
        raise NotImplementedError

    def radians(self, v, table):
        """The parsed value with its angles given in degrees converted to radians."""
        return v * DEGREE if self.angle else v

    def size(self, v) -> float | None:
        """The length this value contributes to the mechanism's size (kinem.model), if any."""
        return None

    def numbers(self, v) -> tuple:
        """The design parameters in value v: (sub-path, number, quantity) each,
        sub-path "" for a scalar key, "0", "1" for a vector's entries, "poly.1"
        inside a table; quantity what it measures, which kinem.parameters
        turns into a unit: "length", "angle", "direction" (a component of a
        direction, normalised), "coordinate" (a length or an angle after the
        constraint's coord), "frequency" (rad/s), "rateK" (a driving
        function's quantity per s^K). None here: the key holds no number
        that shapes the mechanism."""
        return ()


@dataclass(frozen=True)
class BodyKey(Key):
    accepts = "the name of a body"

    def parse(self, ck, where, v, scope):
        return ck.choice(where, self.name, v, scope.bodies, "body")


@dataclass(frozen=True)
class LocalKey(Key):
    """A point of the body named by key ``of``."""
    of: str = ""
    accepts = "[xi, eta] or a point's name"

    def parse(self, ck, where, v, scope):
        body = scope.table.get(self.of)
        if isinstance(v, str):
            known = isinstance(body, str) and body in scope.bodies   # (a bad body: key `of`'s problem, reported)
            carries = dict(scope.bodies[body].carries) if known else {}
            if v in carries:   # a point drawn in the global frame that the body carries (kinem.casefile.drawn)
                return carries[v]
            if ck.choice(where, self.name, v, scope.points, "point") is None:
                return None
            if not known:
                ck.knock_on()
                return None
            if scope.points[v].body != body:
                ck.bad(where, self.name, f"point '{v}' is on body '{scope.points[v].body}', not on '{body}'",
                       f"a point on body '{body}' or [xi, eta]")
                return None
            return scope.points[v].at
        return ck.vector(where, self.name, v, 2, "[xi, eta] or a point name")

    def size(self, v):
        return float(np.hypot(*v))

    def numbers(self, v):
        return (("0", v[0], "length"), ("1", v[1], "length"))


@dataclass(frozen=True)
class NumberKey(Key):
    """A number; ``quantity`` what it measures (kinem.parameters), None for an
    estimate that does not shape the mechanism (a contact angle's starting value)."""
    quantity: str | None = "length"
    accepts = "a number"
    phi_angle: bool = False   # an angle where the table's coord is phi (an absolute constraint's value)

    def numbers(self, v):
        return () if self.quantity is None else (("", v, self.quantity),)

    def parse(self, ck, where, v, scope):
        return ck.number(where, self.name, v)

    def radians(self, v, table):
        return v * DEGREE if self.angle or (self.phi_angle and table.get("coord") == "phi") else v


@dataclass(frozen=True)
class PositiveKey(Key):
    """A positive length (radius, link length): it counts towards the mechanism's size."""
    accepts = "a positive number"

    def parse(self, ck, where, v, scope):
        return ck.number(where, self.name, v, positive=True)

    def size(self, v):
        return float(v)

    def numbers(self, v):
        return (("", v, "length"),)


@dataclass(frozen=True)
class DirectionKey(Key):
    accepts = "a non-zero [x, y]"

    def parse(self, ck, where, v, scope):
        d = ck.vector(where, self.name, v, 2, "[x, y]")
        if d is not None and math.hypot(*d) == 0:
            ck.bad(where, self.name, "zero vector", "a non-zero [x, y]")
            return None
        return d

    def numbers(self, v):
        return (("0", v[0], "direction"), ("1", v[1], "direction"))


@dataclass(frozen=True)
class Vector3Key(Key):
    accepts = "[x, y, phi]"

    def parse(self, ck, where, v, scope):
        return ck.vector(where, self.name, v, 3, "[x, y, phi]")

    def radians(self, v, table):
        return (v[0], v[1], v[2] * DEGREE)

    def numbers(self, v):
        return (("0", v[0], "length"), ("1", v[1], "length"), ("2", v[2], "angle"))


@dataclass(frozen=True)
class CoordKey(Key):
    accepts = "one of x, y, phi"

    def parse(self, ck, where, v, scope):
        if v not in COORDS:
            ck.bad(where, self.name, f"got {show(v)}", "one of x, y, phi")
            return None
        return v


@dataclass(frozen=True)
class WordKey(Key):
    """One of a few words (``words``)."""
    words: tuple = ()

    @property
    def accepts(self):
        return " or ".join(f'"{w}"' for w in self.words)

    def parse(self, ck, where, v, scope):
        if v not in self.words:
            ck.bad(where, self.name, f"got {show(v)}", self.accepts)
            return None
        return v


@dataclass(frozen=True)
class BoolKey(Key):
    accepts = "true or false"

    def parse(self, ck, where, v, scope):
        if not isinstance(v, bool):
            ck.bad(where, self.name, f"got {show(v)}", "true or false")
            return None
        return v


@dataclass(frozen=True)
class FunctionKey(Key):
    accepts = "a function of time d(t) (Functions d(t))"
    phi_angle: bool = False   # its values are angles where the table's coord is phi (a driver's d)

    def parse(self, ck, where, v, scope):
        return function(ck, where, self.name, v, scope.end)

    def radians(self, v, table):
        """A harmonic's omega and phase are angles always; the values where they are angles."""
        from .. import functions as fn

        k = DEGREE if self.phi_angle and table.get("coord") == "phi" else 1.0
        if isinstance(v, fn.Harmonic):
            return fn.Harmonic(v.amplitude * k, v.omega * DEGREE, v.phase * DEGREE, v.offset * k)
        if isinstance(v, fn.Poly):
            return fn.Poly(tuple(c * k for c in v.coeffs))
        return fn.Table(v.t, tuple(x * k for x in v.value)) if k != 1.0 else v

    def numbers(self, v):
        """poly.k (rate k: driven quantity per s^k), harmonic.* and table.value.k."""
        if isinstance(v, fn.Poly):
            return tuple((f"poly.{k}", c, f"rate{k}") for k, c in enumerate(v.coeffs))
        if isinstance(v, fn.Harmonic):
            return (("harmonic.amplitude", v.amplitude, "rate0"), ("harmonic.omega", v.omega, "frequency"),
                    ("harmonic.phase", v.phase, "angle"), ("harmonic.offset", v.offset, "rate0"))
        return tuple((f"table.value.{k}", y, "rate0") for k, y in enumerate(v.value))


@dataclass(frozen=True)
class OutlineKey(Key):
    accepts = "an outline (Outlines)"

    def parse(self, ck, where, v, scope):
        return outline(ck, where, self.name, v)

    def size(self, v):
        return float(np.hypot(*v.center)) + max([abs(x) for x in v.s] + [v.radius])

    def numbers(self, v):
        """circle.radius or spline.s.k (a periodic table's last radius is its first: not listed), center.0, .1."""
        if v.kind == "circle":
            out = [("circle.radius", v.radius, "length")]
        else:
            out = [(f"spline.s.{k}", r, "length") for k, r in enumerate(v.s[:-1] if v.periodic else v.s)]
        return tuple(out) + (("center.0", v.center[0], "length"), ("center.1", v.center[1], "length"))
