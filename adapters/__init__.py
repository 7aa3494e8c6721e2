"""Engine adapters: the same mechanisms in pymunk, MuJoCo and Exudyn.

``REGISTRY`` maps each engine's name to its adapter module (which defines
``ADAPTER``); modules are named ``*_sim.py`` so they never shadow the engines'
own packages, and each is imported only when its engine is asked for. This
is the one list of engines: the CLI, the report, the stress suite and the
benchmarks take it from here (``names()``), and a new engine is one module
plus one line here.
"""
import importlib

REGISTRY = {
    "pymunk": "adapters.pymunk_sim",
    "mujoco": "adapters.mujoco_sim",
    "exudyn": "adapters.exudyn_sim",
}
ENGINES = tuple(REGISTRY)  # the built-in engines; names() also sees any registered later


def names() -> tuple:
    return tuple(REGISTRY)


def _unknown(name, where=""):
    from kinem.errors import InputError

    at = f"{where}: " if where else ""
    return InputError(f"{at}unknown engine '{name}'; expected one of {', '.join(names())}")


def get(name: str):
    """The adapter instance of an engine (imports the engine)."""
    if name not in REGISTRY:
        raise _unknown(name)
    return importlib.import_module(REGISTRY[name]).ADAPTER


def settings(name: str, overrides=None, where: str = "") -> dict:
    """An engine's checked settings: its defaults with ``overrides`` (raises
    InputError naming ``where``, the engine and the key when one is bad)."""
    if name not in REGISTRY:
        raise _unknown(name, where)
    return get(name).settings(overrides, where)


def case_settings(model, name: str, overrides=None) -> dict:
    """An engine's settings for a case: defaults, the case file's
    [engines.NAME] table (checked, naming the file), then ``overrides``."""
    table = dict(model.case.engines.get(name, {}))
    source = getattr(model.case, "source", "") or "case"
    get(name).settings(table, f"{source}: [engines.{name}]", table=True)   # the loader's form of a place
    return settings(name, {**table, **(overrides or {})})


def check_case(case):
    """Every [engines.NAME] table of a case names a known engine."""
    source = getattr(case, "source", "") or "case"
    for name in case.engines:
        if name not in REGISTRY:
            raise _unknown(name, f"{source}: [engines.{name}]")
