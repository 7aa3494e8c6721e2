"""Every case of the repository is cross-checked by at least one engine
within that engine's tolerance (issue 29, item 8): the cams and slots by
Exudyn's user constraints on the outline angle theta. The engines are tried
cheapest first; the first within tolerance is the case's independent check."""
from pathlib import Path

import pytest

import kinem
from adapters import case_settings, get, names
from adapters.compare import compare, tolerance_of

CASES = Path(__file__).resolve().parents[1] / "cases"
CHEAPEST_FIRST = ("pymunk", "mujoco", "exudyn")   # their cost per interval on the book's cases


@pytest.mark.parametrize("name", sorted(p.stem for p in CASES.glob("*.toml")))
def test_every_case_has_an_engine_within_its_tolerance(name):
    model = kinem.compile(kinem.load(CASES / f"{name}.toml"))
    native = kinem.solve(model)
    assert native.success, native.message
    able = [e for e in CHEAPEST_FIRST + tuple(e for e in names() if e not in CHEAPEST_FIRST)
            if not get(e).unsupported(model)]
    assert able, f"{name}: no engine can represent it"
    seen = []
    for e in able:
        a = get(e)
        c = compare(model, native, a.run(model, settings=case_settings(model, e)), tolerance_of(a))
        if c.within_tolerance:
            # within every limit of the engine's table: positions, angles, closure, velocities
            assert all(getattr(c, k) <= v for k, v in tolerance_of(a).items()), (name, e)
            return
        seen.append(f"{e}: {c.verdict_text}")
    pytest.fail(f"{name}: no engine within its tolerance ({'; '.join(seen)})")


def test_exudyn_represents_the_cams_and_slots():
    """The four curve constraint types are Exudyn user constraints, none unsupported."""
    a = get("exudyn")
    for t in ("cam-point", "cam-roller", "cam-flat", "point-follower"):
        assert t in a.supports and t not in a.reasons
