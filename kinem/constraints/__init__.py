"""The registry: case-file constraint type -> its declaration and family
(``read`` checks a [[constraints]] table against it, ``docs`` writes
docs/case-format.md's tables from it)."""
from . import cam, distance, follower, gear, line, revolute, simple

REGISTRY = {}
for _module in (simple, revolute, line, distance, gear, follower, cam):
    for _decl in _module.TYPES:
        REGISTRY[_decl.name] = _decl


def implemented_types() -> list:
    return [name for name, decl in REGISTRY.items() if decl.family is not None]
