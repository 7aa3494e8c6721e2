"""Engine adapters: the same mechanisms in pymunk, MuJoCo and Exudyn.

Modules are named ``*_sim.py`` so they never shadow the engines' own
packages; each is imported only when its engine is asked for.
"""
import importlib

ENGINES = ("pymunk", "mujoco", "exudyn")


def get(name: str):
    """The adapter instance of an engine (imports the engine)."""
    if name not in ENGINES:
        from kinem.errors import InputError

        raise InputError(f"unknown engine '{name}'; expected one of {', '.join(ENGINES)}")
    return importlib.import_module(f"adapters.{name}_sim").ADAPTER
