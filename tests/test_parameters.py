"""Issue 30 item 1: design parameters named by paths in the case file's own
words (kinem.parameters), listed by ``kinem info CASE --parameters``."""
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import kinem
from kinem.parameters import apply, case_dict, parameters, resolve

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml")) + sorted((ROOT / "cases" / "stress").glob("*.toml"))


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_case_dict_round_trips(path):
    """load_dict(case_dict(case)) is the case itself, and every listed
    parameter, set to its own value, gives the same case back."""
    case = kinem.load(path)
    assert kinem.load_dict(case_dict(case), source=case.source) == case
    listed = parameters(case)
    assert listed and len({p.path for p in listed}) == len(listed)
    assert apply(case, {p.path: p.value for p in listed}) == case


def test_four_bar_paths_and_point_references():
    """Named points that constraints read are points.<p>.at.<k>; moving one
    moves every constraint that names it."""
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    paths = {p.path: p for p in parameters(case)}
    assert paths["points.A.at.0"].value == 0.05 and paths["points.A.at.0"].unit == "m"
    assert "constraints.crank-drive.d.poly.1" in paths
    assert paths["constraints.crank-drive.d.poly.1"].unit == "rad/s"
    moved = apply(case, {"points.A.at.0": 0.06})
    readers = [c for c in moved.constraints if "A" in c.refs.values()]
    assert readers and all(c[k] == (0.06, 0.0) for c in readers for k, p in c.refs.items() if p == "A")
    assert next(p for p in moved.points if p.name == "A").at == (0.06, 0.0)


def test_unnamed_constraints_are_hash_index():
    case = kinem.load(ROOT / "cases" / "slider_crank.toml")
    assert {"constraints.#1.value.0", "constraints.#1.value.2"} <= {p.path for p in parameters(case)}
    moved = apply(case, {"constraints.#1.value.1": 5.0})
    assert moved.constraints[0]["value"][1] == 5.0


@pytest.mark.parametrize("path, says", [
    ("constraints.crank-drive.d.poly.7", "did you mean"),
    ("points.A.at.3", "points.A.at.0"),
    ("constraints.A.si.0", "names point 'A'"),
    ("bodies.crank.q.0", "read by no constraint"),
])
def test_bad_paths_name_the_file_and_the_path(path, says):
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    with pytest.raises(kinem.InputError) as e:
        resolve(case, [path])
    assert str(e.value).startswith(f"{case.source}: parameter '{path}'") and says in str(e.value)


def test_a_point_no_constraint_reads_is_refused():
    data = tomllib.loads((ROOT / "cases" / "four_bar.toml").read_text())
    data["points"]["mid"] = {"body": "coupler", "at": [0.05, 0.0]}
    case = kinem.load_dict(data, source="fb.toml")
    with pytest.raises(kinem.InputError, match=r"fb.toml: parameter 'points.mid.at.0': point 'mid' is read by no"):
        apply(case, {"points.mid.at.0": 1.0})


def test_an_estimate_is_not_a_parameter():
    case = kinem.load(ROOT / "cases" / "cam_table41.toml")
    cam = next(c for c in case.constraints if "theta" in c.fields)
    with pytest.raises(kinem.InputError, match="does not shape the mechanism"):
        resolve(case, [f"constraints.{cam.name}.theta"])


def test_a_value_out_of_range_is_the_keys_error():
    case = kinem.load(ROOT / "cases" / "gear_pair.toml")
    radius = next(p.path for p in parameters(case) if p.path.endswith(".ri"))
    with pytest.raises(kinem.InputError, match="key 'ri'.*expected a positive number"):
        apply(case, {radius: -1.0})


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(CASES), st.data())
def test_apply_sets_exactly_the_named_value(path, data):
    """Any parameter set to a nearby value reads back as that value; every other stays put."""
    case = kinem.load(path)
    listed = parameters(case)
    p = data.draw(st.sampled_from(listed))
    v = p.value + data.draw(st.floats(1e-6, 1e-3)) * max(1.0, abs(p.value))
    after = {q.path: q.value for q in parameters(apply(case, {p.path: v}))}
    assert after[p.path] == pytest.approx(v, rel=1e-15)
    assert all(after[q.path] == q.value for q in listed if q.path != p.path)


def test_cli_lists_parameters_as_text_and_json():
    run = [sys.executable, "-m", "kinem", "info", str(ROOT / "cases" / "slider_crank.toml"), "--parameters"]
    text = subprocess.run(run, capture_output=True, text=True, check=True).stdout
    assert text.splitlines()[0].split()[:3] == ["path", "value", "unit"] and "constraints.O.si.0" in text
    rows = json.loads(subprocess.run(run + ["--json"], capture_output=True, text=True, check=True).stdout)
    assert {"path": "constraints.O.si.0", "value": 100.0, "unit": "mm"}.items() <= rows[3].items()
    assert np.isfinite([r["value"] for r in rows]).all()


@pytest.mark.parametrize("path", CASES + sorted((ROOT / "tests" / "data").glob("**/*.toml")), ids=lambda p: p.stem)
def test_resolve_finds_each_path_as_the_listing_does(path):
    """resolve finds a path from the one point, constraint key or named
    dimension it names (kinem.parameters._find), without listing the case's
    parameters: every listed parameter found so, equal to the listing's;
    and a path that is none of them not found (the listing then says why)."""
    from kinem.errors import KinemError
    from kinem.parameters import _find

    try:
        case = kinem.load(path)
    except KinemError:
        pytest.skip("not a loadable case")
    listed = parameters(case)
    assert tuple(_find(case, p.path) for p in listed) == listed
    assert resolve(case, [p.path for p in reversed(listed)]) == tuple(reversed(listed))
    for bad in ("points.nowhere.at.0", "bodies.x.q.0", "constraints.#999.value.0", "parameters.nothing",
                *[p.path + ".0" for p in listed[:3]], *[p.path[:-1] + "9" for p in listed if p.path[-1] in "01"][:3]):
        if bad not in {p.path for p in listed}:
            assert _find(case, bad) is None, bad
