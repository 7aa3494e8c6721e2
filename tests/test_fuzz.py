"""Bad input never crashes: mutated case files and command lines always give
exit code 0, 1 or 2, exactly one line on standard error for 1 and 2 (exit 2
when the mutation makes the file invalid), never a traceback or an internal
error (exit 3), and leave no temporary file behind.

CI runs a fixed, derandomised budget (tests/conftest.py); KINEM_FUZZ_EXAMPLES
raises it for a longer run (issue 17: 5,000 cases, once)."""
import contextlib
import io
import json
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from hypothesis import assume, given, settings, strategies as st

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
    "int40": 10**40, "int400": 10**400, "tiny": 5e-324, "newline": "rod\n", "dollar": "$\\frac{$",
    "list17": [1.0] * 17, "close-times": [0.0, 1e-300, 2e-300, 10.0], "long-name": "x" * 65,
    "control": "a\x07b", "huge-int-text": 9 * 10**4000,
}
EXAMPLES = int(os.environ.get("KINEM_FUZZ_EXAMPLES", "0"))  # 0: the budgets below (CI)
# the slider-crank over two steps of 0.01 s: the engine-facing commands' fuzz tests run it
SHORT = (CASES / "slider_crank.toml").read_text().replace("end = 5.0", "end = 0.02").replace("steps = 500", "steps = 2")


def budget(n):
    return settings(max_examples=EXAMPLES or n)


KINDS = ("delete", "rename", "invalid", "odd", "swap-bodies")
# Mutations for the long run (benchmarks/fault_matrix.py; issue 33): drivers up to 1e6 times
# faster than the output step, tables of up to 1e5 rows, outline splines cut short. A fast
# driver takes up to kinem solve's time limit (--max-seconds): too slow for the CI budget.
SLOW_KINDS = ("fast-driver", "long-table", "cut-spline")


def _drivers(d):
    return [c for c in d.get("constraints", []) if isinstance(c, dict) and isinstance(c.get("d"), dict)]


def _splines(d):
    return [c["outline"]["spline"] for c in d.get("constraints", []) if isinstance(c, dict)
            and isinstance(c.get("outline"), dict) and isinstance(c["outline"].get("spline"), dict)]


def _offset_and_rate(f):
    """The value at 0 and the slope of a driver's function, as far as its poly tells."""
    poly = f.get("poly") if isinstance(f.get("poly"), list) else [0.0]
    nums = [v for v in poly if isinstance(v, (int, float)) and not isinstance(v, bool)] + [0.0, 0.0]
    return float(nums[0]), float(nums[1])


def slow_mutation(d, kind, choose) -> bool:
    """A SLOW_KINDS mutation of d in place; False when d has nothing it applies to."""
    if kind == "cut-spline":
        found = _splines(d)
        if not found:
            return False
        spline = choose(found)
        key = choose(["theta", "s", "both"])
        keep = choose([0, 1, 2, 3, -1])
        for k in (("theta", "s") if key == "both" else (key,)):
            if isinstance(spline.get(k), list):
                spline[k] = spline[k][:keep] if keep >= 0 else spline[k][:-1]
        return True
    found = _drivers(d)
    if not found:
        return False
    c = choose(found)
    offset, rate = _offset_and_rate(c["d"])
    if kind == "fast-driver":
        c["d"] = {"harmonic": {"amplitude": choose([0.01, 0.1, 1.0, 10.0]), "omega": choose([1e2, 1e3, 1e4, 1e5, 1e6]),
                               "phase": 0.0, "offset": offset}}
        return True
    time = d.get("time") if isinstance(d.get("time"), dict) else {}
    end = time.get("end", 1.0)
    end = float(end) if isinstance(end, (int, float)) and not isinstance(end, bool) and 0 < end < 1e6 else 1.0
    rows = choose([1_000, 10_000, 100_000])
    wiggle, omega = choose([0.0, 1e-3, 0.1]), choose([1.0, 50.0, 5e3])
    t = [end * 1.01 * k / (rows - 1) for k in range(rows)]
    c["d"] = {"table": {"t": t, "value": [offset + rate * x + wiggle * math.sin(omega * x) for x in t]}}
    return True


def mutate(doc, choose, kinds=KINDS):
    """One mutation of a parsed case file (a deep copy of ``doc``), each
    choice made by ``choose(sequence)`` (hypothesis's draw here, a seeded
    random.choice in benchmarks/fault_matrix.py), of one of ``kinds``
    (KINDS, and SLOW_KINDS for the long run): (TOML text, whether it
    must be invalid)."""
    d = json.loads(json.dumps(doc))  # deep copy
    path = choose(paths(d))
    parent, key = get(d, path[:-1]), path[-1]
    kind = choose(list(kinds))
    invalid = False
    if kind in SLOW_KINDS and slow_mutation(d, kind, choose):
        pass
    elif kind == "delete":
        if isinstance(parent, list):
            parent.pop(key)
        else:
            del parent[key]
    elif kind == "rename" and isinstance(parent, dict):
        parent[str(key) + "_typo"] = parent.pop(key)
        # an unknown key is always an error, and so is a renamed body (every body is referred to);
        # a renamed point is valid when no constraint names it (found by the 5,000-case run)
        invalid = parent is not d.get("points")
    elif kind == "invalid" and isinstance(get(d, path), (int, float)) and not isinstance(get(d, path), bool):
        parent[key] = INVALID[choose(sorted(INVALID))]
        invalid = True
    elif kind == "swap-bodies":
        cons = [c for c in d.get("constraints", []) if isinstance(c, dict) and "i" in c and "j" in c]
        if cons:
            c = choose(cons)
            c["i"], c["j"] = c["j"], c["i"]
    else:
        parent[key] = ODD[choose(sorted(ODD))]
    return document(d), invalid


@st.composite
def mutated(draw):
    base = draw(st.sampled_from(BASES))
    return mutate(PARSED[base], lambda seq: draw(st.sampled_from(seq)))


def check(tmp_path, text, must_be_invalid, command="info", options=("--steps", "3")):
    path = tmp_path / "case.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    args = [command, str(path)] + ([*options, "--out", str(tmp_path / "o.csv")] if command == "solve" else [])
    code, err = run_main(args)
    if must_be_invalid:
        assert code == 2 and str(path) in err, err
    if code != 0:
        assert not (tmp_path / "o.csv").exists()
    left = sorted(p.name for p in tmp_path.iterdir() if p.name not in ("case.toml", "o.csv"))
    assert not left, left  # no temporary file left behind


NOTES = re.compile(r"\S+: the Monte Carlo band leaves the worst-case linear band by at most |"
                   r"kinem: \d+ of \d+ samples left out of the Monte Carlo band|"
                   r"kinem: the Monte Carlo band stays within the worst-case linear band for ")   # kinem tolerance's


def run_main(args, notes=False):
    """kinem.cli.main in-process; asserts the contract every run keeps
    (``notes``: kinem tolerance's lines on standard error, NOTES, allowed)."""
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(io.StringIO()):
        code = main(args)
    err = buf.getvalue()
    assert code in (0, 1, 2), err
    assert "Traceback" not in err and "internal error" not in err, err
    # a warning (valid input that looks like a mistake: a fast driver) is one line of its own
    # (docs/case-format.md); besides the warnings, one line for 1 and 2, none for 0
    lines = [line for line in err.splitlines()
             if not line.startswith("kinem: warning: ") and not (notes and NOTES.match(line))]
    if code in (1, 2):
        assert len(lines) == 1 and lines[0].startswith("kinem: ") and err.endswith("\n"), err
    else:
        assert not lines, err
    return code, lines[0] if lines else ""


OPTION_VALUES = ["3", "1", "0", "-1", "2.5", "1e8", "1e7", "inf", "-inf", "nan", "1e300", "1e-300", "x", "",
                 "9" * 40, "0x10", "1_0", " 5", "5\n"]


def slow(steps) -> bool:
    """A valid step count above 12: a long run, not for a cheap test (larger ones are refused at once)."""
    try:
        v = float(steps.replace("_", ""))
    except ValueError:
        return False
    return 12 < v <= 1e7


@budget(40)
@given(end=st.one_of(st.none(), st.sampled_from(OPTION_VALUES), st.floats(allow_nan=True).map(repr)),
       steps=st.one_of(st.sampled_from(OPTION_VALUES), st.integers(-5, 12).map(str)))
def test_command_line_times(tmp_path_factory, end, steps):
    """--end and --steps by the case file's rules, whatever their text."""
    assume(not slow(steps))
    options = (["--end", end] if end is not None else []) + ["--steps", steps]
    check(tmp_path_factory.mktemp("opts"), (CASES / "four_bar.toml").read_text(), False, "solve", options)


@budget(150)
@given(m=mutated(), command=st.sampled_from(["info", "solve"]))
def test_mutated_case_files(tmp_path_factory, m, command):
    text, invalid = m
    check(tmp_path_factory.mktemp("fuzz"), text, invalid, command)


@budget(60)
@given(data=st.binary(max_size=400))
def test_random_bytes(tmp_path_factory, data):
    check(tmp_path_factory.mktemp("bytes"), data, False)


@budget(60)
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


@pytest.mark.parametrize("args", [
    ["solve", "/dev/zero"],
    ["info", str(CASES / "slider_crank.toml"), "--errors", "everything"],
    ["solve", str(CASES / "slider_crank.toml"), "--steps", "1e8"],
])
def test_subprocess_one_line(args):
    """The same contract through the real entry point (a few runs: each costs an interpreter start)."""
    p = subprocess.run([sys.executable, "-m", "kinem", *args], capture_output=True, text=True, timeout=120,
                       cwd=CASES.parent)
    assert p.returncode == 2 and len(p.stderr.splitlines()) == 1 and "Traceback" not in p.stderr, p.stderr


def test_emitter_round_trips():
    for b in BASES:
        assert tomllib.loads(document(PARSED[b])) == PARSED[b]
