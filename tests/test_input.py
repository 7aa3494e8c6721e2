"""Issue 17, input: every number, name, time and step count in its documented
range, at load and on the command line by the same rules, each bad value one
line with exit code 2; one problem per root cause, with "did you mean"; a
capped message; --errors all; the generated tables of docs/case-format.md."""
import contextlib
import io
import subprocess
import sys
from pathlib import Path

import pytest

import kinem
from kinem.cli import main

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"
SLIDER = (CASES / "slider_crank.toml").read_text()


def cli(*args):
    """kinem in-process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def one_error(tmp_path, text, *extra, command="info"):
    """The one stderr line of a run on a case file with this text (exit 2 asserted)."""
    path = tmp_path / "case.toml"
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    code, _, err = cli(command, path, *extra)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("kinem: error: ") and "internal error" not in err
    return lines[0]


# -- numbers, times and step counts --------------------------------------

@pytest.mark.parametrize("old,new,needle", [
    ("steps = 500", "steps = " + "9" * 40, "steps"),                                       # 40-digit integer
    ("crank  = { q = [-86.6, 50.0, 5.76] }", "crank  = { q = [-86.6, 5" + "0" * 40 + ", 5.76] }", "q"),
    ("crank  = { q = [-86.6, 50.0, 5.76] }", "crank  = { q = [-86.6, 5" + "0" * 400 + ", 5.76] }", "q"),
    ("steps = 500", "steps = " + "1" * 5000, "digits"),                                    # beyond int('...')
    ("steps = 500", "dt = 5e-324", "key 'dt'"),                                           # end/dt overflows
    ("steps = 500", "dt = 1e-300", "key 'dt'"),
    ("end = 5.0", "end = 1e300", "key 'end'"),
    ("end = 5.0", "end = 1e-300", "key 'end'"),
])
def test_numbers_out_of_range_are_one_line_exit_2(tmp_path, old, new, needle):
    assert old in SLIDER
    line = one_error(tmp_path, SLIDER.replace(old, new))
    assert needle in line and len(line) < 600, line


@pytest.mark.parametrize("qj", ["[5e-324, 0.0]", "[1e-13, 0.0]"])
def test_translation_line_too_short(tmp_path, qj):
    """Found by the 5,000-case fuzz run: a line through [0, 0] and [5e-324, 0] overflowed its normal
    and `info` ended in numpy's "SVD did not converge" (exit 3)."""
    text = (CASES / "quick_return_3.toml").read_text()
    assert "qj = [100.0, 0.0]" in text
    line = one_error(tmp_path, text.replace("qj = [100.0, 0.0]", f"qj = {qj}"))
    assert "key 'qj'" in line and "too short" in line


def test_large_integer_in_engine_settings(tmp_path):
    line = one_error(tmp_path, SLIDER + "\n[engines.pymunk]\niterations = " + "7" * 400 + "\n")
    assert "[engines.pymunk]: key 'iterations'" in line


@pytest.mark.parametrize("args,needle", [
    (("--end", "inf"), "--end: got inf"),
    (("--end", "1e300"), "--end: got 1e+300"),
    (("--end", "nan"), "--end: got nan"),
    (("--end", "-1"), "--end: got -1"),
    (("--steps", "1e8"), "--steps: got 100000000; expected a whole number from 1 to 10000000"),
    (("--steps", "100000000"), "--steps: got 100000000"),
    (("--steps", "0"), "--steps: got 0"),
    (("--steps", "2.5"), "--steps: got 2.5"),
])
def test_command_line_times_by_the_case_file_rules(tmp_path, args, needle):
    out = tmp_path / "o.csv"
    code, _, err = cli("solve", CASES / "slider_crank.toml", "--out", out, *args)
    assert code == 2 and len(err.splitlines()) == 1 and needle in err, err
    assert not out.exists()


def test_same_rule_for_end_in_file_and_on_command_line(tmp_path):
    """1e10 s is beyond the documented end range both ways, with the same expectation."""
    in_file = one_error(tmp_path, SLIDER.replace("end = 5.0", "end = 1e10"))
    _, _, on_line = cli("solve", CASES / "slider_crank.toml", "--end", "1e10")
    expected = in_file.split("; expected ")[1]
    assert on_line.strip().endswith("; expected " + expected), (in_file, on_line)


def test_driver_table_times_too_close(tmp_path):
    text = SLIDER.replace('d = { poly = [5.76, -1.2] }', 'd = { table = { t = [0, 1e-300, 2e-300, 5], value = [5.76, 5.7, 5.6, 0] } }')
    assert text != SLIDER
    line = one_error(tmp_path, text, "--steps", "3", command="solve")
    assert "key 'd.table.t'" in line and "apart" in line


def test_table_times_close_but_resolvable_are_accepted():
    """Gaps of 1e-6 of the span are above the 1e-9 limit."""
    text = SLIDER.replace('d = { poly = [5.76, -1.2] }',
                          'd = { table = { t = [0, 1e-6, 1, 5], value = [5.76, 5.76, 4.5, 0] } }')
    assert kinem.loads(text).constraints[-1]["d"].t[1] == 1e-6


# -- names -----------------------------------------------------------------

@pytest.mark.parametrize("old,new", [
    ('name = "slider_crank"', 'name = "slider_crank\\n"'),
    ("rod    = { q", '"rod\\n" = { q'),
    ('B = { body = "crank"', '"B\\n" = { body = "crank"'),
    ('name = "O"', 'name = "O\\n"'),
    ('name = "O"', 'name = "' + "O" * 65 + '"'),
])
def test_names_full_match(tmp_path, old, new):
    """A trailing newline is not part of a name (the pattern must match all of it)."""
    assert old in SLIDER
    line = one_error(tmp_path, SLIDER.replace(old, new))
    assert "\\n" in line or "O" * 65 in line or "OOO" in line, line


# -- engines, files, units ---------------------------------------------------

def test_engine_list_longer_than_16_is_reported(tmp_path):
    line = one_error(tmp_path, SLIDER + "\n[engines.mujoco]\ngains = [" + ", ".join(["1.0"] * 17) + "]\n")
    assert "[engines.mujoco]: key 'gains'" in line and "1 to 16 numbers" in line


def test_file_read_with_a_hard_cap(tmp_path):
    """/dev/zero has size 0 by stat() and no end: it must be read only up to the cap (16 MiB)."""
    code, _, err = cli("solve", "/dev/zero")
    assert code == 2 and "more than 16777216 bytes" in err and len(err.splitlines()) == 1


@pytest.mark.parametrize("unit", ["a\nb", "x" * 33, ""])
def test_units_length_range(tmp_path, unit):
    text = SLIDER.replace('units = { length = "mm" }', 'units = { length = %s }' % _toml_str(unit))
    assert "key 'length'" in one_error(tmp_path, text)


def _toml_str(s):
    import json
    return json.dumps(s)


def test_units_are_shown_as_text_not_mathtext():
    """A unit with $...$ is a valid unit string; the report's plot labels show it as text."""
    import numpy as np
    from kinem.report import plots

    case = kinem.loads(SLIDER.replace('units = { length = "mm" }', 'units = { length = "$\\\\frac{$" }'))
    t = np.linspace(0.0, 1.0, 5)
    assert plots.trajectories(t, {"slider.x": t}, {}, unit=case.length_unit)  # no ParseSyntaxException


# -- errors: one per root cause, did you mean, capped, --errors all ----------

def problems(text):
    with pytest.raises(kinem.InputError) as e:
        kinem.loads(text, source="x.toml")
    return e.value.problems


def test_typo_of_required_key_is_one_problem_with_suggestion():
    p = problems(SLIDER.replace("sj = [-100.0, 0.0]", "sjj = [-100.0, 0.0]"))
    assert p == ("x.toml: constraint 3 ('B', revolute): key 'sjj': unknown key; did you mean 'sj'?",)


def test_bad_body_name_gives_no_knock_on_errors():
    """A body rejected for its name is one problem; constraints and points that name it add none."""
    text = SLIDER.replace('"crank"', '"crank arm"').replace("crank  = { q", '"crank arm" = { q')
    p = problems(text)
    assert len(p) == 1 and "body 'crank arm': bad name" in p[0], p


def test_four_mistakes_four_messages():
    text = (SLIDER.replace('"crank"', '"crank arm"').replace("crank  = { q", '"crank arm" = { q')  # 1: a bad name
            .replace("sj = [-100.0, 0.0]", "sjj = [-100.0, 0.0]")          # 2: a key typo
            .replace('type = "translational"', 'type = "translatonal"')    # 3: a type typo
            .replace("steps = 500", "steps = 0"))                          # 4: a bad step count
    p = problems(text)
    assert len(p) == 4, p
    assert any("did you mean 'translational'?" in x for x in p)


@pytest.mark.parametrize("old,new,hint", [
    ('j = "crank"\nsj = [-100.0, 0.0]', 'j = "crnak"\nsj = [-100.0, 0.0]', "unknown body 'crnak'; did you mean 'crank'?"),
    ('sj = [-100.0, 0.0]', 'sj = "b"', "unknown point 'b'; did you mean 'B'?"),
    ('type = "revolute"\nname = "O"', 'type = "revolut"\nname = "O"', "unknown type 'revolut'; did you mean 'revolute'?"),
    ("[time]", "[tim]", "key 'tim': unknown key; did you mean 'time'?"),
])
def test_did_you_mean(old, new, hint):
    assert old in SLIDER
    p = problems(SLIDER.replace(old, new))
    assert len(p) == 1 and hint in p[0], p


@pytest.mark.parametrize("section", ["time", "bodies", "constraints"])
def test_missing_section_is_one_problem(section):
    """A misspelt or missing section is reported once, not again by every value that needs it."""
    import tomllib

    d = tomllib.loads(SLIDER)
    d[section[:-1] + "_"] = d.pop(section)
    with pytest.raises(kinem.InputError) as e:
        kinem.load_dict(d, source="x.toml")
    assert len(e.value.problems) == 1, e.value.problems


def test_unknown_type_line_is_short():
    p = problems(SLIDER.replace('type = "revolute"\nname = "O"', 'type = "zzzzzz"\nname = "O"'))
    assert len(p) == 1 and len(p[0]) < 400, p


def many_bad_constraints(n):
    good = SLIDER
    return good + "".join(f'\n[[constraints]]\ntype = "revolute"\ni = "crank"\nsi = [{k}.0, nan]\nj = "rod"\nsj = [0.0, 0.0]\n'
                          for k in range(n))


def test_long_error_list_is_capped_in_a_stable_form(tmp_path):
    line = one_error(tmp_path, many_bad_constraints(2000))
    assert line.endswith(" (and 1997 more; --errors all lists them)"), line[-80:]
    assert len(line) < 2000


def test_errors_all_lists_every_problem_one_a_line(tmp_path):
    path = tmp_path / "case.toml"
    path.write_text(many_bad_constraints(50))
    code, _, err = cli("info", path, "--errors", "all")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 50 and all(x.startswith("kinem: error: ") for x in lines)


def test_one_problem_per_line_even_with_control_characters():
    p = problems(SLIDER.replace("rod    = { q", '"r\\u0007od\\r" = { q'))
    assert all(x.isprintable() for x in p)


# -- the generated tables of docs/case-format.md -------------------------------

def test_case_format_tables_are_generated_and_current():
    from kinem.constraints import docs

    text = (ROOT / "docs" / "case-format.md").read_text()
    assert docs.render(text) == text, "run: python -m kinem.constraints.docs"


def test_every_declared_key_is_documented():
    from kinem.constraints import REGISTRY, docs

    table = docs.keys()
    for name, decl in REGISTRY.items():
        for k in decl.keys:
            assert f"| `{name}` | `{k.name}` | {k.accepts} |" in table


# -- issue 32: angles in degrees, and speeds that look like degrees ---------------------------------

def test_angles_in_degrees_are_converted_once():
    import math

    import numpy as np

    import kinem

    text = (ROOT / "cases" / "slider_crank.toml").read_text()
    deg = (text.replace('units = { length = "mm" }', 'units = { length = "mm", angle = "deg" }')
           .replace("5.76]", f"{math.degrees(5.76)!r}]").replace("0.2]", f"{math.degrees(0.2)!r}]")
           .replace("[5.76, -1.2]", f"[{math.degrees(5.76)!r}, {math.degrees(-1.2)!r}]"))
    assert deg.count("angle = \"deg\"") == 1 and "5.76]" not in deg and "-1.2]" not in deg
    a, b = kinem.load(ROOT / "cases" / "slider_crank.toml"), kinem.loads(deg)
    assert b.units["angle"] == "deg"
    for x, y in zip(a.bodies, b.bodies):
        assert abs(x.q[2] - y.q[2]) <= 1e-15 * 7, (x, y)
    ra, rb = (kinem.solve(kinem.compile(c)) for c in (a, b))
    for col in ("A.x", "B.y", "crank.phi", "rod.omega"):   # outputs stay in radians
        np.testing.assert_allclose(rb.trajectory[col], ra.trajectory[col], rtol=0, atol=1e-12 * 700)


def test_degrees_reach_every_angle_key():
    import math

    import kinem
    from kinem import functions as fn

    case = kinem.loads("""
        name = "d"
        units = { angle = "deg" }
        [time]
        end = 1.0
        steps = 1
        [bodies]
        g = { q = [0.0, 0.0, 90.0] }
        b = { q = [0.0, 0.0, 180.0] }
        [[constraints]]
        type = "ground"
        body = "g"
        value = [0.0, 0.0, 90.0]
        [[constraints]]
        type = "absolute"
        body = "b"
        coord = "phi"
        value = 45.0
        [[constraints]]
        type = "driver"
        body = "b"
        coord = "x"
        d = { harmonic = { amplitude = 2.0, omega = 180.0, phase = 90.0 } }
        [[constraints]]
        type = "driver"
        body = "b"
        coord = "phi"
        d = { poly = [30.0, 360.0] }
        [[constraints]]
        type = "point-follower"
        i = "b"
        si = [0.0, 0.0]
        j = "g"
        outline = { spline = { theta = [0.0, 90.0, 180.0, 270.0, 360.0], s = [1.0, 2.0, 1.0, 2.0, 1.0], periodic = true } }
        theta = 45.0
    """)
    c = case.constraints
    q = math.pi / 180
    assert case.bodies[0].q[2] == 90 * q and c[0]["value"][2] == 90 * q and c[1]["value"] == 45 * q
    assert c[2]["d"] == fn.Harmonic(2.0, 180 * q, 90 * q, 0.0)      # x: the amplitude is a length
    assert c[3]["d"] == fn.Poly((30 * q, 360 * q))
    assert c[4]["theta"] == 45 * q and abs(c[4]["outline"].theta[-1] - 2 * math.pi) < 1e-15


def test_a_crank_speed_that_looks_like_degrees_is_warned(tmp_path):
    import warnings

    import kinem
    from kinem import cli

    text = (ROOT / "cases" / "slider_crank.toml").read_text().replace("[5.76, -1.2]", "[5.76, 360.0]")
    with pytest.warns(kinem.KinemWarning, match=r"constraint 6 \('crank-drive', driver\): turns body 'crank' at "
                                                r"up to 360 rad/s .* that is 6.283 rad/s"):
        kinem.loads(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kinem.load(ROOT / "cases" / "slider_crank.toml")   # 1.2 rad/s: no warning
    path = tmp_path / "fast.toml"
    path.write_text(text)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert cli.main(["info", str(path)]) == 0
    (line,) = err.getvalue().splitlines()
    assert line.startswith("kinem: warning: ") and "units = { angle = \"deg\" }" in line


@pytest.mark.parametrize("key,value", [("times", [0.0, 10 ** 400]), ("q0", [10 ** 400] * 12)])
def test_solve_arguments_beyond_a_float_are_bad_input(key, value):
    """kinem.solve's times and q0 holding a whole number no float holds: an InputError naming the
    argument (it was numpy's OverflowError)."""
    model = kinem.compile(kinem.load(CASES / "slider_crank.toml"))
    with pytest.raises(kinem.InputError, match=f"solve: {key} "):
        kinem.solve(model, **{key: value})


def test_odd_api_values_are_bad_input():
    """kinem.loads of no text, and every solver option given a number no float holds, NaN, a bool, a text
    or a list: an InputError (loads(3) was an AttributeError, max_iterations=10**400 an OverflowError)."""
    import dataclasses

    with pytest.raises(kinem.InputError, match="expected a case file's TOML text"):
        kinem.loads(3)
    for f in dataclasses.fields(kinem.Options):
        for v in (10 ** 400, -10 ** 400, float("nan"), True, "x", [1]):
            try:
                kinem.Options(**{f.name: v})
            except kinem.InputError:
                pass   # (a value an option takes, e.g. True for jacobian_reuse, is fine too)


def test_a_trajectory_column_that_is_no_name_is_unknown():
    """traj[[1, 2]] (a list, unhashable) is the same UnknownColumn as any other missing name (it was a
    TypeError); still a KeyError too."""
    from kinem.errors import UnknownColumn

    traj = kinem.solve(kinem.compile(kinem.load(CASES / "slider_crank.toml")), times=[0.0, 0.01]).trajectory
    for name in ([1, 2], {}, None, 3):
        with pytest.raises(UnknownColumn, match="no column"):
            traj[name]
        with pytest.raises(KeyError):
            traj[name]


@pytest.mark.parametrize("data", [None, 3, "x"])
def test_the_stages_refuse_what_is_no_data(data):
    """kinem.factorize, velocity and acceleration given something that is no kinem.Data: the InputError
    naming data (factorize read data.t first: an AttributeError)."""
    model = kinem.compile(kinem.load(CASES / "slider_crank.toml"))
    for stage in (kinem.factorize, kinem.velocity, kinem.acceleration):
        with pytest.raises(kinem.InputError, match=f"{stage.__name__}: data "):
            stage(model, data)
