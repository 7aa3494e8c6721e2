"""The registry: case-file constraint type -> its declaration and family."""
from . import cam, distance, follower, gear, line, revolute, simple

REGISTRY = {}
for _module in (simple, revolute, line, distance, gear, follower, cam):
    for _decl in _module.TYPES:
        REGISTRY[_decl.name] = _decl


def implemented_types() -> list:
    return [name for name, decl in REGISTRY.items() if decl.family is not None]
