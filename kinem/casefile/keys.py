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

from .checks import show
from .curves import function, outline

COORDS = ("x", "y", "phi")


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
    accepts = ""  # what a value looks like, in the docs' words

    def parse(self, ck, where, v, scope: Scope):
        raise NotImplementedError

    def size(self, v) -> float | None:
        """The length this value contributes to the mechanism's size (kinem.model), if any."""
        return None


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
            carries = dict(scope.bodies[body].carries) if body in scope.bodies else {}
            if v in carries:   # a point drawn in the global frame that the body carries (kinem.casefile.drawn)
                return carries[v]
            if ck.choice(where, self.name, v, scope.points, "point") is None:
                return None
            if scope.points[v].body != body:
                ck.bad(where, self.name, f"point '{v}' is on body '{scope.points[v].body}', not on '{body}'",
                       f"a point on body '{body}' or [xi, eta]")
                return None
            return scope.points[v].at
        return ck.vector(where, self.name, v, 2, "[xi, eta] or a point name")

    def size(self, v):
        return float(np.hypot(*v))


@dataclass(frozen=True)
class NumberKey(Key):
    accepts = "a number"

    def parse(self, ck, where, v, scope):
        return ck.number(where, self.name, v)


@dataclass(frozen=True)
class PositiveKey(Key):
    """A positive length (radius, link length): it counts towards the mechanism's size."""
    accepts = "a positive number"

    def parse(self, ck, where, v, scope):
        return ck.number(where, self.name, v, positive=True)

    def size(self, v):
        return float(v)


@dataclass(frozen=True)
class DirectionKey(Key):
    accepts = "a non-zero [x, y]"

    def parse(self, ck, where, v, scope):
        d = ck.vector(where, self.name, v, 2, "[x, y]")
        if d is not None and math.hypot(*d) == 0:
            ck.bad(where, self.name, "zero vector", "a non-zero [x, y]")
            return None
        return d


@dataclass(frozen=True)
class Vector3Key(Key):
    accepts = "[x, y, phi]"

    def parse(self, ck, where, v, scope):
        return ck.vector(where, self.name, v, 3, "[x, y, phi]")


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

    def parse(self, ck, where, v, scope):
        return function(ck, where, self.name, v, scope.end)


@dataclass(frozen=True)
class OutlineKey(Key):
    accepts = "an outline (Outlines)"

    def parse(self, ck, where, v, scope):
        return outline(ck, where, self.name, v)

    def size(self, v):
        return float(np.hypot(*v.center)) + max([abs(x) for x in v.s] + [v.radius])
