"""Bad input never crashes the engine-facing commands, and generated code
never holds raw user text (docs/benchmarks.md, "Fuzz campaign, session 23,
part 2"): ``kinem export`` of a case whose description and file name hold
quotes, backslashes, newlines, triple quotes, ``</``, ``<!--``, ``&``,
``${...}``, ``{}`` and unicode writes MJCF that xml.etree parses and MuJoCo
loads, and Python that compiles, each text only in quoted form; engine
settings of any size (``--dt``, ``--set ENGINE.KEY=VALUE``, a case's
[engines.NAME] table) are run or refused as bad input, never an internal
error; ``kinem diff`` of odd, truncated, nested or wrong-type JSON and
``--jobs`` of any size keep the command line's contract
(tests/test_fuzz.run_main). The report's HTML escapes the case's text.

CI runs a small derandomised budget (tests/conftest.py); KINEM_FUZZ_EXAMPLES
raises it, HYPOTHESIS_PROFILE=dev randomises it. The examples below the fuzz
tests are the failures the campaign found, each fixed."""
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from hypothesis import given, strategies as st

import kinem
from kinem.errors import InputError
from test_fuzz import SHORT, budget, run_main

ROOT = Path(__file__).resolve().parents[1]
ODD_TEXTS = ['a"b', "a'b", "a\\b", "a\nb", '"""', "'''", "</mujoco>", "<!--", "-->", "a--b", "]]>", "a&b;", "&amp;",
             "${x}", "{}", "{0}", "%s", "é漢\u2028", "<script>", "\t", "x" * 300, "__import__('os').system('x')",
             "\"); import os; (\"", "'''+1+'''"]
ENGINES = ("mujoco", "pymunk", "exudyn")


def _quoted_only(text, odd):
    """Every occurrence of ``odd`` in the generated ``text`` is inside a quoted
    or escaped form of a longer user text (a repr, never bare)."""
    return odd not in text.replace(repr(odd), "")


@budget(10)
@given(description=st.sampled_from(ODD_TEXTS), file_name=st.sampled_from(ODD_TEXTS),
       engine=st.sampled_from(ENGINES))
def test_export_quotes_user_text(tmp_path_factory, description, file_name, engine):
    """An exported model stays valid whatever the case's description and
    file name hold; no user text becomes code."""
    tmp = tmp_path_factory.mktemp("export")
    folder = tmp / file_name.replace("/", "_")[:100].replace("\x00", "_")
    folder.mkdir()
    case = folder / "case.toml"
    case.write_text(SHORT.replace('description = "', f"description = {json.dumps('kinem-fuzz:' + description)} # ", 1))
    out = tmp / ("model.xml" if engine == "mujoco" else "model.py")
    code, _ = run_main(["export", str(case), "--engine", engine, "--out", str(out)])
    assert code == 0
    text = out.read_text()
    if engine == "mujoco":
        import mujoco

        ET.fromstring(text)
        mujoco.MjModel.from_xml_path(str(out))
    else:
        compile(text, str(out), "exec")
        assert repr(str(case)) in text and _quoted_only(text, str(case))   # the source path a Python literal
    assert "kinem-fuzz:" + description not in text          # the description is not exported at all


SETTING_VALUES = ["1", "0", "-1", "1e-300", "1e300", "5e-324", "99999999999", "2000", "2001", "nan", "inf", "x",
                  "auto", "true", "[1, 2]", "10**400", "9" * 400, "1e-9"]


_MODELS = {}


def models(steps):
    """The slider-crank over ``steps`` output intervals (compiled once)."""
    if steps not in _MODELS:
        import tempfile

        with tempfile.TemporaryDirectory(prefix="kinem-fuzz-") as d:
            case = Path(d) / "case.toml"
            case.write_text(SHORT.replace("steps = 2", f"steps = {steps}")
                            .replace("end = 0.02", f"end = {0.01 * steps}"))
            _MODELS[steps] = kinem.compile(kinem.load(str(case)))
    return _MODELS[steps]


@budget(20)
@given(engine=st.sampled_from(ENGINES), key=st.sampled_from(["dt", "substeps"]), value=st.sampled_from(SETTING_VALUES),
       steps=st.sampled_from([1, 2, 5000]))
def test_engine_settings_of_any_size(engine, key, value, steps):
    """An engine's settings resolved for a case (the step every command takes
    before an engine runs: compare, report, animate, export): either a step
    and substeps within the caps, or an InputError naming the setting."""
    from adapters import get
    from adapters.base import MAX_RUN_STEPS, MAX_SUBSTEPS, start

    model = models(steps)
    adapter = get(engine)
    try:
        v = json.loads(value)
    except ValueError:
        v = value
    try:
        s = adapter.settings({key: v})
        n = adapter.resolve(model, s, *start(model))
    except InputError as e:
        assert "\n" not in str(e)
        assert "setting" in str(e)
        return
    assert 1 <= n and (n <= MAX_SUBSTEPS or n * (len(model.times) - 1) <= MAX_RUN_STEPS)


JSON_TEXTS = ["", "{", '{"cases": [', "[]", "3", '"x"', "null", "NaN", "{}", '{"cases": 3}', '{"schema_version": 5}',
              '{"schema_version": 5, "cases": "x"}', "[" * 100_000 + "]" * 100_000,
              '{"a":' * 50_000 + "1" + "}" * 50_000,
              "\ufeff{}", '{"schema_version": 1e400}', '{"schema_version": 5, "cases": [{"name": []}]}']


@budget(12)
@given(text=st.one_of(st.sampled_from(JSON_TEXTS), st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(["schema_version", "cases", "meta",
                                                                                  "name", "runs"]), inner, max_size=3),
    max_leaves=8).map(json.dumps)), first=st.booleans())
def test_diff_of_odd_json(tmp_path_factory, text, first):
    """kinem diff of a file that is not a results.json: exit 2, one line."""
    odd = tmp_path_factory.mktemp("diff") / "odd.json"
    odd.write_text(text)
    good = str(ROOT / "reports" / "baseline.json")
    code, line = run_main(["diff"] + ([str(odd), good] if first else [good, str(odd)]))
    assert code == 2 and "odd.json" in line


@pytest.mark.parametrize("engine, key", [("pymunk", "iterations"), ("pymunk", "substeps"), ("mujoco", "iterations"),
                                         ("exudyn", "newton_max_iterations")])
def test_found_a_count_written_1e3_is_read_as_steps_reads_it(engine, key):
    """--set pymunk.iterations=1e3 (JSON's float) was refused where --steps 1e3 is read as 1,000 (session 30's
    fuzz campaign, left): a whole float given for a count is that count, as an int; 2.5 and 1e30 stay refused."""
    from adapters import settings

    s = settings(engine, {key: 1e3}, "--set")
    assert s[key] == 1000 and type(s[key]) is int
    for bad in (2.5, 1e30, -1e3):
        with pytest.raises(InputError, match=f"setting '{key}' = "):
            settings(engine, {key: bad}, "--set")


@pytest.mark.parametrize("text, kind", [("[1, 2]", "array"), ('"x"', "string"), ("null", "null"),
                                        ("true", "boolean"), ("3.5", "number")])
def test_found_baseline_not_an_object_names_its_kind(tmp_path, text, kind):
    """A baseline that is JSON but not an object was refused as "schema_version None" (session 30's fuzz
    campaign, left): now it says what it is and that an object is expected."""
    odd = tmp_path / "odd.json"
    odd.write_text(text)
    code, line = run_main(["diff", str(odd), str(ROOT / "reports" / "baseline.json")])
    assert code == 2 and f"odd.json: a JSON {kind}; expected a results.json of kinem report (a JSON object)" in line


@pytest.mark.parametrize("args", [
    ["stress", "--jobs", "99999999999", "--engines", "native", "--quick"],
    ["stress", "--jobs", "-1", "--engines", "native", "--quick"],
    ["report", "--jobs", "99999999999", "cases/four_bar.toml", "--out", "NOWHERE"],
    ["report", "--jobs", "-1", "cases/four_bar.toml", "--out", "NOWHERE"],
])
def test_found_jobs_out_of_range(args):
    """--jobs beyond a C int was an OverflowError (exit 3) in stress; -1 was
    run as no workers in stress (report refused it): both refused, alike."""
    code, line = run_main(args)
    assert code == 2 and line.startswith("kinem: error: --jobs: got ")


@pytest.mark.parametrize("option", [["--dt", "1e-300"], ["--set", "pymunk.substeps=2000000000"],
                                    ["--set", "pymunk.dt=1e-300"], ["--set", "mujoco.substeps=2000000000"],
                                    ["--set", "exudyn.dt=1e-300"], ["--set", "mujoco.dt=5e-324"]])
def test_found_compare_steps_beyond_memory(tmp_path, option):
    """compare with a step giving 1e298 (or 1e11) steps per output interval:
    a MemoryError or ValueError in pymunk's and MuJoCo's step tables (exit 3),
    Exudyn ran until stopped. Now bad input naming the setting."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    engine = option[1].split(".")[0] if option[0] == "--set" else "pymunk"
    code, line = run_main(["compare", str(case), "--engines", engine] + option)
    assert code == 2 and "steps per output interval" in line


@pytest.mark.parametrize("option", ["pymunk.substeps=99999999999", "pymunk.iterations=99999999999",
                                    "pymunk.dt=" + "9" * 400, "exudyn.substeps=" + "9" * 400, "mujoco.tolerance=1e400",
                                    "mujoco.iterations=" + "9" * 40])
def test_found_settings_beyond_a_float_or_a_c_int(tmp_path, option):
    """A whole number of 400 digits as dt or substeps was an OverflowError
    (int too large to convert to float), exit 3; counts beyond a C int reach
    the engines as C ints. Now each setting's check refuses them."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["compare", str(case), "--engines", option.split(".")[0], "--set", option])
    assert code == 2 and f"setting '{option.split('.')[1].split('=')[0]}'" in line


def test_found_engines_table_beyond_memory(tmp_path):
    """The same setting from a case's [engines.NAME] table: refused by export too."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT + "\n[engines.pymunk]\nsubsteps = 99999999999\n")
    code, line = run_main(["export", str(case), "--engine", "pymunk", "--out", str(tmp_path / "m.py")])
    assert code == 2 and "[engines.pymunk]: key 'substeps': got 99999999999" in line
    assert not (tmp_path / "m.py").exists()


def test_found_diff_of_deeply_nested_json(tmp_path):
    """JSON nested 100,000 deep: RecursionError, exit 3; now not JSON, exit 2."""
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    code, line = run_main(["diff", str(ROOT / "reports" / "baseline.json"), str(deep)])
    assert code == 2 and "not JSON" in line


def test_diff_of_an_empty_path_names_it(tmp_path):
    """kinem diff '' B.json: no file named (the empty path was read as the current folder: "cannot read:
    Is a directory: '.'"), exit 2, one line (run_main checks the line)."""
    code, err = run_main(["diff", "", str(tmp_path / "b.json")])
    assert code == 2 and "results '': no file named" in err, err
