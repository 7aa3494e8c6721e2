"""Bad input never crashes: mutated case files always give a one-line
error (exit 2 when the mutation makes the file invalid), never a traceback
or an internal error (exit 3)."""
import contextlib
import io
import json
import math
import tomllib
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from kinem.cli import main

CASES = Path(__file__).resolve().parents[1] / "cases"
BASES = ["slider_crank", "four_bar", "quick_return_3"]
PARSED = {b: tomllib.loads((CASES / f"{b}.toml").read_text()) for b in BASES}


def emit(value) -> str:
    """TOML for any structure: inline tables and arrays nest arbitrarily."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(emit(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {emit(v)}" for k, v in value.items()) + "}"


def document(d: dict) -> str:
    return "\n".join(f"{json.dumps(k)} = {emit(v)}" for k, v in d.items()) + "\n"


def paths(node, prefix=()):
    """Every (path to a node) in a parsed case."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += paths(v, prefix + (k,))
    elif isinstance(node, list):
        for k, v in enumerate(node):
            out += paths(v, prefix + (k,))
    return out


def get(d, path):
    for p in path:
        d = d[p]
    return d


INVALID = {  # replacements that no key of the format accepts where a number is expected
    "nan": float("nan"), "inf": float("inf"), "-inf": float("-inf"),
    "huge-list": list(range(200_001)),
}
ODD = {  # replacements that may or may not be valid where they land
    "string": "zzz", "bool": True, "empty-table": {}, "empty-list": [], "zero": 0, "negative": -1.5,
    "big": 1e308, "nested": {"a": [1, {"b": 2}]}, "list3": [1.0, 2.0, 3.0],
}


@st.composite
def mutated(draw):
    base = draw(st.sampled_from(BASES))
    d = json.loads(json.dumps(PARSED[base]))  # deep copy
    path = draw(st.sampled_from(paths(d)))
    parent, key = get(d, path[:-1]), path[-1]
    kind = draw(st.sampled_from(["delete", "rename", "invalid", "odd", "swap-bodies"]))
    invalid = False
    if kind == "delete":
        if isinstance(parent, list):
            parent.pop(key)
        else:
            del parent[key]
    elif kind == "rename" and isinstance(parent, dict):
        parent[str(key) + "_typo"] = parent.pop(key)
        invalid = True  # an unknown key is always an error (or the name of a body/point that then is unknown)
    elif kind == "invalid" and isinstance(get(d, path), (int, float)) and not isinstance(get(d, path), bool):
        parent[key] = INVALID[draw(st.sampled_from(sorted(INVALID)))]
        invalid = True
    elif kind == "swap-bodies":
        cons = [c for c in d.get("constraints", []) if isinstance(c, dict) and "i" in c and "j" in c]
        if cons:
            c = draw(st.sampled_from(cons))
            c["i"], c["j"] = c["j"], c["i"]
    else:
        parent[key] = ODD[draw(st.sampled_from(sorted(ODD)))]
    return document(d), invalid


def check(tmp_path, text, must_be_invalid, command="info"):
    path = tmp_path / "case.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    args = [command, str(path)] + (["--steps", "3", "--out", str(tmp_path / "o.csv")] if command == "solve" else [])
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(io.StringIO()):
        code = main(args)
    err = buf.getvalue()
    assert code in (0, 1, 2), err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 1, err
    if must_be_invalid:
        assert code == 2 and str(path) in err, err
    if code != 0:
        assert err.startswith("kinem: ")
        assert not (tmp_path / "o.csv").exists()


@settings(max_examples=150)
@given(m=mutated(), command=st.sampled_from(["info", "solve"]))
def test_mutated_case_files(tmp_path_factory, m, command):
    text, invalid = m
    check(tmp_path_factory.mktemp("fuzz"), text, invalid, command)


@settings(max_examples=60)
@given(data=st.binary(max_size=400))
def test_random_bytes(tmp_path_factory, data):
    check(tmp_path_factory.mktemp("bytes"), data, False)


@settings(max_examples=60)
@given(cut=st.integers(1, 1500), base=st.sampled_from(BASES))
def test_truncated_files(tmp_path_factory, cut, base):
    text = (CASES / f"{base}.toml").read_text()
    if cut >= len(text):
        return
    check(tmp_path_factory.mktemp("cut"), text[:cut], False)


@pytest.mark.parametrize("text", [
    "", "name = 'x'", "[[constraints]]\n" * 3, "a = " + "[" * 5000 + "]" * 5000,
    'name = "x"\n[time]\nend = 1\nsteps = 100000000\n', "\x00\x01\x02",
])
def test_degenerate_files(tmp_path, text):
    check(tmp_path, text, True)


def test_emitter_round_trips():
    for b in BASES:
        assert tomllib.loads(document(PARSED[b])) == PARSED[b]
