"""Bad input never crashes the design commands and calls either: ``kinem
sensitivity``, ``tolerance``, ``sweep`` and ``--set`` on case files whose
[tolerances], [parameters] and [report] sensitivity are mutated, and with odd
argument texts, keep the command line's contract (tests/test_fuzz.run_main:
exit 0, 1 or 2, one line, never an internal error); kinem.solve(model,
parameters=...), kinem.sensitivity, kinem.tolerance.tolerance, kinem.sweep
and kinem.load(parameters=...) given odd values (huge whole numbers, NaN,
inf, booleans, texts, nested lists, unknown paths, empty lists) return or
raise a KinemError of one line, never another exception.

CI runs a small derandomised budget (tests/conftest.py); KINEM_FUZZ_EXAMPLES
raises it, HYPOTHESIS_PROFILE=dev randomises it (docs/benchmarks.md, "Fuzz
campaign, session 23"). The examples below the fuzz tests are the failures
the campaign found, each fixed."""
import contextlib
import io
import json
import math
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

import kinem
from kinem.cli import main
from kinem.errors import MAX_LINE, KinemError
from kinem.tolerance import MAX_SAMPLES, tolerance
from test_fuzz import INVALID, ODD, budget, document, get, paths, run_main

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "cases" / "four_bar.toml"                    # [tolerances], [report] sensitivity
NAMED = ROOT / "tests" / "data" / "four_bar_named.toml"        # [parameters]
BASES = {p: tomllib.loads(p.read_text()) for p in (FOUR_BAR, NAMED)}
DESIGN = ("tolerances", "parameters", "report")
PATHS = ["points.A.at.0", "points.A.at.1", "constraints.B.si.0", "constraints.crank-drive.d.poly.1", "crank",
         "parameters.crank", "coupler", "points.A.at.9", "points.A.at.x", "constraints.#2.sj.0", "constraints.B.si",
         "parameters.nope", "bodies.crank.q.0", "time.end", "", ".", "a..b", "points..at.0", "constraints",
         "\x00", "x" * 600, "points.O2.at.0,points.O2.at.0"]
TEXTS = ["0", "1", "-1", "2", "1e-4", "nan", "inf", "-inf", "1e400", "9" * 400, "x", "", " ", "true", "[1]",
         "0x10", "1_0", "{a=1}", "5e-324", "1e308", ",", "B.x", "B.x,B.x", "positions", "nope", "\t"]


def mutate_design(doc, choose):
    """One mutation of a parsed case's design sections ([tolerances],
    [parameters], [report]) or of a number that a named dimension could
    stand for: (TOML text, whether it must be invalid)."""
    d = json.loads(json.dumps(doc))
    kind = choose(["delete", "odd", "invalid", "new-key", "name-a-number"])
    if kind == "name-a-number":   # a constraint's number given as a name: of [parameters], or none
        numbers = [p for p in paths(d) if p[0] == "constraints" and isinstance(get(d, p), float)]
        p = choose(numbers)
        get(d, p[:-1])[p[-1]] = choose(["crank", "coupler", "nope", "", "parameters.crank"])
        return document(d), False
    if kind == "new-key":
        section = choose(["tolerances", "parameters"])
        d.setdefault(section, {})[choose(PATHS)] = choose([ODD[k] for k in sorted(ODD)] + [1e-4, {"pm": 1e-4}])
        return document(d), False
    found = [p for p in paths(d) if p[0] in DESIGN]
    p = choose(found)
    parent, key = get(d, p[:-1]), p[-1]
    if kind == "delete":
        del parent[key]
        return document(d), False
    if kind == "invalid" and isinstance(get(d, p), (int, float)) and not isinstance(get(d, p), bool):
        parent[key] = INVALID[choose(sorted(INVALID))]
        return document(d), True
    parent[key] = ODD[choose(sorted(ODD))]
    return document(d), False


@st.composite
def design_mutated(draw):
    base = draw(st.sampled_from(sorted(BASES)))
    return mutate_design(BASES[base], lambda seq: draw(st.sampled_from(seq)))


def arguments(command, draw):
    """Command-line arguments after the case file, part valid, part odd."""
    text = st.one_of(st.sampled_from(TEXTS), st.text(max_size=8))
    path = st.one_of(st.sampled_from(PATHS), st.text(max_size=12))
    steps = ["--steps", draw(st.sampled_from(["3", "2", "0", "x", "1e9"]))]
    if command == "sensitivity":
        out = ["--parameters", ",".join(draw(st.lists(path, min_size=1, max_size=3)))]
        return out + (["--outputs", draw(text)] if draw(st.booleans()) else []) + steps
    if command == "tolerance":
        out = ["--samples", draw(st.sampled_from(["0", "1", "2", "-1", "x", "1.5", "9" * 30, str(MAX_SAMPLES + 1)])),
               "--seed", draw(st.sampled_from(["0", "7", "-1", "9" * 30, "x"]))]
        return out + (["--outputs", draw(text)] if draw(st.booleans()) else []) + steps
    if command == "sweep":
        sets = draw(st.lists(st.tuples(path, st.one_of(text, st.sampled_from(
            ["0.05:0.06:2", "0.05,0.06", "inf:1:2", "1e400:1:2", "1:2:0", "1:2:x", "1e308:-1e308:3", "0.1:0.2:1e9",
             "0.05:0.06:100001", ":1:2", "1::2"]))), max_size=2))
        out = [x for name, v in sets for x in ("--set", f"{name}={v}")]
        return out + ["--outputs", draw(st.sampled_from(["B.x", "B.x,rocker.phi", "", "nope", ",", "t"]))]
    sets = draw(st.lists(st.tuples(path, text), max_size=2))   # solve, info (its listing of the parameters too)
    out = [x for name, v in sets for x in ("--set", f"{name}={v}")]
    return out + (steps if command == "solve" else ["--parameters"] if draw(st.booleans()) else [])


def run(tmp_path, command, text, args):
    case = tmp_path / "case.toml"
    case.write_text(text)
    out = tmp_path / "o.csv"
    argv = [command, str(case), *args] + (["--out", str(out)] if command != "info" else [])
    code, err = run_main(argv, notes=command == "tolerance")
    if command == "sweep" and code == 1:   # variants that failed: the whole table, their rows saying why
        text = out.read_text()
        rows = text.splitlines()
        assert text.endswith("\n") and rows[0].startswith("variant,") and rows[0].endswith(",error"), rows[0]
        assert any(r.endswith('"') for r in rows[1:]), text[-300:]
    elif code != 0:
        assert not out.exists(), "an output written by a failed run"
    left = sorted(p.name for p in tmp_path.iterdir() if p.name not in ("case.toml", "o.csv"))
    assert not left, left
    return code, err


COMMANDS = ["info", "solve", "sensitivity", "tolerance", "sweep"]


@budget(30)
@given(m=design_mutated(), command=st.sampled_from(COMMANDS))
def test_mutated_design_sections(tmp_path_factory, m, command):
    """A mutated [tolerances], [parameters] or [report] under every design command (valid arguments)."""
    text, invalid = m
    args = {"info": [], "solve": ["--steps", "3"], "sweep": ["--set", "points.O2.at.0=0,0.001", "--outputs", "B.x"],
            "sensitivity": ["--parameters", "points.O2.at.0", "--steps", "3"],
            "tolerance": ["--samples", "2", "--outputs", "B.x", "--steps", "3"]}[command]
    tmp = tmp_path_factory.mktemp("design")
    code, err = run(tmp, command, text, args)
    if invalid:
        assert code == 2 and str(tmp / "case.toml") in err, err


@budget(40)
@given(command=st.sampled_from(COMMANDS), base=st.sampled_from(sorted(BASES)), data=st.data())
def test_odd_arguments(tmp_path_factory, command, base, data):
    """--set (solve, info, sweep), --parameters, --samples, --seed, --outputs, --steps: any text."""
    run(tmp_path_factory.mktemp("args"), command, base.read_text(), arguments(command, data.draw))


# -- the API ----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def models():
    return {p: kinem.compile(kinem.load(p).with_time(steps=3)) for p in BASES}


VALUES = st.one_of(
    st.sampled_from([10 ** 400, -10 ** 400, 10 ** 40, math.nan, math.inf, -math.inf, True, False, "x", "0.05", "",
                     None, [], [[]], [1, [2]], [[1.0, 2.0]], {}, {"pm": 1e-4}, {"pm": 1e-4, "sigma": math.nan},
                     1e308, 5e-324, 0, -1, b"1", 1j, [0.05, 0.06], [10 ** 400], [True], np.array([[1.0]]),
                     np.float64("nan"), (0.05,), "points.A.at.0"]),
    st.floats(), st.integers(), st.text(max_size=6), st.lists(st.floats(), max_size=3))
KEYS = st.one_of(st.sampled_from(PATHS + [3, None, True, (1,)]), st.text(max_size=10))


def calm(call):
    """call() returns, or raises a KinemError of one line; its warnings are not errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            call()
        except KinemError as e:
            # one line of at most InputError.SHOWN problems of at most MAX_LINE characters each
            assert str(e) and "\n" not in str(e) and len(str(e)) <= 4 * MAX_LINE, repr(str(e))


def samples_of(draw):
    """A Monte Carlo sample count: a small valid one or an odd one, never a slow valid one."""
    v = draw(st.one_of(VALUES, st.integers(-3, 3)))
    return 2 if isinstance(v, int) and not isinstance(v, bool) and 3 < v <= MAX_SAMPLES else v


@budget(40)
@given(api=st.sampled_from(["solve", "sensitivity", "tolerance", "sweep", "load"]), base=st.sampled_from(sorted(BASES)),
       key=KEYS, value=VALUES, data=st.data())
def test_api_odd_values(models, api, base, key, value, data):
    model = models[base]
    extra = data.draw(st.one_of(st.none(), VALUES, st.sampled_from([["B.x"], "B.x", ("positions",)])))
    if api == "solve":
        if isinstance(value, list) and len(value) > 3:
            value = value[:3]
        calm(lambda: kinem.solve(model, parameters=data.draw(st.sampled_from([{key: value}, value])),
                                 **({"outputs": extra} if extra is not None else {})))
    elif api == "sensitivity":
        calm(lambda: kinem.sensitivity(model, data.draw(st.sampled_from([[key], key, value, [key, value]])),
                                       **({"outputs": extra} if extra is not None else {})))
    elif api == "tolerance":
        calm(lambda: tolerance(model, data.draw(st.sampled_from([{key: value}, value, None])),
                               samples=samples_of(data.draw), seed=data.draw(st.one_of(VALUES, st.integers(0, 9))),
                               outputs=extra))
    elif api == "sweep":
        if isinstance(value, list) and len(value) > 3:
            value = value[:3]
        calm(lambda: kinem.sweep(base, data.draw(st.sampled_from([{key: value}, value])), outputs=extra))
    else:
        calm(lambda: kinem.load(base, parameters=data.draw(st.sampled_from([{key: value}, value]))))


# -- what the campaign found (each an internal error or another exception before its fix) ------------

@pytest.mark.parametrize("args", [
    ["tolerance", str(FOUR_BAR), "--samples", "-1"],                       # ValueError: negative dimensions
    ["tolerance", str(FOUR_BAR), "--samples", "9" * 20],                   # ValueError: maximum dimension
    ["tolerance", str(FOUR_BAR), "--seed", "-1"],                          # ValueError: non-negative integer
    ["sweep", str(NAMED), "--set", "crank=inf:1:2"],                       # numpy's RuntimeWarning lines
    ["sweep", str(NAMED), "--set", "crank=1e400:1:2"],
    ["sweep", str(NAMED), "--set", "crank=1e308:-1e308:3"],
])
def test_found_command_lines(tmp_path, args):
    """Exit 2, one line (a Python warning counts as a fault here: the command line prints it to standard error
    as lines of its own: numpy's RuntimeWarning for a sweep's ends beyond a float)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, err = run_main([*args, "--out", str(tmp_path / "o.csv")])
    assert code == 2 and err.startswith("kinem: error: --"), err
    assert not (tmp_path / "o.csv").exists()


def test_found_a_body_key_that_is_a_list_beside_a_point_name(tmp_path):
    """A mutated quick_return_3 (seed 2301 of the random profile): a revolute-revolute's body key i given a
    list, its si a point's name: TypeError (unhashable) in the point's lookup, exit 3. Now the body's one
    problem, exit 2; an unknown body's name beside a point's name is that one problem too (no second one
    for the point, whose body it cannot be on)."""
    text = (ROOT / "cases" / "quick_return_3.toml").read_text()
    case = tmp_path / "case.toml"
    for body in ("[0.0, 1e-300]", '"nope"', "3"):
        case.write_text(text.replace('i = "rocker"\nsi = "B"', f'i = {body}\nsi = "B"', 1))
        assert f"i = {body}" in case.read_text()
        code, err = run_main(["info", str(case), "--errors", "all"])
        assert code == 2 and "key 'i': unknown body" in err and "key 'si'" not in err, err


def test_found_a_warning_beside_exit_0(tmp_path):
    """A driver 1e5 times faster than the output step is valid: exit 0 with one warning line (the fuzz
    test's random profile had read it as a broken contract)."""
    text = (ROOT / "cases" / "slider_crank.toml").read_text()
    case = tmp_path / "case.toml"
    case.write_text(text.replace("d = { poly = [5.76, -1.2] }", "d = { poly = [5.76, -1.2e5] }"))
    assert "-1.2e5" in case.read_text()
    code, err = run_main(["info", str(case)])
    assert code == 0 and err == ""


@pytest.mark.parametrize("call", [
    lambda m: kinem.solve(m, parameters={"points.A.at.0": 10 ** 400}),        # OverflowError
    lambda m: kinem.solve(m, parameters={"points.A.at.0": [True, False]}),    # booleans taken as 1.0 and 0.0
    lambda m: kinem.solve(m, parameters={"points.A.at.0": [0.05]}, outputs=3),   # TypeError: not iterable
    lambda m: kinem.sensitivity(m, 3),                                        # TypeError: not iterable
    lambda m: kinem.sensitivity(m, None),
    lambda m: kinem.sensitivity(m, [["points.A.at.0"]]),                      # TypeError: unhashable
    lambda m: tolerance(m, 1e-4),                                             # TypeError: not iterable
    lambda m: tolerance(m, "points.A.at.0"),                                  # ValueError: dict update
    lambda m: tolerance(m, samples=-1),                                       # ValueError: negative dimensions
    lambda m: tolerance(m, samples=10 ** 20),                                 # ValueError: maximum dimension
    lambda m: tolerance(m, samples=2.5),                                      # TypeError
    lambda m: tolerance(m, samples=None),
    lambda m: tolerance(m, samples=2, seed=-1),                               # ValueError: non-negative
    lambda m: tolerance(m, samples=2, seed=math.nan),                         # TypeError
    lambda m: tolerance(m, samples=2, outputs=3),                             # TypeError: not iterable
    lambda m: tolerance(m, samples=2, outputs=[["B.x"]]),                     # TypeError: unhashable
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": "x"}),                  # ValueError: float('x')
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": [1, [2]]}),             # ValueError: ragged
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": 10 ** 400}),            # OverflowError
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": {}}),                   # TypeError
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": [True]}),               # a boolean taken as 1.0
    lambda m: kinem.sweep(FOUR_BAR, [0.05]),                                  # TypeError: list indices
    lambda m: kinem.sweep(FOUR_BAR, None),                                    # TypeError: not iterable
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": [0.05]}, outputs=3),    # TypeError: not iterable
    lambda m: kinem.sweep(FOUR_BAR, {"points.A.at.0": [0.05]}, outputs=[["B.x"]]),   # TypeError: unhashable
    lambda m: kinem.load(FOUR_BAR, parameters=1.5),                           # TypeError: not iterable
    lambda m: kinem.load(FOUR_BAR, parameters="points.A.at.0"),               # ValueError: dict update
])
def test_found_api_calls(models, call):
    with pytest.raises(kinem.InputError) as e:
        call(models[FOUR_BAR])
    assert "\n" not in str(e.value)


# -- session 25 (docs/benchmarks.md, "Fuzz campaign, session 25"): what a user or a bad script gives the
# design commands beyond a crash: duplicated names, a misleading place, an output refused only after the
# work, a tolerance table's misspelt key, bounds, and the two leftovers of session 24 -----------------------

STEPS3 = ["--steps", "3"]


@pytest.mark.parametrize("args, said", [
    # a parameter set twice: the later value won unseen (kinem sweep refused it)
    (["solve", str(NAMED), *STEPS3, "--set", "crank=0.1", "--set", "crank=0.12"], "'crank' given twice"),
    (["info", str(NAMED), "--parameters", "--set", "points.A.at.0=0.1", "--set", "points.A.at.0=0.2"],
     "'points.A.at.0' given twice"),
    # a named dimension by its name and by its path: the later won (sweep and solve(parameters=) refused it)
    (["solve", str(NAMED), *STEPS3, "--set", "crank=0.1", "--set", "parameters.crank=0.12"],
     "'crank' and 'parameters.crank' are one parameter"),
    (["info", str(NAMED), "--set", "parameters.crank=0.1", "--set", "crank=0.12"],
     "'parameters.crank' and 'crank' are one parameter"),
    # #N of a named constraint: "does not shape the mechanism", of a key that does
    (["sensitivity", str(FOUR_BAR), "--parameters", "constraints.#3.sj.0", *STEPS3],
     "constraint #3 is named 'A': its paths begin constraints.A; did you mean 'constraints.A.sj.0'?"),
    (["solve", str(FOUR_BAR), *STEPS3, "--set", "constraints.#4.si.0=0.15"], "did you mean 'constraints.B.si.0'?"),
    # a misspelt bare name: no did-you-mean where --set gave one
    (["sensitivity", str(NAMED), "--parameters", "crnk", *STEPS3], "unknown parameter; did you mean 'crank'?"),
    # --outputs '' (an unset shell variable) meant every point's x and y; sweep refused it
    (["tolerance", str(FOUR_BAR), "--samples", "2", *STEPS3, "--outputs", ""], "none given"),
    (["tolerance", str(FOUR_BAR), "--samples", "2", *STEPS3, "--outputs", ","], "none given"),
    (["tolerance", str(FOUR_BAR), "--samples", "2", *STEPS3, "--outputs", "b.x"], "did you mean 'B.x'?"),
    # COUNT 1 between two ends: START alone, STOP dropped unseen
    (["sweep", str(NAMED), "--set", "crank=0.1:0.12:1", "--outputs", "B.x"], "COUNT 1 takes START alone"),
    # a CSV table written under .npz
    (["sweep", str(NAMED), "--set", "crank=0.1,0.11", "--outputs", "B.x", "--out", "{tmp}/s.npz"],
     "writes a CSV table; expected a .csv file name"),
    # part 4's leftovers: --timeout below the watchdog's look, or no bound; report --engines '' was native alone
    (["compare", str(FOUR_BAR), "--scheduler", "tcp://127.0.0.1:1", "--timeout", "1e-300"], "--timeout: got 1e-300"),
    (["compare", str(FOUR_BAR), "--scheduler", "tcp://127.0.0.1:1", "--timeout", "inf"], "--timeout: got inf"),
    (["report", str(FOUR_BAR), "--scheduler", "tcp://127.0.0.1:1", "--timeout", "0.5"], "--timeout: got 0.5"),
    (["stress", "--scheduler", "tcp://127.0.0.1:1", "--timeout", "1e8"], "from 1 to 1e+07"),
    (["report", str(FOUR_BAR), "--engines", "", "--out", "{tmp}/r", "--baseline", "none"], "--engines: got ''"),
    (["report", str(FOUR_BAR), "--engines", ",", "--out", "{tmp}/r", "--baseline", "none"], "--engines: got ','"),
])
def test_found_session_25_command_lines(tmp_path, monkeypatch, args, said):
    """Each ran (exit 0, or a misleading reason) before its fix: now exit 2, one line saying why, nothing written."""
    from kinem import parallel

    monkeypatch.setattr(parallel, "RUN_TIMEOUT", parallel.RUN_TIMEOUT)   # --timeout sets it while parsing
    code, line = run_main([a.replace("{tmp}", str(tmp_path)) for a in args])
    assert code == 2 and said in line, line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command", ["sweep", "tolerance", "sensitivity"])
@pytest.mark.parametrize("kind", ["read-only", "missing-directory", "directory", "trailing-slash", "link-to-read-only"])
def test_found_a_bad_out_refused_before_the_work(tmp_path, monkeypatch, command, kind):
    """kinem sweep and tolerance found a read-only (or otherwise bad) --out only when writing, after every
    variant or sample was solved (3,000 variants: 2.8 s, 20,000 samples: 8.3 s, then exit 1); now refused
    before the case is read, as kinem solve refuses it. The work is never reached here."""
    import importlib

    def reached(*args, **kwargs):
        raise AssertionError("the work began before the output was checked")

    monkeypatch.setattr(importlib.import_module(f"kinem.{command}"), command, reached)   # the module, not kinem's name
    out = tmp_path / "o.csv"
    if kind in ("read-only", "link-to-read-only"):
        target = tmp_path / "old.csv"
        target.write_text("old\n")
        target.chmod(0o444)
        if kind == "read-only":
            out = target
        else:
            out.symlink_to(target)
    elif kind == "missing-directory":
        out = tmp_path / "nope" / "o.csv"
    elif kind == "directory":
        out = tmp_path
    else:
        out = f"{out}/"
    args = {"sweep": ["--set", "crank=0.1,0.11"], "tolerance": ["--samples", "2"],
            "sensitivity": ["--parameters", "crank"]}[command]
    case = str(NAMED if command != "tolerance" else FOUR_BAR)
    code, line = run_main([command, case, *args, "--out", str(out)])
    assert code == (1 if "read-only" in kind else 2) and "cannot write" in line, line
    if "read-only" in kind:
        assert (tmp_path / "old.csv").read_text() == "old\n"


def test_found_no_monte_carlo_band_is_not_said_to_hold(tmp_path):
    """--samples 0 (no Monte Carlo band) and samples that all fail printed, per output, "the Monte Carlo
    band leaves the worst-case linear band by at most 0": a band that does not exist, said to hold. Now
    no such line; the rejected samples' line says why there is none."""
    code, err = run_main(["tolerance", str(FOUR_BAR), "--samples", "0", *STEPS3, "--outputs", "B.x",
                          "--out", str(tmp_path / "o.csv")])
    assert code == 0 and err == ""
    case = tmp_path / "case.toml"   # a driver's rate toleranced by 1e6 rad/s: no sample assembles
    case.write_text(FOUR_BAR.read_text().replace('"points.A.at.0" = 0.0001',
                                                 '"constraints.crank-drive.d.poly.1" = 1e6'))
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        assert main(["tolerance", str(case), "--samples", "3", *STEPS3, "--outputs", "B.x",
                     "--out", str(tmp_path / "o.csv")]) == 0
    assert "leaves the worst-case" not in buf.getvalue() and "3 of 3 samples" in buf.getvalue(), buf.getvalue()


def test_found_an_excess_line_per_output_even_at_zero(tmp_path):
    """kinem tolerance printed "the Monte Carlo band leaves the worst-case linear band by at most 0" for every
    output, the ground points' included (session 28's part 10 left it). Now a line per output whose band is left,
    and one line counting those that stay within."""
    case = tmp_path / "case.toml"   # A's position by +-10 mm: the Monte Carlo band leaves the linear one at B.x
    text = FOUR_BAR.read_text()
    case.write_text(text[:text.index("[tolerances]")] + '[tolerances]\n"points.A.at.0" = 0.01\n')
    for path, outputs, said in ((case, "O2.x,O2.y,B.x", ["B.x: the Monte Carlo band leaves the worst-case linear "
                                                         "band by at most ", "kinem: the Monte Carlo band stays "
                                                         "within the worst-case linear band for the other 2 "
                                                         "outputs"]),
                                (FOUR_BAR, "O2.x", ["kinem: the Monte Carlo band stays within the worst-case linear "
                                                    "band for 1 output"])):
        buf = io.StringIO()
        with contextlib.redirect_stderr(buf):
            assert main(["tolerance", str(path), "--samples", "20", "--steps", "20", "--outputs", outputs,
                         "--out", str(tmp_path / "o.csv")]) == 0
        lines = buf.getvalue().splitlines()
        assert len(lines) == len(said) and all(line.startswith(s) for line, s in zip(lines, said)), lines
        assert lines[-1] == said[-1], lines


@pytest.mark.parametrize("tolerances, said", [
    ({"points.A.at.0": {"pm": 1e-4, "sgima": 3e-5}}, "key 'sgima': unknown key; did you mean 'sigma'?"),  # uniform, unseen
    ({"points.A.at.0": {"pm": 1e-4, 3: 1}}, "key 3: unknown key; expected pm and sigma"),
    ({"constraints.crank-drive.d.poly.0": 1e300}, "got 1e+300"),        # numpy's overflow warnings, bands inf
    ({"constraints.crank-drive.d.poly.1": 1e13}, "at most 1e+12"),
    ({"points.A.at.0": {"pm": 1e-4, "sigma": 1e300}}, "sigma 1e+300"),
])
def test_found_tolerance_tables(models, tolerances, said):
    """A tolerance table given to the API: a misspelt key was ignored (the case file refuses it); a tolerance
    beyond a case file's numbers (1e12) gave numpy's overflow warnings (a line each on the command line)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(kinem.InputError) as e:
            tolerance(models[FOUR_BAR], tolerances, samples=2)
    assert said in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_found_api_calls_of_session_25(models):
    """kinem.sensitivity and tolerance given a Case (not a Model): AttributeError; a named dimension by its
    name and by its path in kinem.load(parameters=): the later won; an output asked twice: its bands twice."""
    case = kinem.load(FOUR_BAR)
    for call in (lambda: kinem.sensitivity(case, ["points.A.at.0"]), lambda: tolerance(case, samples=2),
                 lambda: kinem.sensitivity(None, ["points.A.at.0"])):
        with pytest.raises(kinem.InputError, match="expected a kinem.Model"):
            call()
    with pytest.raises(kinem.InputError, match="are one parameter"):
        kinem.load(NAMED, parameters={"crank": 0.1, "parameters.crank": 0.12})
    b = tolerance(models[FOUR_BAR], samples=2, outputs=["B.x", "B.x"])
    assert b.outputs == ("B.x",) and len(set(b.table.columns)) == len(b.table.columns) == 7
    with pytest.raises(kinem.InputError, match="none given"):
        tolerance(models[FOUR_BAR], samples=2, outputs=[])


PMS = st.one_of(st.floats(), st.sampled_from([0.0, -0.0, 5e-324, 1e-300, 1e-4, 0.05, 0.19, 0.2, 1.0, 3.0, 1e12,
                                              1e13, 10 ** 400, True]))


@budget(40)
@given(table=st.dictionaries(st.sampled_from(["points.A.at.0", "points.B.at.0", "constraints.B.si.0",
                                              "constraints.crank-drive.d.poly.0", "constraints.crank-drive.d.poly.1",
                                              "points.O4.at.1", "crank", "points.A.at.O"]),
                             st.one_of(PMS, st.fixed_dictionaries({"pm": PMS}, optional={
                                 "sigma": PMS, "sgima": PMS, "PM": PMS})), max_size=3),
       samples=st.integers(0, 3), seed=st.integers(0, 2 ** 70))
def test_api_tolerance_tables(models, table, samples, seed):
    """Any tolerance table (huge, tiny, negative zero, NaN, a tolerance larger than a link, keys misspelt):
    bands without a Python warning (each a line of its own on the command line) or one InputError; where
    no sample is in the Monte Carlo band its columns are NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            b = tolerance(models[FOUR_BAR], table, samples=samples, seed=seed, outputs=["B.x"])
        except kinem.InputError as e:
            assert "\n" not in str(e) and len(str(e)) <= 4 * MAX_LINE
            return
    assert b.accepted == samples - len(b.rejected) >= 0
    assert np.isnan(b["B.x.mc+"]).all() == (b.accepted == 0)


def test_found_the_report_says_there_is_no_band(tmp_path, monkeypatch):
    """The report's design section said "Largest excess of the Monte Carlo band over the linear one: B.x: 0"
    where every sample was left out (no band); now it says there is none."""
    from kinem.report import design

    monkeypatch.setattr(design, "SAMPLES", 3)   # the report's 200, each left out: seconds
    _bands = design._bands

    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace('"points.A.at.0" = 0.0001', '"constraints.crank-drive.d.poly.1" = 1e6'))
    html = _bands(kinem.compile(kinem.load(case).with_time(steps=3)), ("B.x", "B.y"))[0]
    assert "No Monte Carlo band" in html and "Largest excess" not in html, html


@pytest.mark.parametrize("old, new, said", [
    ('sensitivity = ["points.A.at.0",', 'sensitivity = ["points.A.at.O",', "[report] sensitivity: parameter 'points.A.at.O'"),
    ('"points.B.at.0" = 0.0001', '"points.B.at.O" = 0.0001', "[tolerances]: parameter 'points.B.at.O'"),
])
def test_found_the_place_of_a_bad_path(tmp_path, old, new, said):
    """A bad path in [report] sensitivity or [tolerances] named the file and the path but not the section
    (the contract: the file, the place and the key)."""
    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace(old, new))
    assert new in case.read_text()
    code, line = run_main(["info", str(case)])
    assert code == 2 and f"{case}: {said}" in line, line


@pytest.mark.parametrize("args, said", [
    (["sweep", str(NAMED), "--set", "crank=0.09:0.11:100000"], "sweep: 100,000 variants x 251 instants x 60 columns"),
    (["sensitivity", str(FOUR_BAR), "--parameters", "points.A.at.0,points.B.at.0", "--steps", "10000000"],
     "sensitivity: 10,000,001 instants x 60 columns x 2 parameters"),
    (["tolerance", str(FOUR_BAR), "--samples", "10", "--steps", "2000000"], "sensitivity: 2,000,001 instants"),
])
def test_found_results_beyond_memory(tmp_path, args, said):
    """A sweep, sensitivities or tolerance bands whose table cannot be held in memory (a 100,000-variant sweep
    of every column: 11.2 GiB): numpy's MemoryError, exit 3, under a memory limit, or the machine's memory
    taken. Now refused before the work (kinem.budget.MAX_HELD, 2e8 numbers); kinem solve streams instead."""
    code, line = run_main([*args, "--out", str(tmp_path / "o.csv")])
    assert code == 2 and said in line and "numbers exceeds the 2e+08" in line, line
    assert not list(tmp_path.iterdir())


def test_found_variants_beyond_memory(models):
    """kinem.solve(model, parameters=) of 100,000 variants of every column: 11.2 GiB, refused before any."""
    with pytest.raises(kinem.InputError, match=r"100,000 variants x 4 instants x 60 columns = 2\.4e\+07") as e:
        from kinem import budget

        old, budget.MAX_HELD = budget.MAX_HELD, 1e7   # the same rule at a smaller scale: nothing allocated
        try:
            kinem.solve(models[FOUR_BAR], parameters={"points.A.at.0": np.linspace(0.049, 0.051, 100_000)})
        finally:
            budget.MAX_HELD = old
    assert "\n" not in str(e.value)


def test_tolerance_of_a_long_run_batches_within_memory(monkeypatch):
    """The Monte Carlo samples of a long run are solved in batches that fit the held bound: the same bands."""
    from kinem import budget

    m = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=20))
    whole = tolerance(m, samples=9, outputs=["B.x"], seed=3)
    import importlib

    monkeypatch.setattr(budget, "MAX_HELD", 21 * 4)   # 4 samples a batch: the checks of the nominal's tables off
    for module in (budget, importlib.import_module("kinem.sensitivity")):
        monkeypatch.setattr(module, "check_held", lambda *args: None)
    parts = tolerance(m, samples=9, outputs=["B.x"], seed=3)
    assert np.array_equal(whole.table.data, parts.table.data, equal_nan=True) and parts.rejected == whole.rejected


def test_found_a_singular_nominal_is_said(tmp_path):
    """kinem tolerance of a case whose Phi_q is singular at an instant (the stress suite's change point):
    its linear bands are inf there, said by nothing (kinem sensitivity warns); now the same warning line."""
    case = tmp_path / "case.toml"
    case.write_text((ROOT / "cases" / "stress" / "change_point.toml").read_text()
                    + '\n[tolerances]\n"points.A.at.0" = 0.001\n')
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        assert main(["tolerance", str(case), "--samples", "2", "--outputs", "B.x",
                     "--out", str(tmp_path / "o.csv")]) == 0
    assert f"kinem: warning: {case}: Phi_q singular" in buf.getvalue(), buf.getvalue()
    assert "the linear bands with them" in buf.getvalue()
    assert tolerance(kinem.compile(kinem.load(case)), samples=0).singular.startswith("Phi_q singular")


@pytest.mark.parametrize("degrees", [False, True])
def test_found_a_fast_drivers_warning_once(tmp_path, monkeypatch, degrees):
    """kinem tolerance of a case with a fast driver (valid, warned at its loading) printed the warning a
    second time as Python's two lines ("tolerance.py:254: KinemWarning: ..." and the source line): the
    nominal's branch pinned is a case loaded again; in degrees, on the merged path (chunk 1: a forked
    worker's), every sample's case is validated again (kinem.moved.cases_of) and warned too. Now once."""
    import importlib

    text = FOUR_BAR.read_text().replace("d = { poly = [0.7853981633974483, 1.5, -0.6] }",
                                        "d = { poly = [0.7853981633974483, 300.0, 0.0] }")
    if degrees:
        module = importlib.import_module("kinem.tolerance")
        real = module.tolerance
        monkeypatch.setattr(module, "tolerance", lambda *a, **k: real(*a, **{**k, "chunk": 1}))
        text = (text.replace('units = { length = "m" }', 'units = { length = "m", angle = "deg" }')
                .replace("0.7853981633974483, 300.0, 0.0", "45.0, 17188.733853924696, 0.0")
                .replace("0.785] }", "45.0] }").replace("0.27] }", "15.5] }").replace("0.76] }", "43.5] }"))
    case = tmp_path / "case.toml"
    case.write_text(text)
    assert ("17188" if degrees else "300.0") in case.read_text()
    with warnings.catch_warnings(record=True) as leaked:   # past the command line's own printing of them
        warnings.simplefilter("always")
        code, _ = run_main(["tolerance", str(case), "--samples", "3", "--steps", "20", "--outputs", "B.x",
                            "--out", str(tmp_path / "o.csv")], notes=True)
    assert code == 0 and not [str(w.message) for w in leaked if issubclass(w.category, kinem.KinemWarning)]


# -- session 25, part 6 (docs/benchmarks.md, "Fuzz campaign, session 25", "Part 6"): what part 5 left ------

def test_found_a_named_dimension_no_number_uses(tmp_path):
    """A [parameters] name that no number of the file uses was accepted without a word: its derivatives 0,
    every variant of it the nominal (a name misspelt where it is meant, or left over). Now refused as an
    unknown key is, naming it; a name detached from its one number by a value set at that number's path
    (a variant, kinem.parameters.apply) is not the file's and stays accepted."""
    case = tmp_path / "case.toml"
    case.write_text(NAMED.read_text().replace("ground = 0.2 ", "ground = 0.2\nspare = 0.5 ", 1))
    assert "spare = 0.5" in case.read_text()
    for command in (["info", str(case)], ["sensitivity", str(case), "--parameters", "spare", *STEPS3],
                    ["sweep", str(case), "--set", "spare=0.4,0.6", "--outputs", "B.x"]):
        code, line = run_main([*command, "--out", str(tmp_path / "o.csv")] if command[0] != "info" else command)
        assert code == 2 and f"{case}: [parameters]: key 'spare': used by no number of the case" in line, line
    assert not (tmp_path / "o.csv").exists()
    variant = kinem.load(NAMED, parameters={"points.A.at.0": 0.11})   # crank's one number, set by its path
    assert "crank" not in variant.uses and variant.points[2].at[0] == 0.11
    b = tolerance(kinem.compile(variant.with_time(steps=3)), {"points.B.at.0": 1e-4}, samples=2, outputs=["B.x"])
    assert b.accepted == 2


@pytest.mark.parametrize("call, said", [
    (lambda m, tmp: kinem.sweep(NAMED, {"crank": [0.1]}, outputs=["B.x"], progress=3),      # AttributeError
     "sweep: progress 3: expected None or a progress bar"),
    (lambda m, tmp: kinem.sweep(NAMED, {"crank": [0.1]}, outputs=["B.x"], progress=True),
     "sweep: progress True: expected None or a progress bar"),
    (lambda m, tmp: tolerance(m, samples=2, progress=3),           # TypeError, after the first samples were solved
     "tolerance: progress 3: expected None or a function progress(done, total)"),
    (lambda m, tmp: kinem.animate(kinem.solve(m), tmp / "x.svg", progress="yes"),   # a text taken as True
     "animate: progress = 'yes': expected True, False or None"),
])
def test_found_a_progress_of_the_wrong_type(models, tmp_path, call, said):
    """kinem.sweep(..., progress=3): AttributeError ('int' object has no attribute 'total'); kinem.tolerance's
    progress=3 a TypeError after the first batch; animate took any value as a flag. Now an InputError naming
    the argument and what it expects, before any work."""
    with pytest.raises(kinem.InputError) as e:
        call(models[FOUR_BAR], tmp_path)
    assert said in str(e.value) and "\n" not in str(e.value), str(e.value)
    assert not list(tmp_path.iterdir())
    assert kinem.sweep(NAMED, {"crank": [0.1]}, outputs=["B.x"], progress=False).data.shape[0] == 1


def test_found_a_scalar_variant_value_says_how(models):
    """kinem.solve(model, parameters={PATH: 0.1}): "expected a 1-D sequence of one or more finite numbers",
    not how to do it: now an array of N numbers (of the others' length when there are others), or
    kinem.load(..., parameters=) for one value, in one line."""
    m = models[FOUR_BAR]
    for given, said in (({"points.A.at.0": 0.1}, "an array of N numbers, one per variant (e.g. [0.1])"),
                        ({"points.A.at.0": 0.1, "points.B.at.0": [0.2, 0.21]}, "an array of 2 numbers"),
                        ({"points.A.at.0": np.float64(0.1)}, "got one number, 0.1")):
        with pytest.raises(kinem.InputError) as e:
            kinem.solve(m, parameters=given)
        text = str(e.value)
        assert said in text and "kinem.load(path, parameters={'points.A.at.0': 0.1})" in text, text
        assert "\n" not in text


@pytest.mark.parametrize("args, intervals", [([], 250), (["--steps", "20"], 20), (["--steps", "1000"], None),
                                             (["--end", "0.5"], None)])
def test_found_a_fast_drivers_warning_counts_what_is_solved(tmp_path, args, intervals):
    """The fast-driver warning counted the case file's output intervals (250), whatever --steps said: it
    warned of --steps 1000 (0.12 turns an interval: followed) and said 250 of --steps 20. Now it judges the
    case with --end and --steps applied."""
    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace("d = { poly = [0.7853981633974483, 1.5, -0.6] }",
                                                 "d = { poly = [0.7853981633974483, 300.0, 0.0] }"))
    assert "300.0" in case.read_text()
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        assert main(["solve", str(case), *args, "--out", str(tmp_path / "o.csv")]) == 0
    if intervals is None:
        assert buf.getvalue() == ""
    else:
        assert buf.getvalue().count("\n") == 1 and f"119 turns in 2.5 s, {intervals} output intervals" in buf.getvalue()


def test_found_an_excess_of_rounding_noise(models):
    """The excess of the Monte Carlo band over the linear one reported the last bits of the samples' solves
    (a tolerance too small to move anything: 1.4e-17 m on A.x of the four-bar, 9.1e-13 mm on A.x and 1e-25
    on A.y, a coordinate that stays 0, of the slider-crank). Now 0 below the noise of the band's figures:
    the Newton tolerance of their largest magnitude (a point's x and y together); a true excess stays."""
    slider = kinem.compile(kinem.load(ROOT / "cases" / "slider_crank.toml").with_time(steps=20))
    for m, path in ((models[FOUR_BAR], "points.A.at.0"), (slider, "constraints.O.si.0")):
        b = tolerance(m, {path: 1e-20}, samples=4)
        assert b.accepted == 4 and all(amount == 0 for _, amount, _ in b.excess), b.excess
    b = tolerance(models[FOUR_BAR], {"points.A.at.0": 1e-2}, samples=20, outputs=["B.x"])
    assert b.excess[0][1] > 1e-5, b.excess


# -- session 26, part 7 (docs/benchmarks.md, "Fuzz campaign, session 26"): what part 6 left -----------------

GEARS = ROOT / "cases" / "gear_pair.toml"


@pytest.mark.parametrize("case, tolerances, said", [
    (FOUR_BAR, {"constraints.crank-drive.d.poly.0": 1e6}, "+-1e+06 rad is not smaller than half a turn (3.14159 rad)"),
    (FOUR_BAR, {"constraints.crank-drive.d.poly.0": math.pi}, "is not smaller than half a turn"),
    (GEARS, {"constraints.mesh.phi0": {"pm": 4.0, "sigma": 0.1}}, "+-4 rad is not smaller than half a turn"),
])
def test_found_an_angle_tolerance_of_a_turn(case, tolerances, said):
    """A tolerance of 1e6 rad on a driver's phase or a gear's angle was accepted (the bound was a case file
    number's, 1e12): every angle is within +-half a turn of any other, so a tolerance of half a turn or more
    is no manufacturing tolerance. Now refused naming the key, in the API and in the case file."""
    m = kinem.compile(kinem.load(case).with_time(steps=3))
    outputs = ["B.x"] if case == FOUR_BAR else ["gear2.phi"]
    with pytest.raises(kinem.InputError) as e:
        tolerance(m, tolerances, samples=2, outputs=outputs)
    text = str(e.value)
    assert said in text and f"[tolerances]: key '{next(iter(tolerances))}'" in text and "\n" not in text, text
    path = next(iter(tolerances))
    assert tolerance(m, {path: 0.01}, samples=2, outputs=outputs).accepted == 2   # a small one: bands as before


def test_found_a_tolerance_of_a_case_without_points(tmp_path):
    """kinem tolerance of a case with no named points (cases/gear_pair.toml with a [tolerances] table) and no
    --outputs: "internal error: ValueError: need at least one array to stack", exit 3 (its default outputs,
    every point's x and y, were none). Now one line asking for --outputs; with them, the bands."""
    case = tmp_path / "case.toml"
    case.write_text(GEARS.read_text() + '\n[tolerances]\n"constraints.mesh.ri" = 0.01\n')
    code, line = run_main(["tolerance", str(case), "--samples", "2", *STEPS3])
    assert code == 2 and "the case has no named points, the default outputs; expected outputs (--outputs)" in line
    code, line = run_main(["tolerance", str(case), "--samples", "2", *STEPS3, "--outputs", "gear2.phi",
                           "--out", str(tmp_path / "o.csv")], notes=True)
    assert code == 0 and (tmp_path / "o.csv").exists(), line


def test_found_an_angle_tolerance_of_a_turn_in_the_file(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace('"points.A.at.0" = 0.0001 ',
                                                 '"constraints.crank-drive.d.poly.0" = 1e6\n"points.A.at.0" = 0.0001 ', 1))
    assert "1e6" in case.read_text()
    code, line = run_main(["info", str(case)])
    assert code == 2 and "[tolerances]: key 'constraints.crank-drive.d.poly.0': +-1e+06 rad is not smaller " \
                         "than half a turn" in line, line
    degrees = tmp_path / "deg.toml"   # in degrees: half a turn is 180
    degrees.write_text(GEARS.read_text().replace('units = { length = "mm" }', 'units = { length = "mm", angle = "deg" }')
                       + '\n[tolerances]\n"constraints.motor.d.poly.0" = 200.0\n')
    code, line = run_main(["info", str(degrees)])
    assert code == 2 and "+-200 deg is not smaller than half a turn (180 deg)" in line, line


@pytest.mark.parametrize("value, ok", [("infinity", False), ("Infinity", False), ("NaN", False), ("1__0", False),
                                       (".1", False), ("1.", False), ("01", False), ("\u0661", False), ("1e-1", True),
                                       ("0.1", True), ("1_0e-2", True), ("+0.1", True)])
def test_found_sweep_values_read_as_python_reads_them(tmp_path, value, ok):
    """kinem sweep's --set values were read with Python's float: 'infinity', '1__0'-like texts and digits of
    other scripts ('\u0661', Arabic-Indic one) were numbers where a case file refuses them. Now read as a case
    file's TOML reads its numbers (1_0e-2, +0.1 and 1e-1 too), the rest refused in one line."""
    out = tmp_path / "o.csv"
    for text in (f"crank={value}", f"crank={value},0.1", f"crank={value}:0.11:2"):
        code, line = run_main(["sweep", str(NAMED), "--set", text, "--outputs", "B.x", "--out", str(out)])
        if ok:
            assert code == 0, line
        else:
            assert code == 2 and "numbers as a case file writes them, TOML: 0.5" in line, line
    code, line = run_main(["sweep", str(NAMED), "--set", "crank=0.1:0.11:2.0", "--outputs", "B.x", "--out", str(out)])
    assert code == 2 and "COUNT a whole number" in line, line


@pytest.mark.parametrize("value", ["infinity", ".1", "1__0", "\u0661"])
def test_found_set_values_read_as_python_reads_them(tmp_path, value):
    """The same of solve's and info's --set (kinem.casefile.checks.number): 'infinity' reached the key's
    range check as inf, '.1' was 0.1, '\u0661' 1."""
    code, line = run_main(["info", str(NAMED), "--set", f"crank={value}"])
    assert code == 2 and "expected a number as a case file writes it (TOML: 0.5" in line, line


@pytest.mark.parametrize("args", [["solve", str(FOUR_BAR), "--max-seconds"], ["solve", str(FOUR_BAR), "--max-work"],
                                  ["compare", str(FOUR_BAR), "--engines", "pymunk", "--dt"],
                                  ["compare", str(FOUR_BAR), "--scheduler", "tcp://127.0.0.1:1", "--timeout"]])
@pytest.mark.parametrize("value", ["infinity", ".1", "1__0", "nan", "\u0661"])
def test_found_number_options_read_as_python_reads_them(tmp_path, args, value):
    """Left by part 7: --dt, --timeout, --max-seconds and --max-work were read with Python's float
    ('infinity' was inf, '1__0'-like texts and '\u0661' numbers, '.1' 0.1). Now read as --end, --steps
    and --set read theirs, a case file's TOML numbers, before anything runs (one line, exit 2)."""
    code, line = run_main([*args, value] + (["--out", str(tmp_path / "o.csv")] if args[0] == "solve" else []))
    assert code == 2 and f"argument {args[-1]}: got {value!r}; expected a number as a case file writes it" in line, line
    assert not list(tmp_path.iterdir())


def test_number_options_take_a_case_files_numbers(tmp_path):
    """1_000 and 1e-3 are numbers there as in a case file (the parser's values, nothing run); a whole
    number beyond a float is infinity, which --max-work's range refuses (exit 2, not an OverflowError)."""
    from kinem.cli.parser import number_option

    assert [number_option(x) for x in ("1_000", "1e-3", "inf", "+2", "1" + "0" * 400)] == [1000.0, 1e-3, math.inf,
                                                                                         2.0, math.inf]
    code, line = run_main(["solve", str(FOUR_BAR), "--max-work", "1" + "0" * 400, "--out", str(tmp_path / "o.csv")])
    assert code == 2 and "--max-work" in line and "internal" not in line, line


def test_found_report_sensitivity_repeats_counted(tmp_path):
    """Left by part 7: [report] sensitivity counted its paths before dropping repeats, so nine copies of one
    path were refused as more than 8 while two copies were one. Now the distinct paths count; nine distinct
    ones are still refused."""
    line = '["points.A.at.0", "constraints.B.si.0", "points.O4.at.0"]'
    text = FOUR_BAR.read_text()
    assert text.count(line) == 1
    case = tmp_path / "case.toml"
    case.write_text(text.replace(line, "[" + ", ".join(['"points.A.at.0"'] * 9) + "]"))
    assert kinem.load(case).report["sensitivity"] == ("points.A.at.0",)
    nine = [f'"points.{p}.at.{i}"' for p in ("A", "B", "O2", "O4") for i in (0, 1)] + ['"constraints.B.si.0"']
    case.write_text(text.replace(line, "[" + ", ".join(nine) + "]"))
    code, said = run_main(["info", str(case)])
    assert code == 2 and "a list of 1 to 8 design parameter paths" in said, said


def test_found_a_report_progress_of_the_wrong_type(tmp_path):
    """kinem.report.run(Options(progress=3)) ran: Progress took any value as its flag (the other calls'
    progress= are checked since part 6). Now refused before any case is read or run."""
    from kinem.report import Options, run

    for bad in (3, "yes", [True]):
        with pytest.raises(kinem.InputError) as e:
            run(Options(cases=("no such case.toml",), engines=(), out=str(tmp_path / "r"), progress=bad))
        assert f"report: Options(progress={bad!r}): expected True, False or None" in str(e.value), str(e.value)
    assert not list(tmp_path.iterdir())


def test_found_a_name_used_only_by_a_mass(tmp_path):
    """A [parameters] name used only by numbers no constraint reads (a body's mass, estimate) was a design
    parameter: sensitivity 0, every sweep variant the nominal, a tolerance band of width 0. The issue:
    "a parameter that no constraint reads is refused with a message naming it": the name, like the mass's
    own path, is now refused as a design parameter (the case file itself stays valid: its mass is used)."""
    case = tmp_path / "case.toml"
    case.write_text(NAMED.read_text().replace("ground = 0.2 ", "ground = 0.2\nm = 2.0 ", 1)
                    .replace("crank   = { q = [0.0, 0.0, 0.785] }", 'crank   = { q = [0.0, 0.0, 0.785], mass = "m" }'))
    assert 'mass = "m"' in case.read_text()
    assert run_main(["info", str(case)])[0] == 0
    said = "named dimension m is used only by bodies.crank.mass, which no constraint reads: not a design parameter"
    for command in (["info", str(case), "--set", "m=3"],
                    ["sensitivity", str(case), "--parameters", "m", *STEPS3],
                    ["sweep", str(case), "--set", "m=1,3", "--outputs", "B.x"],
                    ["tolerance", str(case), "--samples", "2", *STEPS3]):
        if command[0] == "tolerance":
            case.write_text(case.read_text() + '\n[tolerances]\nm = 0.1\n')
        out = [] if command[0] == "info" else ["--out", str(tmp_path / "o.csv")]
        code, line = run_main([*command, *out])
        assert code == 2 and said in line, line
    assert not (tmp_path / "o.csv").exists()
    from kinem.parameters import parameters

    listed = [p.path for p in parameters(kinem.load(NAMED))]
    assert "parameters.crank" in listed   # names a constraint's number reads: as before


# -- session 27, part 9 (docs/benchmarks.md, "Fuzz campaign, session 27"): what part 7 left ----------------

def _compare(args):
    """kinem compare in-process: (exit code, standard output, standard error); compare prints its table
    with exit 1 (a failed run), so tests/test_fuzz.run_main's one line does not apply."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compare", *args])
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("table, said", [
    ("dt = -1.0", "[engines.pymunk]: key 'dt': got -1.0; expected a positive number"),
    ("steps = 3", "[engines.pymunk]: key 'steps': unknown key; expected one of dt, "),
    ('dt = "fast"', "[engines.pymunk]: key 'dt': got 'fast'; expected"),
    ("dt = nan", "[engines.pymunk]: key 'dt': got nan; expected a finite number"),   # the loader's own check
])
def test_found_two_forms_of_an_engine_tables_place(tmp_path, table, said):
    """A case's [engines.NAME] setting the engine refused read "CASE [engines.pymunk]: pymunk setting 'dt' =
    -1.0: expected ...", where the loader writes "CASE: [engines.pymunk]: key 'dt': got ...; expected ...":
    two forms of one place. Now one, the loader's, whichever layer finds the problem."""
    from test_fuzz import SHORT

    case = tmp_path / "case.toml"
    case.write_text(SHORT + f"\n[engines.pymunk]\n{table}\n")
    for command in (["compare", str(case), "--engines", "native,pymunk"],
                    ["export", str(case), "--engine", "pymunk", "--out", str(tmp_path / "m.py")]):
        code, line = run_main(command)
        assert code == 2 and f"{case}: {said}" in line, line
    assert not (tmp_path / "m.py").exists()


@pytest.mark.parametrize("text", ["\\u0007", "\\u0000", "\\u202e", "\\u001b[31m", "\\u200b", "\\r", "\\u0085"])
def test_found_a_description_with_control_characters(tmp_path, text):
    """A case's description took any TOML string: a NUL, a BEL, an escape sequence, U+202E (a right-to-left
    override that reorders what the reader sees), shown as codes by the report, raw elsewhere (the API's
    Case.description). Names take letters, digits, '_' and '-' alone, units.length printable characters:
    now the description refuses control and invisible formatting characters, naming the key and the
    character (tab and newline, prose, stay)."""
    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace('description = "', f'description = "a b{text}', 1))
    assert text in case.read_text()
    code, line = run_main(["info", str(case)])
    code_point = {"\\r": "000D"}.get(text, text[2:6].upper())
    assert code == 2 and f"{case}: top level: key 'description': U+{code_point} at character 4; expected text " \
                         "without control or invisible formatting characters" in line, line
    with pytest.raises(kinem.InputError):
        kinem.load(case)


def test_a_description_keeps_tabs_newlines_and_other_scripts(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(FOUR_BAR.read_text().replace('description = "', 'description = "a\\tb\\nc\\u00a0d \\u00e9 \\u4e2d ',
                                                 1))
    assert kinem.load(case).description.startswith("a\tb\nc\u00a0d \u00e9 \u4e2d ")


@pytest.mark.parametrize("value", ["0", "-1", "inf", "1e400", "1e8"])
def test_found_compare_max_seconds_refused_as_solves(value):
    """kinem compare had no --max-seconds: a four-bar at 5,000,000 steps ran more than 120 s. Now the
    option kinem solve has, read by the same reader, with the same range and message (nothing run)."""
    code, line = run_main(["compare", str(FOUR_BAR), "--engines", "native", "--max-seconds", value])
    assert code == 2 and f"--max-seconds: got {float(value):g}; expected a number of seconds in (0, 1e+07]" in line, line


@pytest.mark.parametrize("given", [True, False])
def test_found_compare_without_a_time_limit(monkeypatch, given):
    """The same, run: a compare past its time limit (given, or the default: kinem solve's MAX_SECONDS, made
    small here) ends native's solve and says so in its table, exit 1 (the limit's words: no timing asserted)."""
    from kinem.cli import solve

    if not given:
        monkeypatch.setattr(solve, "MAX_SECONDS", 0.3)
    code, out, err = _compare([str(FOUR_BAR), "--engines", "native,pymunk", "--steps", "2000000",
                               *(["--max-seconds", "0.3"] if given else [])])
    assert code == 1 and err == "", err
    assert "the time limit of 0.3 s (Options.max_seconds, --max-seconds of kinem solve, compare and animate)" in out, out
    assert "pymunk   failed: no native reference" in out, out


def test_compare_sensitivity_within_a_time_limit():
    """--max-seconds holds for compare --sensitivity's native solves too (the exact sensitivities first: a limit
    of 1 ms, which loading the case alone exceeds, so that the nominal solve stops on every machine; at 0.3 s a
    fast machine finished it and the moved solves reported the limit in the table instead)."""
    code, out, err = _compare([str(FOUR_BAR), "--engines", "native", "--steps", "400000", "--sensitivity",
                               "points.A.at.0", "--max-seconds", "0.001"])
    assert code == 1 and "the time limit of 0.001 s" in err and err.count("\n") == 1, (out, err)



@pytest.mark.parametrize("value, code", [("0.001", 1), ("0", 2), ("inf", 2), ("1__0", 2)])
def test_found_animate_without_a_time_limit(tmp_path, value, code):
    """kinem animate had no time bound (part 9's "left": a case file of 2,000,000 steps solved for minutes): now
    its native solve stops after --max-seconds as solve's and compare's do (the same reader, range and message;
    exit 1 past it, nothing written; exit 2 for a bad value, before anything runs)."""
    case = tmp_path / "long.toml"
    case.write_text(FOUR_BAR.read_text().replace("steps = 250", "steps = 2000000"))
    out = tmp_path / "a.svg"
    got, line = run_main(["animate", str(case), "--out", str(out), "--engines", "native", "--max-seconds", value])
    assert got == code, line
    assert ("the time limit of 0.001 s" in line) if code == 1 else ("--max-seconds" in line and "expected" in line), line
    assert not out.exists()

# -- session 27, part 9, part B: the report's design section with hostile [report] sensitivity values -----------

@pytest.mark.parametrize("listed", [["crank"], ["crank", "parameters.crank"], ["parameters.crank", "crank", "coupler"]])
def test_found_report_sensitivity_by_a_name_drew_nothing(listed):
    """[report] sensitivity = ["crank"] (a name of [parameters], which the list accepts): the design section's
    table had its row, but its plot matched curves by the text as written against the parameter's path
    ("parameters.crank"): an empty panel and matplotlib's "No artists with labels found to put in legend"
    on the report's standard error (two lines of a Python warning); ["crank", "parameters.crank"], one
    parameter, had two panels, one empty. Now the plot takes the resolved paths: one panel a parameter,
    each with its curves, no warning."""
    from kinem.report import design

    text = NAMED.read_text().replace("steps = 250", "steps = 10")
    case = kinem.load_dict(tomllib.loads(text + "\n[report]\nsensitivity = [" + ", ".join(f'"{p}"' for p in listed)
                                        + "]\n"), source="named")
    drawn = []
    plot = design._sensitivity_plot
    design_plot = lambda t, paths, *a, **k: drawn.append(paths) or plot(t, paths, *a, **k)  # noqa: E731
    with warnings.catch_warnings(), pytest.MonkeyPatch.context() as mp:
        warnings.simplefilter("error")
        mp.setattr(design, "_sensitivity_plot", design_plot)
        parts = design.section(kinem.compile(case))
    assert drawn == [list(dict.fromkeys("parameters." + p.split(".")[-1] for p in listed))], drawn
    assert len(parts) == 2 and parts[0].count("<code>parameters.") == len(drawn[0]), parts[0][:300]


@pytest.mark.parametrize("rod, said", [("0.5", "not computed: native at p +- h: step to t = "),
                                       ("5.0", None)])
def test_found_report_sensitivity_past_an_assembly_limit(rod, said):
    """A slider-crank whose rod is 0.5 mm longer than its crank, [report] sensitivity = ["constraints.B.si.0"]:
    the design section's central differences move the rod 2h shorter than the crank, where the mechanism no
    longer assembles: the failed solves' partial trajectories met in "ValueError: operands could not be
    broadcast", kinem report's "internal error", exit 3, no report. Now the row says the differences were not
    computed and why. With the rod 5 mm longer (every solve ok) the column the parameter does not move (the
    slider's A.y, its exact derivative rounding, 2.2e-16) made "native differences" 1.0, 100 % of the
    peak: a column's peak below 1e-9 of the row's largest is rounding, not its scale."""
    import re

    from kinem.report import design

    text = (ROOT / "cases" / "slider_crank.toml").read_text().replace("steps = 500", "steps = 100")
    text = text.replace("si = [300.0, 0.0]", f"si = [{rod}, 0.0]", 1).replace(
        "[report]\n", '[report]\nsensitivity = ["constraints.B.si.0"]\n', 1)
    assert f"si = [{rod}, 0.0]" in text and "sensitivity" in text
    model = kinem.compile(kinem.load_dict(tomllib.loads(text), source="slider"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        table = re.sub("<[^>]*>", " ", design.section(model)[0])
    if said:
        assert said in table, table[-400:]
    else:
        assert float(table.split()[-1]) < 1e-3, table[-200:]


# -- session 28, part 10 (docs/benchmarks.md, "Fuzz campaign, session 28"): what part 9 left ----------------

ENGINES = ("pymunk", "mujoco", "exudyn")


@pytest.mark.parametrize("engine", ENGINES)
def test_found_compare_engines_past_the_time_limit(monkeypatch, engine):
    """compare --max-seconds bounded native's solves, not the engines' runs: a run of millions of steps went on
    far past it. Now each engine's run ends at the same limit (checked between output intervals; Exudyn's
    solver asks before each step), its row failed with the time limit's words, exit 1. Here the limit has
    passed when the engines begin (native's solve within it)."""
    import time

    from adapters import compare

    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    code, out, err = _compare([str(FOUR_BAR), "--engines", f"native,{engine}", "--steps", "40", "--max-seconds",
                               "30"])
    assert code == 1 and err == "", (out, err)
    row = next(line for line in out.splitlines() if line.startswith(engine))
    assert "failed: the time limit of 30 s (Options.max_seconds, --max-seconds of kinem solve, compare and animate) " \
           "is reached at t = 0" in row, out


@pytest.mark.parametrize("engine", ENGINES)
def test_an_engine_run_stops_at_its_time_limit(engine):
    """The same bound on a long run (a four-bar of 200,000 output instants, each engine's own settings): it
    ends failed, with its time-limit words and where it stopped (the limit's words: no timing asserted); no
    refinement or earlier attempt stands in for it (an earlier attempt that failed before the limit, pymunk's
    first on a quick machine since its tables are made window by window, is only told of in a note); without a
    limit the same call is bounded by nothing but its steps."""
    import time

    from adapters import get
    from adapters.base import Status

    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=200_000, end=2000.0))
    start = time.time()
    run = get(engine).run(model, limit=(0.5, start + 0.5))
    assert run.status is Status.OUT_OF_TIME and run.detail.startswith("the time limit of 0.5 s (Options.max_seconds") \
        and " is reached at t = " in run.detail, run.detail
    assert run.trajectory is None and all("attempt" in note for note in run.notes), run.notes


def test_compare_sensitivity_engines_past_the_time_limit(monkeypatch):
    """compare --sensitivity's engine runs (nominal and moved) end at the limit too: their rows say so, exit 1."""
    import time

    from adapters import compare

    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    code, out, err = _compare([str(FOUR_BAR), "--engines", "native,pymunk", "--steps", "40", "--sensitivity",
                               "points.A.at.0", "--max-seconds", "30"])
    assert code == 1 and err == "", (out, err)
    assert "nominal run: the time limit of 30 s" in out, out


def test_found_animate_engines_past_the_time_limit(tmp_path, monkeypatch):
    """animate --max-seconds bounded its native solve alone: an engine's run went on past it (and a run stopped
    would have been a ghost left out, the animation written). Now the engines' runs end at the limit as
    compare's do, and past it animate fails: exit 1, the engine and the limit named, nothing written."""
    import time

    from adapters import compare

    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    out = tmp_path / "a.svg"
    code, line = run_main(["animate", str(FOUR_BAR), "--out", str(out), "--engines", "native,pymunk",
                           "--max-seconds", "30"])
    assert code == 1 and f"{FOUR_BAR}: pymunk: the time limit of 30 s (Options.max_seconds, --max-seconds of kinem " \
                         "solve, compare and animate) is reached at t = 0" in line, line
    assert not out.exists()


EIGHT_IN_NINE = ["crank", "parameters.crank", "parameters.coupler", "parameters.rocker", "parameters.ground",
                 "points.O2.at.0", "points.O2.at.1", "constraints.O2.sj.0", "constraints.O2.sj.1"]


def _named_case(tmp_path, listed):
    case = tmp_path / "case.toml"
    case.write_text(NAMED.read_text().replace("steps = 250", "steps = 10") + "\n[report]\nsensitivity = ["
                    + ", ".join(f'"{p}"' for p in listed) + "]\n")
    return case


def test_found_report_sensitivity_counted_texts(tmp_path):
    """[report] sensitivity counted its distinct texts against its 8, not its parameters: "crank" and
    "parameters.crank" (one parameter, one row and one panel in the report) counted twice, so eight
    parameters written in nine texts were refused. A user means parameters: now the parameters count (the
    texts are bounded at twice that, the two ways to write one), the message says so, the report's table
    and plot have one row and one panel a parameter."""
    from kinem.parameters import resolve
    from kinem.report import design

    case = _named_case(tmp_path, EIGHT_IN_NINE)
    loaded = kinem.load(case)
    listed = resolve(loaded, loaded.report["sensitivity"])
    assert len(loaded.report["sensitivity"]) == 9 and len(listed) == 8, listed
    assert run_main(["info", str(case)])[0] == 0
    drawn = []
    plot = design._sensitivity_plot
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(design, "_sensitivity_plot",
                   lambda t, paths, *a, **k: drawn.append(paths) or plot(t, paths, *a, **k))
        mp.setattr(design, "_bands", lambda *a, **k: [])
        parts = design.section(kinem.compile(loaded))
    assert drawn == [[p.path for p in listed]], drawn
    assert parts[0].count("<tr><td class=l><code>") == 8


def test_found_report_sensitivity_nine_parameters_refused(tmp_path):
    """Nine parameters (nine texts) stay refused, now by their count, naming the key and what is expected."""
    case = _named_case(tmp_path, EIGHT_IN_NINE[1:] + ["points.O4.at.1"])
    code, line = run_main(["info", str(case)])
    assert code == 2 and f"{case}: [report]: key 'sensitivity': 9 design parameters; expected a list of 1 to 8 " \
                         "design parameter paths (or names of [parameters]), each parameter counted once" in line, line
    many = _named_case(tmp_path, [f"points.O2.at.{i}" for i in range(17)])
    code, line = run_main(["info", str(many)])
    assert code == 2 and "[report]: key 'sensitivity': got [" in line and "each parameter counted once" in line, line


@pytest.mark.parametrize("text, code", [("a\x07b", "0007"), ("\u202eab", "202E"), ("ab\x1b[31m", "001B"),
                                        ("ab\r", "000D")])
def test_found_a_python_built_case_with_control_characters(text, code):
    """A kinem.Case built in Python (its constructor, or dataclasses.replace of a loaded one) took any
    description: the loader's check (session 27) was the file's alone. Now the Case refuses it itself, in the
    loader's words (tab and newline stay)."""
    import dataclasses

    case = kinem.load(FOUR_BAR)
    at = text.index(text.strip("ab")[0]) + 1
    said = f"<memory>: top level: key 'description': U+{code} at character {at}; expected text without control " \
           "or invisible formatting characters (tab and newline allowed)"
    with pytest.raises(kinem.InputError) as e:
        kinem.Case(name="x", bodies=case.bodies, points=case.points, constraints=case.constraints, end=1.0,
                   steps=10, description=text)
    assert str(e.value) == said, str(e.value)
    with pytest.raises(kinem.InputError) as e:
        dataclasses.replace(case, description=text)
    assert f"{FOUR_BAR}: top level: key 'description': U+{code}" in str(e.value), str(e.value)
    with pytest.raises(kinem.InputError) as e:
        dataclasses.replace(case, description=3)
    assert "key 'description': got int; expected text" in str(e.value), str(e.value)
    assert dataclasses.replace(case, description="a\tb\nc \u00e9").description == "a\tb\nc \u00e9"


def _short_rod(tmp_path, tolerance):
    """A slider-crank whose rod is 0.5 mm longer than its crank, with a [tolerances] table: samples whose rod is
    shorter than the crank cannot pass its dead centre (the solve stops, singular), others are in the band."""
    text = (ROOT / "cases" / "slider_crank.toml").read_text().replace("si = [300.0, 0.0]", "si = [0.5, 0.0]", 1)
    case = tmp_path / "rod.toml"
    case.write_text(text.replace("steps = 500", "steps = 50") + f"\n[tolerances]\n{tolerance}\n")
    return case


@pytest.mark.parametrize("samples, seed, none", [("50", "0", False), ("1", "3", True)])
def test_found_tolerance_failed_samples_said_as_branches(tmp_path, samples, seed, none):
    """kinem tolerance with samples that fail on the way (a rod drawn shorter than its crank: singular at the
    dead centre) said "N of M samples not on the nominal's branch", which they never left; with every sample
    left out the CSV's Monte Carlo columns were NaN without a word of why. Now docs/design.md's words (not a
    valid case, cannot assemble, leave the branch or fail on the way), and with none in the band, that its
    .mc columns are NaN; exit 0 (the linear bands are the answer), the CSV whole."""
    case = _short_rod(tmp_path, '"constraints.B.si.0" = 1.0')
    out = tmp_path / "o.csv"
    args = ["tolerance", str(case), "--samples", samples, "--seed", seed, "--out", str(out)]
    assert run_main(args, notes=True) == (0, "")   # the contract: its notes alone on standard error
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        code = main(args)
    err = buf.getvalue()
    assert code == 0, err
    said = [line for line in err.splitlines() if line.startswith("kinem: ") and " samples left out " in line]
    assert len(said) == 1 and "samples left out of the Monte Carlo band (not a valid case, cannot assemble, leave " \
        "the nominal's branch or fail on the way)" in said[0] and "; first: SINGULAR: " in said[0], err
    assert ("none is in the band: its .mc columns are NaN" in said[0]) == none, said
    rows = out.read_text().splitlines()
    head, first = rows[0].split(","), rows[1].split(",")
    assert len(rows) == 52 and head[-1] == "A.y.mc+", rows[0]
    mc = [float(first[k]) for k, c in enumerate(head) if ".mc" in c]
    assert all(math.isnan(x) for x in mc) if none else all(math.isfinite(x) for x in mc), first


@pytest.mark.parametrize("tolerance, samples, said", [
    ('"constraints.B.si.0" = 1.0', 200, "44 of 200 samples left the nominal's branch or could not assemble"),
    ('"constraints.A.sj.0" = 10.0', 1, "No Monte Carlo band: no sample is in it"),
])
def test_report_bands_with_failed_samples(tmp_path, monkeypatch, tolerance, samples, said):
    """The report's tolerance bands where samples fail (part 9's "not covered"): counted and left out of the
    band; with none in it, no band and no excess over it. Found sound."""
    import re

    from kinem.report import design

    monkeypatch.setattr(design, "SAMPLES", samples)
    model = kinem.compile(kinem.load(_short_rod(tmp_path, tolerance)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parts = design._bands(model, ["A.x", "A.y"])
    text = re.sub("<[^>]*>", " ", parts[0])
    assert said in text and len(parts) == 2, text


# -- session 28, part 10, part B: sweep, tolerance and info --parameters with hostile inputs -------------------

@pytest.mark.parametrize("command", [
    ["sweep", "--set", "ground=0.19,0.21", "--set", "points.O4.at.0=0.2,0.22", "--outputs", "B.x"],
    ["solve", "--set", "points.O4.at.0=0.2", "--set", "ground=0.19", "--steps", "3"],
    ["info", "--set", "ground=0.19", "--set", "points.O4.at.0=0.2"],
    ["tolerance", "--samples", "3"],
])
def test_found_a_name_and_a_number_it_gives_set_together(tmp_path, command):
    """A name of [parameters] and the path of a number it gives, set together (--set ground=... --set
    points.O4.at.0=..., or both in [tolerances]): the path's value stood and the name's was ignored there
    unseen; a sweep's table had a ground column that moved nothing (its variants equal in pairs), and the
    tolerance's linear bands counted the one number twice while its samples drew it once. Now refused,
    naming both and the number (two spellings of one parameter were already refused)."""
    case = tmp_path / "case.toml"
    text = NAMED.read_text()
    if command[0] == "tolerance":
        text += '\n[tolerances]\nground = 1e-4\n"points.O4.at.0" = 2e-4\n'
    case.write_text(text)
    out = [] if command[0] == "info" else ["--out", str(tmp_path / "o.csv")]
    code, line = run_main([command[0], str(case), *command[1:], *out])
    said = ("'ground' and 'points.O4.at.0' set one number: ground of [parameters] gives points.O4.at.0; expected one "
            "of them")
    assert code == 2 and said in line, line
    assert not (tmp_path / "o.csv").exists()
    from kinem.parameters import apply

    with pytest.raises(kinem.InputError, match="set one number"):
        apply(kinem.load(NAMED), {"crank": 0.11, "points.A.at.0": 0.12})
    assert apply(kinem.load(NAMED), {"crank": 0.11, "points.B.at.0": 0.23}).parameters["crank"] == 0.11


def test_found_a_name_set_apart_listed_as_a_parameter(tmp_path):
    """info --parameters --set points.O4.at.0=0.25 (the one number the name ground gives, set apart) listed
    parameters.ground, "used by no number of the case", with no unit: setting it would move nothing (a case
    file is refused such a name). Now a name no number uses is not a design parameter, and saying it is
    refused with the reason."""
    from kinem.parameters import apply, parameters

    code, _ = run_main(["info", str(NAMED), "--parameters", "--set", "points.O4.at.0=0.25"])
    assert code == 0
    variant = apply(kinem.load(NAMED), {"points.O4.at.0": 0.25})
    listed = [p.path for p in parameters(variant)]
    assert "parameters.ground" not in listed and "parameters.crank" in listed, listed
    with pytest.raises(kinem.InputError) as e:
        kinem.sensitivity(kinem.compile(variant), ["ground"])
    assert "parameter 'parameters.ground': named dimension ground is used by no number of the case" in str(e.value)
    assert "parameters.ground" in [p.path for p in parameters(kinem.load(NAMED))]


def test_found_info_parameters_and_blocks(tmp_path):
    """info --parameters --blocks printed the parameters and ignored --blocks (two listings instead of the
    summary, one chosen unseen). Now refused before the case is read, as report's --stress --no-stress."""
    for case in (str(FOUR_BAR), str(tmp_path / "missing.toml")):
        code, line = run_main(["info", case, "--parameters", "--blocks", "--json"])
        assert (code, line) == (2, "kinem: error: --parameters and --blocks: give at most one (each is a listing "
                                   "instead of the summary)"), line
    assert run_main(["info", str(FOUR_BAR), "--blocks", "--json"])[0] == 0


def test_found_a_sweep_into_fast_drivers_said_nothing(tmp_path):
    """A driver's rate swept to 2,000 rad/s over 250 output intervals: kinem solve of one such variant warns
    (a speed in degrees read as radians?), the sweep said nothing (its variants' warnings were dropped so
    that the case's own are given once). Now one line for all of them, the first quoted; a sweep whose
    variants warn as the case does adds none."""
    out = tmp_path / "o.csv"
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        code = main(["sweep", str(FOUR_BAR), "--set", "constraints.crank-drive.d.poly.1=1:2000:5", "--outputs", "B.x",
                     "--out", str(out)])
    lines = buf.getvalue().splitlines()
    assert code == 1 and len(lines) == 2, lines   # two variants fail on the way: their own line
    assert lines[0].startswith("kinem: warning: sweep: 4 of 5 variants warn where the case itself does not; first, "
                               "variant 1: ") and "turns body 'crank' at up to 500.8 rad/s" in lines[0], lines
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kinem.sweep(str(FOUR_BAR), {"constraints.crank-drive.d.poly.1": [1.4, 1.6]}, ["B.x"])


# -- session 29, part 11 (docs/benchmarks.md, "Fuzz campaign, session 29"): what part 10 left ------------------

def _engine_returning(monkeypatch, engine, status, detail):
    """The engine's Adapter.run made to return a run of that status (its cause kept by the run alone)."""
    from adapters import get
    from adapters.base import EngineRun

    def run(self, model, *a, **k):
        return EngineRun(engine=engine, status=status, detail=detail, trajectory=None, q=None, qd=None)

    monkeypatch.setattr(type(get(engine)), "run", run)


def test_found_the_time_limit_told_by_the_clock(tmp_path, monkeypatch):
    """An engine's run stopped by the time limit was told from other failures by the clock in animate (past the
    deadline: EngineRun kept no cause), so another failure after the deadline read as the time limit, and a
    run stopped by the limit on a clock that had not passed it (a worker's) was a ghost left out. Now the run
    carries the limit as its own status (Status.OUT_OF_TIME), which animate reads: the time limit fails the
    command whatever the clock says; another failure leaves the ghost out, named."""
    import time

    from adapters import compare
    from adapters.base import Status

    limit = "the time limit of 30 s (Options.max_seconds, --max-seconds of kinem solve, compare and animate) is " \
            "reached at t = 0.5"
    out = tmp_path / "a.svg"
    _engine_returning(monkeypatch, "pymunk", Status.OUT_OF_TIME, limit)   # the clock far from the deadline
    code, line = run_main(["animate", str(FOUR_BAR), "--out", str(out), "--engines", "native,pymunk",
                           "--max-seconds", "30"])
    assert (code, line) == (1, f"kinem: analysis failed: {FOUR_BAR}: pymunk: {limit}") and not out.exists(), line
    _engine_returning(monkeypatch, "pymunk", Status.DIVERGED, "left the mechanism at t = 0.2")
    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        code = main(["animate", str(FOUR_BAR), "--out", str(out), "--engines", "native,pymunk", "--max-seconds", "30"])
    assert (code, buf.getvalue()) == (0, "pymunk: not drawn: failed: left the mechanism at t = 0.2\n") and out.exists()


def test_out_of_time_is_a_status_and_a_verdict(monkeypatch):
    """The same status in compare: the row's label keeps the one prefix of failures ("failed: the time limit ...")
    and its JSON names the kind: outcome and verdict "out of time", which fails the run (exit 1); an engine's
    run past its limit returns that status."""
    import time

    from adapters import compare, get
    from adapters.base import Status
    from adapters.compare import Verdict

    assert Verdict.OUT_OF_TIME.fails and Status.OUT_OF_TIME.failure
    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    code, out, err = _compare([str(FOUR_BAR), "--engines", "native,pymunk", "--steps", "40", "--max-seconds", "30",
                               "--json"])
    row = json.loads(out)["engines"]["pymunk"]
    assert code == 1 and err == "", err
    assert (row["outcome"], row["verdict"]) == ("out of time", "out of time"), row
    assert row["status"].startswith("failed: the time limit of 30 s"), row["status"]
    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=40))
    run = get("pymunk").run(model, limit=(30, time.time() - 1.0))
    assert run.status is Status.OUT_OF_TIME and run.label.startswith("failed: the time limit of 30 s"), run.label


def test_out_of_time_is_in_the_report_schema():
    """results.json's outcome and verdict enums hold the new members, so a run of that status is valid there."""
    from adapters.base import Status
    from adapters.compare import Verdict
    from kinem.report.schema import SCHEMA

    text = json.dumps(SCHEMA)
    assert text.count('"out of time"') == 4, text.count('"out of time"')
    assert Status("out of time") is Status.OUT_OF_TIME and Verdict("out of time") is Verdict.OUT_OF_TIME


def test_found_the_sweep_counted_warnings_not_variants():
    """The sweep's warning line counted warnings ("4 warning(s) of the variants"): a variant with two fast drivers
    counted twice (caught per chunk of 64 variants, not per variant). Now it counts the variants that warn, and
    names the first: a four-bar with a second crank (a wheel pinned to the ground), both rates swept over
    {1.5, 2000}: 3 of 4 variants warn, one of them twice."""
    doc = json.loads(json.dumps(BASES[FOUR_BAR]))
    doc["bodies"]["wheel"] = {"q": [0.2, 0.0, 0.0]}
    doc["constraints"] += [{"type": "revolute", "name": "W", "i": "ground", "si": "O4", "j": "wheel", "sj": [0.0, 0.0]},
                           {"type": "driver", "name": "wheel-drive", "body": "wheel", "coord": "phi",
                            "d": {"poly": [0.0, 1.0]}}]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kinem.sweep(doc, {"constraints.crank-drive.d.poly.1": [1.5, 2000.0],
                          "constraints.wheel-drive.d.poly.1": [1.0, 2000.0]}, ["B.x"])
    said = [str(w.message) for w in caught if issubclass(w.category, kinem.KinemWarning)]
    assert len(said) == 1 and said[0].startswith("sweep: 3 of 4 variants warn where the case itself does not; first, "
                                                 "variant 1: <dict>: constraint "), said
    assert "'wheel-drive'" in said[0], said


def test_found_compare_native_row_past_the_time_limit(monkeypatch):
    """compare's native row checked native against the case's closed form whatever the time: at 2,000,000 steps
    and --max-seconds 8, 13 s of it after the limit (a four-bar, load 5). Now it is not begun past the limit: the
    row is out of time, saying so, exit 1."""
    import time

    from adapters import compare

    monkeypatch.setattr(compare, "engines_deadline", lambda options: (options.max_seconds, time.time() - 1.0))
    code, out, err = _compare([str(FOUR_BAR), "--engines", "native", "--steps", "40", "--max-seconds", "30", "--json"])
    row = json.loads(out)["engines"]["native"]
    assert code == 1 and err == "", err
    assert (row["outcome"], row["verdict"], row["independent"]) == ("out of time", "out of time", False), row
    assert row["status"] == "failed: the time limit of 30 s (Options.max_seconds, --max-seconds of kinem solve, " \
                            "compare and animate) is reached before its check against the closed form", row


def test_found_compare_native_closed_form_past_the_time_limit(monkeypatch):
    """pin_in_spline_slot's closed form is a Python loop (a Brent root an instant, 1.7 ms each): compare at
    100,000 steps with --max-seconds 5 ran 169 s of it past the limit (native's solve: 0.3 s). Now the loop looks
    at the limit every 1,024 instants, and past it the native row is out of time, saying where it stopped."""
    import time

    from adapters import references
    from adapters.base import OutOfTime, Status, limited
    from kinem.solver import solve

    slot = ROOT / "cases" / "pin_in_spline_slot.toml"
    model = kinem.compile(kinem.load(slot).with_time(steps=40))
    native = solve(model)
    with limited((5, time.time() - 1.0)), pytest.raises(OutOfTime):
        references.closed_form(model, native)
    assert references.closed_form(model, native) is not None   # no limit: the same check

    def late(t, steps=0, wall=0.0):
        raise OutOfTime(Status.OUT_OF_TIME, f"the time limit is reached at t = {t:.6g}")

    _native_row_stopped(monkeypatch, slot, late, "0")


def _native_row_stopped(monkeypatch, case, late, at: str):
    """compare --engines native of ``case`` (40 steps, --json) with the closed forms' look at the time limit
    (adapters.references.in_time) replaced by ``late``: exit 1, the native row out of time, its check against the
    closed form stopped at t = ``at``."""
    from adapters import references

    monkeypatch.setattr(references, "in_time", late)
    code, out, err = _compare([str(case), "--engines", "native", "--steps", "40", "--json"])
    row = _strict(out)["engines"]["native"]
    assert code == 1 and (row["outcome"], row["verdict"]) == ("out of time", "out of time"), row
    assert row["status"] == f"failed: the time limit is reached at t = {at} of its check against the closed form", \
        row


@pytest.mark.parametrize("engine", ENGINES)
def test_found_an_engines_own_checks_past_the_time_limit(monkeypatch, engine):
    """An engine's run was bounded between its output intervals, not in the checks after an attempt (the
    self-check of dt = "auto", a Python loop over the instants: minutes at millions of instants). Now they look
    at the limit every CHECK_EVERY instants: here the limit is made to have passed for the checks alone."""
    from adapters import base, get

    def late(t, steps=0, wall=0.0):
        raise base.OutOfTime(base.Status.OUT_OF_TIME, f"the time limit is reached at t = {t:.6g}", steps, wall=wall)

    adapter = get(engine)   # imported first: its stepping loop keeps its own (unpatched) name
    monkeypatch.setattr(base, "in_time", late)
    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=40))
    run = adapter.run(model)
    assert run.status is base.Status.OUT_OF_TIME and run.detail == "the time limit is reached at t = 0", run.label
    assert run.trajectory is None


def test_pymunk_tables_in_chunks_are_the_same_run(monkeypatch):
    """pymunk's driving tables are made TABLE_CHUNK steps at a time between output intervals (all at once, 10^7
    steps took 23 s past any limit): the same trajectory to the bit whatever the chunk (7 steps, or all)."""
    from adapters import get, pymunk_sim

    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=40))
    runs = []
    for chunk in (7, 10**9):
        monkeypatch.setattr(pymunk_sim, "TABLE_CHUNK", chunk)
        runs.append(get("pymunk").run(model, settings={"substeps": 3}))
    assert runs[0].ok and np.array_equal(runs[0].q, runs[1].q) and np.array_equal(runs[0].qd, runs[1].qd)


# -- session 29, part 11, part B: kinem.solve(parameters=), kinem.tolerance with odd arguments -------------------

@pytest.fixture(scope="module")
def four_bar_20():
    return kinem.compile(kinem.load(FOUR_BAR).with_time(steps=20))


def test_found_variants_with_a_junk_options(four_bar_20):
    """kinem.solve(model, parameters=..., options="fast") raised AttributeError ('str' object has no attribute
    'started'); one solve refuses it. Now the same InputError."""
    with pytest.raises(kinem.InputError, match="^solve: options str: expected a kinem.Options$"):
        kinem.solve(four_bar_20, parameters={"points.A.at.0": [0.05]}, options="fast")


@pytest.mark.parametrize("values", [[0.05 + 1j], np.array([0.05, 0.06], complex)])
def test_found_variants_of_complex_numbers(four_bar_20, values):
    """Complex values were cast to their real part, numpy's ComplexWarning on the way (0.05+1j solved as 0.05).
    Now no numbers, as booleans are not (kinem.casefile.checks.floats: kinem.sweep too)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(kinem.InputError, match="expected a 1-D sequence of one or more finite numbers"):
            kinem.solve(four_bar_20, parameters={"points.A.at.0": values})
        with pytest.raises(kinem.InputError, match="expected one or more finite numbers"):
            kinem.sweep(str(FOUR_BAR), {"points.A.at.0": values}, ["B.x"])


@pytest.mark.parametrize("path, value", [("points.A.at.0", 1e300), ("points.A.at.0", -1e13),
                                         ("constraints.crank-drive.d.poly.1", 1e300),
                                         ("constraints.crank-drive.d.poly.0", 1e300)])
def test_found_variants_beyond_a_case_files_magnitude(four_bar_20, path, value):
    """A variant's value beyond MAX_MAGNITUDE (1e12: what a case file, kinem.load(parameters=) and a sweep's
    variant refuse) was solved: numpy's "overflow encountered in dot" twice, seconds of it, and a reason that
    misled ("too few driving equations"). Now that variant is bad input, never solved, in the loader's words;
    the others are solved as before."""
    nominal = next(p.value for p in kinem.parameters(four_bar_20.case) if p.path == path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = kinem.solve(four_bar_20, parameters={path: [value, nominal]})
    assert r.success.tolist() == [False, True] and np.isnan(r.data[0]).all(), r.messages
    assert r.status[0] is kinem.native.Why.BAD_INPUT, r.status
    assert r.messages[0] == f"bad input: {four_bar_20.case.source}: {path} = {value:g}: expected a number of " \
                            "magnitude at most 1e+12", r.messages
    alone = kinem.solve(four_bar_20, parameters={path: [nominal]})
    assert np.array_equal(r.data[1], alone.data[0])


def test_found_variants_outputs_as_bytes(four_bar_20):
    """outputs=b"B.x" read as the numbers 66, 46, 120: "no column 66". Now refused as outputs None is."""
    with pytest.raises(kinem.InputError, match=r"outputs b'B.x': expected stages"):
        kinem.solve(four_bar_20, parameters={"points.A.at.0": [0.05]}, outputs=b"B.x")


@pytest.mark.parametrize("chunk", [0, -1, 2.5, "2", True])
def test_found_tolerance_with_an_odd_chunk(four_bar_20, chunk):
    """kinem.tolerance(chunk=-1) solved no sample and returned bands without a Monte Carlo one, unseen
    (range(0, samples, -1)); chunk="2" raised TypeError. Now refused: None or a whole number from 1."""
    with pytest.raises(kinem.InputError, match="tolerance: chunk .*: expected None or a whole number from 1"):
        tolerance(four_bar_20, samples=5, chunk=chunk)
    assert tolerance(four_bar_20, samples=5, chunk=10**20).accepted == 5


# -- session 29, part B: compare --sensitivity and the report's design section of a small radius ---------------

ROLLER = ROOT / "cases" / "cam_roller_circle.toml"


def _small_roller(tmp_path, extra=""):
    """cam_roller_circle with a roller of radius 0.05 mm: below 2h of the central differences (h = 1e-3 L and
    5e-4 L, L = 50 mm), so that p - h or p - 2h is no valid case."""
    text = ROLLER.read_text().replace("radius = 8.0", "radius = 0.05", 1).replace("steps = 200", "steps = 20")
    assert "radius = 0.05" in text
    case = tmp_path / "roller.toml"
    case.write_text(text + extra)
    return case


def test_found_compare_sensitivity_past_a_valid_case(tmp_path):
    """compare --sensitivity of a radius below 2h stopped the command: "kinem: error: CASE: constraint 4 ('contact',
    cam-roller): key 'radius': got 0; expected a positive number", exit 2: the case file blamed for a value it
    does not hold (0.05 is valid), no row of the other parameters. Now that parameter's row fails saying which
    moved case is not valid and why (exit 1, a failed check); the other parameters are checked as ever."""
    case = _small_roller(tmp_path)
    code, out, err = _compare([str(case), "--engines", "native", "--sensitivity",
                               "constraints.contact.radius,constraints.contact.outline.circle.radius"])
    assert code == 1 and err == "", err
    rows = [line for line in out.splitlines() if line.startswith("native")]
    assert "failed: native at p +- h: p - h = 0 is not a valid case (" in rows[0] and "got 0; expected a positive " \
           "number)" in rows[0], rows
    assert "within: " in rows[1], rows


def test_found_report_sensitivity_past_a_valid_case(tmp_path):
    """The same in the report's design section ([report] sensitivity with the radius, a named point on the
    follower): the whole report stopped with that error, exit 2, nothing written. Now its row says the
    differences were not computed and why."""
    import re

    from kinem.report import design

    text = _small_roller(tmp_path, '\n[report]\nsensitivity = ["constraints.contact.radius"]\n').read_text()
    text = text.replace("[bodies]", '[points]\nF = { body = "follower", at = [0.0, 0.0] }\n\n[bodies]', 1)
    model = kinem.compile(kinem.load_dict(tomllib.loads(text), source="roller"))
    table = re.sub("<[^>]*>", " ", design.section(model)[0])
    assert "not computed: native at p +- h: p - 2h = 0 is not a valid case (" in html_unescape(table), table[-400:]


def html_unescape(text):
    import html

    return html.unescape(text)


def test_found_report_design_section_without_points(tmp_path):
    """A case with [report] sensitivity but no named point on a moving body (cam_roller_circle has none) got no
    design section and no word of why. Now a paragraph says so."""
    from kinem.report import design

    text = ROLLER.read_text().replace("steps = 200", "steps = 20") + \
        '\n[report]\nsensitivity = ["constraints.contact.radius"]\n'
    model = kinem.compile(kinem.load_dict(tomllib.loads(text), source="roller"))
    assert design.section(model) == ["<h3>Design sensitivities and tolerance bands</h3><p>Not drawn: they are the "
                                     "named points' on moving bodies, and the case has none (its [points], or the "
                                     "[report] points listed).</p>"]


def _strict(text):
    """JSON as RFC 8259 has it: NaN and Infinity are no numbers (strict readers refuse them)."""
    def refuse(constant):
        raise ValueError(f"{constant} is no JSON number")
    return json.loads(text, parse_constant=refuse)


def test_found_compare_json_with_nan(tmp_path):
    """compare --json wrote "cost_per_interval": NaN for a row that did not run (a native failure: no engine
    run), and compare --sensitivity --json wrote "error": NaN, "ratio": NaN ... for every row not computed
    (failed, unsupported): no JSON. Now null, as the rows' other figures not computed already were."""
    stalled = ROOT / "cases" / "stress" / "slider_dead_centre.toml"
    code, out, err = _compare([str(stalled), "--engines", "native,pymunk", "--steps", "20", "--json"])
    assert code == 1 and _strict(out)["engines"]["pymunk"]["cost_per_interval"] is None, out
    code, out, err = _compare([str(_small_roller(tmp_path)), "--engines", "native,mujoco", "--json", "--sensitivity",
                               "constraints.contact.radius,constraints.contact.outline.circle.radius"])
    rows = _strict(out)["sensitivity"]
    assert code == 1 and [r["ratio"] is None for r in rows] == [True, False, True], rows


def test_found_native_row_stopped_by_the_limit_is_out_of_time():
    """Native's own solve stopped by the time limit kept compare's native row 'failed' (its SolveResult said
    NOT_CONVERGED, the cause only in its words). Now the result's status is OUT_OF_TIME and so is the row's."""
    import numpy as np

    from adapters.base import Status
    from adapters.compare import native_row

    model = kinem.compile(kinem.load(FOUR_BAR))
    times = np.linspace(0.0, 50.0, 2_000_001)
    native = kinem.solve(model, times=times, options=kinem.Options(max_seconds=0.2))
    assert not native.success and native.status is kinem.Status.OUT_OF_TIME, native.message
    row = native_row(model, native, kinem.Options(max_seconds=0.2))
    assert row.status is Status.OUT_OF_TIME and row.verdict.fails, row


def test_found_masked_values_refused_not_solved(four_bar_20):
    """A numpy masked array's mask was dropped (np.asarray): the masked values, whatever lay under them, were
    solved as variants by kinem.solve(parameters=) and kinem.sweep. Now a masked value is refused as a value
    that is not a finite number; a masked array with nothing masked is its numbers."""
    import numpy as np

    masked = np.ma.masked_array([0.05, 1e6], mask=[False, True])
    with pytest.raises(kinem.InputError, match="'points.A.at.0': expected a 1-D sequence of one or more finite"):
        kinem.solve(four_bar_20, parameters={"points.A.at.0": masked})
    with pytest.raises(kinem.InputError, match="points.A.at.0"):
        kinem.sweep(str(FOUR_BAR), {"points.A.at.0": masked}, ["B.x"])
    plain = kinem.solve(four_bar_20, parameters={"points.A.at.0": np.ma.masked_array([0.05], mask=[False])})
    assert plain.success.all()


@pytest.mark.parametrize("call", ["solve", "sensitivity", "variants"])
def test_found_empty_outputs_refused_alike(four_bar_20, call):
    """outputs=[] was read as positions by kinem.solve and kinem.sensitivity, and refused ("none given") by
    kinem.solve(parameters=): one call, two meanings. Now refused by all three, as --outputs '' is."""
    args = {"solve": lambda: kinem.solve(four_bar_20, outputs=[]),
            "sensitivity": lambda: kinem.sensitivity(four_bar_20, ["points.A.at.0"], outputs=[]),
            "variants": lambda: kinem.solve(four_bar_20, parameters={"points.A.at.0": [0.05]}, outputs=[])}
    with pytest.raises(kinem.InputError, match="outputs"):
        args[call]()


# -- session 30, part 12 (docs/benchmarks.md, "Fuzz campaign, session 30"): what part 11 left -----------------

def _warned(call):
    """(the value of call(), the texts of the KinemWarnings it gave)."""
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        out = call()
    return out, [str(w.message) for w in got if issubclass(w.category, kinem.KinemWarning)]


def _degrees_named(tmp_path):
    """cases/four_bar.toml in degrees, its crank's rate a named dimension."""
    text = FOUR_BAR.read_text().replace('units = { length = "m" }', 'units = { length = "m", angle = "deg" }')
    for rad, deg in (("0.785]", "45.0]"), ("0.27]", "15.47]"), ("0.76]", "43.54]")):
        text = text.replace(rad, deg)
    text = text.replace("d = { poly = [0.7853981633974483, 1.5, -0.6] }", 'd = { poly = [45.0, "rate", -34.38] }')
    text = text.replace("[time]", "[parameters]\nrate = 85.94\n\n[time]")
    path = tmp_path / "degrees.toml"
    path.write_text(text)
    return path


def test_found_variants_of_a_fast_driver_said_nothing(tmp_path):
    """kinem.solve(model, parameters=...) of a driver's rate up to 2,000 rad/s said nothing where kinem.sweep of
    the same values warns (a speed in degrees read as radians?): its variants are formed in the core, no case
    built. Now the driver's functions are evaluated from the values (no case built) and one line counts the
    variants, as the sweep's; the first quoted is the sweep's own text, in degrees and by a named dimension
    too. A variant refused as bad input, or of the nominal's rate, and a parameter not of a driver, add none."""
    model = kinem.compile(kinem.load(FOUR_BAR))
    rates = list(np.linspace(1.0, 2000.0, 5))
    sweep, said = _warned(lambda: kinem.sweep(str(FOUR_BAR), {"constraints.crank-drive.d.poly.1": rates}, ["B.x"]))
    got, told = _warned(lambda: kinem.solve(model, parameters={"constraints.crank-drive.d.poly.1": rates},
                                            outputs=["B.x"]))
    assert len(said) == 1 and len(told) == 1, (said, told)
    assert told[0].startswith("solve: 4 of 5 variants warn where the case itself does not; first, variant 1: ")
    assert told[0].split("first, ")[1] == said[0].split("first, ")[1], (told, said)
    assert (np.isnan(got.data) == np.isnan(sweep.data)).all()
    _, told = _warned(lambda: kinem.solve(model, parameters={"constraints.crank-drive.d.poly.1": [1.5, 1.4],
                                                             "points.A.at.0": [0.05, 0.04]}, outputs=["B.x"]))
    assert told == []
    _, told = _warned(lambda: kinem.solve(model, parameters={"points.A.at.0": [0.05, 0.04]}, outputs=["B.x"]))
    assert told == []
    refused, told = _warned(lambda: kinem.solve(model, parameters={"constraints.crank-drive.d.poly.1": [2000.0] * 2,
                                                                   "points.A.at.0": [0.05, 1e300]}, outputs=["B.x"]))
    assert refused.status[1] is kinem.native.Why.BAD_INPUT and len(told) == 1, told
    assert told[0].startswith("solve: 1 of 2 variants warn where the case itself does not; first, variant 0: "), told
    path = _degrees_named(tmp_path)
    degrees = kinem.compile(kinem.load(path))
    sweep, said = _warned(lambda: kinem.sweep(str(path), {"rate": [85.94, 30000.0, 85.94]}, ["B.x"]))
    _, told = _warned(lambda: kinem.solve(degrees, parameters={"rate": [85.94, 30000.0, 85.94]}, outputs=["B.x"]))
    assert len(said) == 1 and told == ["solve: 1 of 3 variants warn where the case itself does not; first, "
                                       + said[0].split("first, ")[1]], (told, said)
    assert "at up to 523.6 rad/s" in told[0], told


CLOSED = [p for p in sorted((ROOT / "cases").glob("*.toml")) if p.stem != "pin_in_spline_slot"]


@pytest.mark.parametrize("path", CLOSED, ids=lambda p: p.stem)
def test_closed_forms_in_chunks_are_the_same_arrays(monkeypatch, path):
    """A closed form is evaluated CHUNK instants at a time (the time limit looked at between chunks), each chunk
    with the first instant, whose dimensions and d(0) it reads: the same arrays to the bit as one pass, whatever
    the chunk (7 instants, or all). (pin_in_spline_slot's loops over its instants and looks itself.)"""
    from adapters import references

    model = kinem.compile(kinem.load(path).with_time(steps=60))
    native = kinem.solve(model)
    forms = []
    for chunk in (10**12, 7, 60):
        monkeypatch.setattr(references, "CHUNK", chunk)
        forms.append(references.closed_form(model, native))
    assert forms[0] is not None
    whole = [np.asarray(x) for x in references._flat(forms[0])]
    for cf in forms[1:]:
        assert cf.label == forms[0].label and list(cf.points) == list(forms[0].points)
        assert list(cf.bodies) == list(forms[0].bodies)
        parts = [np.asarray(x) for x in references._flat(cf)]
        assert all(a.shape == b.shape and a.tobytes() == b.tobytes() for a, b in zip(whole, parts))


def test_found_a_closed_form_of_one_pass_past_the_time_limit(monkeypatch):
    """A closed form evaluated in one numpy pass over all the instants (the four-bar's: 17 s at 5,000,000, the
    most compare holds, load 4.2) ran to its end past --max-seconds. Now it looks at the limit between chunks of
    CHUNK instants: past it, compare's native row is out of time, saying where the check stopped."""
    import time

    from adapters import references
    from adapters.base import OutOfTime, Status, limited

    monkeypatch.setattr(references, "CHUNK", 16)
    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=40))
    native = kinem.solve(model)
    with limited((5, time.time() - 1.0)), pytest.raises(OutOfTime, match=r"reached at t = 0\.9375$"):
        references.closed_form(model, native)
    assert references.closed_form(model, native) is not None   # no limit: the same check
    calls = []

    def late(t, steps=0, wall=0.0):   # the limit reached after the first chunk
        calls.append(t)
        if len(calls) > 1:
            raise OutOfTime(Status.OUT_OF_TIME, f"the time limit is reached at t = {t:.6g}")

    _native_row_stopped(monkeypatch, FOUR_BAR, late, "1.9375")


def test_found_pymunk_pose_arrays_of_the_whole_run_before_its_first_check(monkeypatch):
    """pymunk's prescribed poses and joint targets were numpy arrays over every step of the run, made with the
    mechanism before the first interval's check of --max-seconds (8 to 16 s at 10^7 steps, load 4.5). Now they
    are made a window of TABLE_CHUNK steps at a time, with the tables, when the stepping reaches them: no
    driving function is evaluated over more than a window, and a run past its limit evaluates none beyond the
    first. (The same runs to the bit: test_pymunk_tables_in_chunks_are_the_same_run, and below.)"""
    import time

    from adapters import get, pymunk_sim

    lengths = []
    real = pymunk_sim._values

    def values(f, t):
        lengths.append(len(t))
        return real(f, t)

    model = kinem.compile(kinem.load(FOUR_BAR).with_time(steps=40))
    whole = get("pymunk").run(model, settings={"substeps": 10})
    monkeypatch.setattr(pymunk_sim, "_values", values)
    monkeypatch.setattr(pymunk_sim, "TABLE_CHUNK", 16)
    run = get("pymunk").run(model, settings={"substeps": 10})
    assert run.ok and np.array_equal(run.q, whole.q) and np.array_equal(run.qd, whole.qd)
    assert lengths and max(lengths) <= 16 + 1 < 402, lengths   # 402 step instants in the run
    lengths.clear()
    late = get("pymunk").run(model, settings={"substeps": 10}, limit=(5, time.time() - 1.0))
    assert late.status is pymunk_sim.Status.OUT_OF_TIME and max(lengths, default=0) <= 1, (late.label, lengths)


# -- session 30, part B: case files as editors write them, numbers past Python's digits, odd baselines --------

def test_found_a_case_file_with_a_byte_order_mark(tmp_path):
    """A case file saved with a UTF-8 byte order mark (Windows editors write one) was refused as "TOML syntax
    error: Invalid statement (at line 1, column 1)", naming nothing that is wrong. Now one leading mark is read
    past (Python's utf-8-sig); two are refused as ever; CRLF line ends and tabs were sound."""
    text = FOUR_BAR.read_text()
    path = tmp_path / "bom.toml"
    for body in (text, text.replace("\n", "\r\n"), text.replace(" = ", "\t=\t")):
        path.write_bytes(b"\xef\xbb\xbf" + body.encode())
        assert kinem.load(path) == kinem.load(FOUR_BAR).__class__(**{**vars(kinem.load(FOUR_BAR)),
                                                                     "source": str(path)})
        assert run_main(["info", str(path)])[0] == 0
    assert kinem.loads("\ufeff" + text).name == "four_bar"
    path.write_bytes(b"\xef\xbb\xbf" * 2 + text.encode())
    code, line = run_main(["info", str(path)])
    assert code == 2 and "TOML syntax error" in line and str(path) in line, line


@pytest.mark.parametrize("value, shown", [("1979-05-27", "1979-05-27 (a TOML date)"),
                                          ("07:32:00", "07:32:00 (a TOML time)"),
                                          ("1979-05-27T07:32:00Z", "1979-05-27T07:32:00+00:00 (a TOML date-time)")])
def test_found_toml_dates_shown_as_python(tmp_path, value, shown):
    """A TOML date, time or date-time where a number is expected was quoted as Python writes it: "got
    datetime.date(1979, 5, 27)". Now as the file writes it, saying what TOML read."""
    path = tmp_path / "date.toml"
    path.write_text(FOUR_BAR.read_text().replace("end = 2.5", f"end = {value}"))
    code, line = run_main(["info", str(path)])
    assert (code, line) == (2, f"kinem: error: {path}: [time]: key 'end': got {shown}; expected a number"), line


def test_found_whole_numbers_past_pythons_digits(tmp_path):
    """A whole number of more than 4,300 digits (Python converts none to text: sys.get_int_max_str_digits) was an
    internal error, exit 3, where a case file gives it in hexadecimal (0xfff...: TOML reads it, the message
    could not quote it), as --set of a named dimension (--set crank=999...: the text was read as TOML) or as
    kinem.load(parameters=) (a ValueError). Now bad input that counts its digits; a decimal one in a case file
    (TOML's reader refuses it) names its line."""
    huge = "f" * 5000
    path = tmp_path / "hex.toml"
    path.write_text(FOUR_BAR.read_text().replace("steps = 250", f"steps = 0x{huge}"))
    code, line = run_main(["info", str(path)])
    assert (code, line) == (2, f"kinem: error: {path}: [time]: key 'steps': got a whole number of about 6,021 "
                               "digits; expected a whole number from 1 to 10000000"), line
    path.write_text(FOUR_BAR.read_text().replace("O2 = { body = \"ground\", at = [0.0, 0.0] }",
                                                 f"O2 = {{ body = \"ground\", at = [0x{huge}, 0.0] }}"))
    code, line = run_main(["info", str(path)])
    assert code == 2 and "point 'O2': key 'at': got a whole number of about 6,021 digits" in line, line
    path.write_text(FOUR_BAR.read_text().replace("steps = 250", "steps = " + "9" * 5000))
    code, line = run_main(["info", str(path)])
    assert code == 2 and line.startswith(f"kinem: error: {path}: line 7: "), line
    for value in ("9" * 5000, "-" + "9" * 5000, "0x" + huge):
        code, line = run_main(["info", str(NAMED), "--set", f"crank={value}"])
        assert code == 2 and "key 'crank': got a whole number of about" in line, line
    with pytest.raises(kinem.InputError, match="a whole number of about 5,000 digits"):
        kinem.load(NAMED, parameters={"crank": 10 ** 4999})
    for option in ("--steps", "--end"):
        code, line = run_main(["solve", str(FOUR_BAR), option, "9" * 5000])
        assert code == 2 and f"{option}: got a whole number of about 5,000 digits" in line, line


def test_found_a_baseline_that_never_ends(tmp_path, monkeypatch):
    """kinem report --baseline and kinem diff read a results.json whole (Path.read_text): /dev/zero grew until
    memory ran out (exit 3, MemoryError, under a 3 GB limit), a FIFO without a writer waited for ever. Now at
    most MAX_BYTES are read, a FIFO's writer waited for as a case file's (FIFO_WAIT), a directory and a file that
    is not UTF-8 said so in kinem's words; a byte order mark is read past."""
    import os

    from kinem import output
    from kinem.report import results

    monkeypatch.setattr(results, "MAX_BYTES", 1000)
    monkeypatch.setattr(output, "FIFO_WAIT", 0.2)
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    (tmp_path / "dir.json").mkdir()
    (tmp_path / "latin1.json").write_bytes('{"a": "é"}'.encode("latin-1"))
    cases = {"/dev/zero": "results /dev/zero: more than 1000 bytes; expected a results.json of kinem report",
             str(fifo): f"{fifo}: cannot read: a FIFO with no writer (waited 0.2 s)",
             str(tmp_path / "dir.json"): f"results {tmp_path / 'dir.json'}: cannot read: is a directory; expected a "
                                         "results.json of kinem report",
             str(tmp_path / "latin1.json"): f"results {tmp_path / 'latin1.json'}: cannot read: not UTF-8 text "
                                            "(byte 7); expected a results.json of kinem report"}
    for path, said in cases.items():
        code, line = run_main(["diff", path, path])
        assert (code, line) == (2, f"kinem: error: {said}"), line
    monkeypatch.setattr(results, "MAX_BYTES", 256 * 2**20)
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + (ROOT / "reports" / "baseline.json").read_bytes())
    assert results.load(bom) == results.load(ROOT / "reports" / "baseline.json")


@pytest.mark.parametrize("option", ["--samples", "--seed"])
def test_found_whole_options_read_as_python_reads_them(option):
    """tolerance --samples and --seed (and --jobs of report and stress) were read by Python's int: '٣' (a digit
    of another script) was 3 where --steps refuses it, '1e3' was refused ("invalid int value") where --steps
    reads 1000, and 5,000 nines an internal error's neighbour (refused for Python's digit limit, no word of
    why). Now as --steps reads its: a case file's number that is whole, past 3,000 digits refused saying so."""
    for text in ("٣", "2.5", "nan", "", "x"):
        code, line = run_main(["tolerance", str(FOUR_BAR), option, text])
        assert code == 2 and f"argument {option}: got {text!r}; expected a whole number as a case file writes it" \
            in line, line
    code, line = run_main(["tolerance", str(FOUR_BAR), option, "9" * 5000])
    assert code == 2 and "got a whole number of about 5,000 digits; expected one of at most 3,000" in line, line
    from kinem.cli.parser import whole_option

    assert [whole_option(t) for t in ("1e3", "0x10", "1_0", " 5", "-3")] == [1000, 16, 10, 5, -3]
