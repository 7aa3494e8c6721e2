"""The layers contract (.importlinter, docs/solver.md "Layers") names every
top-level module and subpackage of kinem and adapters, so that a new module
cannot stand outside the one-way stack (import-linter checks only the
modules a contract names; python3 dev.py test runs it)."""
import configparser
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_module_is_in_a_layer():
    config = configparser.ConfigParser()
    config.read(ROOT / ".importlinter")
    named = set(re.split(r"[\s|]+", config["importlinter:contract:stack"]["layers"])) - {""}
    found = set()
    for package in ("kinem", "adapters"):
        for p in (ROOT / package).iterdir():
            if p.suffix == ".py" and p.name != "__init__.py":
                found.add(f"{package}.{p.stem}")
            elif p.is_dir() and (p / "__init__.py").exists():
                found.add(f"{package}.{p.name}")
    assert found - named == set(), "not in a layer of .importlinter's stack"
    assert named - found == set(), "in a layer of .importlinter's stack, not in the package"
