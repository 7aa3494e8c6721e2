"""Issue 30 item 4: tolerance bands (kinem.tolerance): linear worst case,
root-sum-square and Monte Carlo on the nominal's branch."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem.parameters import Tolerance, tolerances_of
from kinem.tolerance import tolerance

ROOT = Path(__file__).resolve().parents[1]
TOLS = {"points.A.at.0": 1e-4, "constraints.B.si.0": 1e-4, "points.B.at.0": {"pm": 1e-4, "sigma": 3e-5},
        "points.O4.at.0": 1e-4}


def test_four_bar_bands_nest_where_linearisation_holds():
    """With 0.1 mm tolerances on the four-bar's links, the Monte Carlo band
    lies within the worst-case linear band (to 1e-3 of its width: second
    order), the root-sum-square band within the worst case, and the table
    has the documented columns; the same seed gives the same band."""
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml").with_time(steps=50))
    b = tolerance(model, TOLS, samples=60, outputs=["B.x", "rocker.phi"], seed=3)
    assert b.table.columns[:7] == ("B.x", "B.x.worst-", "B.x.worst+", "B.x.rss-", "B.x.rss+", "B.x.mc-", "B.x.mc+")
    for c in ("B.x", "rocker.phi"):
        width = b[f"{c}.worst+"] - b[f"{c}.worst-"]
        assert (b[f"{c}.rss+"] <= b[f"{c}.worst+"] + 1e-15).all()
        assert (b[f"{c}.mc+"] <= b[f"{c}.worst+"] + 1e-3 * width).all()
        assert (b[f"{c}.mc-"] >= b[f"{c}.worst-"] - 1e-3 * width).all()
        assert (b[f"{c}.mc+"] - b[f"{c}.mc-"] > 0.3 * width).all()   # the samples spread over the band
    assert not b.rejected
    assert all(amount <= 1e-3 * np.max(b[f"{c}.worst+"] - b[f"{c}.worst-"]) for c, amount, _ in b.excess)
    again = tolerance(model, TOLS, samples=60, outputs=["B.x", "rocker.phi"], seed=3)
    assert np.array_equal(again.table.data, b.table.data)


def test_samples_off_the_branch_are_counted_not_averaged():
    """The stress suite's change-point four-bar (s + l = p + q): a longer
    crank cannot turn through (the sample cannot assemble on the way), a
    shorter one can: the failures are listed with their values and reasons,
    the band holds the others only (finite), and the nominal's change point
    makes the linear band infinite there, not a finite number."""
    case = kinem.load(ROOT / "cases" / "stress" / "change_point.toml").with_time(steps=20)
    model = kinem.compile(case)
    b = tolerance(model, {"points.A.at.0": 0.01}, samples=30, outputs=["B.x"], seed=1)
    assert 0 < len(b.rejected) < 30
    for values, why in b.rejected:
        assert set(values) == {"points.A.at.0"} and why
    assert np.isfinite(b["B.x.mc+"]).all() and np.isfinite(b["B.x.mc-"]).all()
    longest_kept = max(values["points.A.at.0"] for values, _ in b.rejected)
    assert longest_kept > 1.0   # the rejected are the longer cranks


def test_bad_tolerances_are_refused_naming_them():
    model = kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml"))
    with pytest.raises(kinem.InputError, match="did you mean"):
        tolerance(model, {"constraints.B.sii.0": 1e-4})
    with pytest.raises(kinem.InputError, match="not smaller than the mechanism"):
        tolerance(model, {"points.A.at.0": 0.5})
    with pytest.raises(kinem.InputError, match="expected a positive number"):
        tolerance(model, {"points.A.at.0": -1.0})
    # numbers no float holds, and sigmas that are not finite and positive (found by the fuzz test's
    # random profile: a 400-digit tolerance was an internal error)
    for bad in (9 * 10 ** 400, float("nan"), float("inf"), {"pm": 1e-4, "sigma": 3 * 10 ** 400},
                {"pm": 1e-4, "sigma": float("inf")}, {"pm": 1e-4, "sigma": float("nan")}, {"pm": 1e-4, "sigma": 0}):
        with pytest.raises(kinem.InputError, match=r"points\.A\.at\.0.*expected a positive number"):
            tolerance(model, {"points.A.at.0": bad})


def test_a_tolerance_beyond_a_float_in_the_file_is_bad_input(tmp_path):
    """kinem info on a case whose [tolerances] holds a 400-digit number or sigma: exit 2, one line naming
    the file and the key (it was an internal error, exit 3)."""
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    for old, new in (('"points.A.at.0" = 0.0001', '"points.A.at.0" = 9' + "0" * 400),
                     ("sigma = 0.00003", "sigma = 3" + "0" * 400)):
        bad = tmp_path / "bad.toml"
        bad.write_text(text.replace(old, new))
        r = subprocess.run([sys.executable, "-m", "kinem", "info", str(bad)], capture_output=True, text=True)
        assert r.returncode == 2 and str(bad) in r.stderr and "[tolerances]" in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and len(r.stderr) < 400


def test_case_file_section_and_cli(tmp_path):
    """cases/four_bar.toml's [tolerances] (0.1 mm on every link, one normal)
    and kinem tolerance's CSV; a bad path is one line naming the file, exit 2."""
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    case = kinem.load(ROOT / "cases" / "four_bar.toml")
    assert case.tolerances["points.A.at.0"] == 0.0001 and case.tolerances["points.O4.at.0"]["sigma"] == 0.00003
    out = tmp_path / "bands.csv"
    subprocess.run([sys.executable, "-m", "kinem", "tolerance", str(ROOT / "cases" / "four_bar.toml"),
                    "--samples", "8", "--steps", "10", "--outputs", "B.x", "--out", str(out)],
                   check=True, capture_output=True, text=True)
    head = out.read_text().splitlines()[0].split(",")
    assert head == ["t", "B.x", "B.x.worst-", "B.x.worst+", "B.x.rss-", "B.x.rss+", "B.x.mc-", "B.x.mc+"]
    assert np.isfinite(np.loadtxt(out, delimiter=",", skiprows=1)).all()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('"points.A.at.0" = 0.0001', '"points.A.at.9" = 0.0001'))
    r = subprocess.run([sys.executable, "-m", "kinem", "tolerance", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and "points.A.at.9" in r.stderr and str(bad) in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_report_design_section_and_its_key():
    """The four-bar's [report] sensitivity and [tolerances] give the report
    a design section: a table whose native-difference column is below 1e-6
    and two plots; a bad path in [report] sensitivity is the file's InputError."""
    import re

    from kinem.report.design import section

    parts = section(kinem.compile(kinem.load(ROOT / "cases" / "four_bar.toml").with_time(steps=40)))
    assert len(parts) == 4 and "Design sensitivities" in parts[0] and "Tolerance bands" in parts[2]
    rows = re.findall(r"<tr><td class=l><code>([^<]+)</code>.*?<td>([0-9.e+-]+)</td></tr>", parts[0])
    assert [r[0] for r in rows] == ["points.A.at.0", "constraints.B.si.0", "points.O4.at.0"]
    assert all(float(r[1]) < 1e-6 for r in rows)
    text = (ROOT / "cases" / "four_bar.toml").read_text().replace('"points.O4.at.0"]', '"points.O4.at.5"]')
    with pytest.raises(kinem.InputError, match="points.O4.at.5"):
        kinem.loads(text, source="fb.toml")


def test_a_normal_tolerance_without_pm_names_pm(tmp_path):
    """{ sigma = ... } without pm is that key's missing pm (it was read as a deeper path,
    'points.O4.at.0.sigma', and refused as an unknown parameter)."""
    bad = tmp_path / "bad.toml"
    bad.write_text((ROOT / "cases" / "four_bar.toml").read_text().replace(
        '"points.O4.at.0" = { pm = 0.0001, sigma = 0.00003 }', '"points.O4.at.0" = { sigma = 0.00003 }'))
    r = subprocess.run([sys.executable, "-m", "kinem", "info", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and str(bad) in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "key 'points.O4.at.0': key 'pm': missing" in r.stderr and "sigma'" not in r.stderr, r.stderr


def test_a_named_dimension_by_its_bare_name():
    """[tolerances], kinem.tolerance and kinem.sensitivity take a name of [parameters] bare, as --set and
    sweeps do (parameters.NAME), with a did-you-mean for a misspelt one; the same parameter twice is refused."""
    case = kinem.load(ROOT / "tests" / "data" / "four_bar_named.toml")
    assert tolerances_of(case, {"crank": 1e-4, "parameters.rocker": 2e-4}) == (
        Tolerance("parameters.crank", 1e-4), Tolerance("parameters.rocker", 2e-4))
    with pytest.raises(kinem.InputError, match="unknown parameter 'crnk'; did you mean 'crank'"):
        tolerances_of(case, {"crnk": 1e-4})
    with pytest.raises(kinem.InputError, match=r"'crank' and 'parameters.crank' are one parameter"):
        tolerances_of(case, {"crank": 1e-4, "parameters.crank": 1e-4})
    # kinem.sensitivity too (docs/case-format.md, "Design parameters": one scheme everywhere)
    from kinem.sensitivity import sensitivity

    model = kinem.compile(case)
    bare, path = sensitivity(model, ["crank"]), sensitivity(model, ["parameters.crank"])
    assert [p.path for p in bare.parameters] == ["parameters.crank"]
    assert bare.derivatives.columns == path.derivatives.columns
    assert np.array_equal(bare.derivatives.data, path.derivatives.data)
    # a bare name and its path given together: one parameter twice, refused wherever values are set
    for call in (lambda: kinem.solve(model, parameters={"crank": [0.1], "parameters.crank": [0.1]}),
                 lambda: kinem.sweep(ROOT / "tests" / "data" / "four_bar_named.toml",
                                     {"crank": [0.1], "parameters.crank": [0.1]})):
        with pytest.raises(kinem.InputError, match=r"'crank' and 'parameters.crank' are one parameter"):
            call()
