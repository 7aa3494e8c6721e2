"""The frozen specification of a case: what a case file says, validated and
with its defaults filled in. ``kinem.case`` makes one from TOML or a dict;
``kinem.model.compile`` turns one into a Model."""
import re
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .errors import InputError

# Characters that hide or spoof text where shown (C0 but tab and newline, DEL, C1, soft hyphen, zero-width and
# bidirectional controls such as U+202E): refused in a description (the loader's check, and Case's own for a Case
# built in Python), shown as codes by the report (kinem/report/escaping.py)
HIDDEN = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u00ad\u061c\u180e\u200b-\u200f\u2028-\u202e\u2060-\u206f\ufeff"
                    "\ufff9-\ufffb]")
PLAIN = "text without control or invisible formatting characters (tab and newline allowed)"


def frozen_map(d=None) -> Mapping:
    return MappingProxyType(dict(d or {}))


@dataclass(frozen=True)
class Body:
    name: str
    q: tuple  # initial estimate (x, y, phi); derived from its points where drawn (kinem.casefile.drawn)
    mass: float | None = None
    inertia: float | None = None
    carries: tuple = ()   # (point name, (xi, eta)): the drawn points it carries, in its own frame
    derived: bool = False  # q derived from its drawn points (the file gave none)


@dataclass(frozen=True)
class Point:
    name: str
    body: str
    at: tuple  # local coordinates (xi, eta)
    drawn: tuple | None = None   # (x, y) as drawn in the global frame (frame = "global"), else None


@dataclass(frozen=True)
class Constraint:
    type: str
    name: str
    index: int  # 1-based position in the file's [[constraints]]
    fields: Mapping[str, Any] = field(default_factory=frozen_map)
    refs: Mapping[str, str] = field(default_factory=frozen_map)  # key -> the named point it gave (fields hold its at)
    filled: tuple = field(default=(), compare=False)   # keys the loader filled in from the estimates (phi0, value)

    def __getitem__(self, key):
        return self.fields[key]

    def get(self, key, default=None):
        return self.fields.get(key, default)

    @property
    def where(self) -> str:
        return f"constraint {self.index} ('{self.name}', {self.type})"


@dataclass(frozen=True)
class Equivalence:
    """The case models the same mechanism as the other cases of ``group``:
    its named ``points`` must coincide with theirs (same names) at every instant."""
    group: str
    points: tuple


@dataclass(frozen=True)
class Case:
    name: str
    bodies: tuple
    points: tuple
    constraints: tuple
    end: float
    steps: int
    tolerance: float = 1e-12
    max_iterations: int = 25
    linear_solver: str = "auto"
    jacobian_reuse: bool = False
    block: int = 256  # 1: step by step in Python; more: the compiled march (kinem.march)
    description: str = ""
    units: Mapping = field(default_factory=frozen_map)
    engines: Mapping = field(default_factory=frozen_map)  # engine name -> settings overrides
    report: Mapping = field(default_factory=frozen_map)   # [report]: points (names the report draws)
    source: str = "<memory>"
    equivalent: Equivalence | None = None  # [equivalent]: the group of equivalent models it belongs to
    parameters: Mapping = field(default_factory=frozen_map)   # [parameters]: name -> the value used
    tolerances: Mapping = field(default_factory=frozen_map)  # [tolerances]: parameter path -> pm or {pm, sigma}
    uses: Mapping = field(default_factory=frozen_map)   # [parameters] name -> the paths of the numbers it gave

    def __post_init__(self):
        # the loader's check of a description (kinem.loader.build), for a Case built in Python or replaced too:
        # what is shown (the report, a case file written again) is what it holds
        d = self.description
        hidden = HIDDEN.search(d) if isinstance(d, str) else None
        if hidden or not isinstance(d, str):
            got = f"U+{ord(hidden.group()):04X} at character {hidden.start() + 1}" if hidden else \
                f"got {type(d).__name__}"
            raise InputError(f"{self.source}: top level: key 'description': {got}; expected {PLAIN}")

    def __repr__(self) -> str:   # a summary: the whole case is kinem.load's input, and thousands of characters
        return (f"Case({self.name!r}: {len(self.bodies)} bodies, {len(self.points)} points, "
                f"{len(self.constraints)} constraints, end {self.end:g}, {self.steps} steps, source {self.source!r})")

    @property
    def times(self) -> np.ndarray:
        """Output instants t = 0, h, ..., end with h = end/steps."""
        return np.arange(self.steps + 1) * (self.end / self.steps)

    @property
    def length_unit(self) -> str:
        return self.units.get("length", "")

    def with_time(self, end: float | None = None, steps: int | None = None) -> "Case":
        return replace(self, end=self.end if end is None else float(end),
                       steps=self.steps if steps is None else int(steps))
