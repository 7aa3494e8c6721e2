"""The report's independent references (adapters.references,
kinem.reference): every repository case's closed form against native, each
closed form's rates against its own central differences (no kinem in
that), random dimensions for the gears, the rack and the cams, refusal of a
geometry a closed form does not fit, and a wrong native failing the report
with the figure named."""
import copy
import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import kinem
from kinem.options import Options
from adapters import references

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted(p.stem for p in (ROOT / "cases").glob("*.toml"))
# Native converges to a scaled residual of 1e-12; measured against the closed forms it sits at
# 1e-16 .. 1.2e-14 (of L, of the rates' peaks). 1e-12 leaves room for another machine's rounding.
AGREE = 1e-12


def _solve(path_or_case, tolerance=None):
    case = kinem.load(path_or_case) if isinstance(path_or_case, (str, Path)) else path_or_case
    model = kinem.compile(case)
    options = Options.of(case) if tolerance is None else dataclasses.replace(Options.of(case), tolerance=tolerance)
    result = kinem.solve(model, options=options)
    assert result.success, result.message
    return model, result


@pytest.fixture(scope="module")
def solved():
    return {name: _solve(ROOT / "cases" / f"{name}.toml") for name in CASES}


def test_every_case_has_a_closed_form(solved):
    assert set(CASES) <= set(references.CLOSED_FORMS)
    for name, (model, r) in solved.items():
        assert references.closed_form(model, r) is not None, name


@pytest.mark.parametrize("name", CASES)
def test_closed_form_agrees_with_native(solved, name):
    """Positions / L, velocities and accelerations / their peaks within AGREE."""
    model, r = solved[name]
    cf = references.closed_form(model, r)
    f = references.error(model, r.trajectory, cf)
    assert f.position_rel < AGREE and f.velocity_rel < AGREE and f.acceleration_rel < AGREE, (name, f)
    moving = sum(np.ptp(np.abs(m[0])) > 0 for m in references._motions(cf))
    assert moving, name   # the closed form is not a still picture


class Shifted:
    """A trajectory seen at other instants: row 0 (the t = 0 configuration,
    all a closed form reads of it) first, then ``times``."""

    def __init__(self, traj, times):
        self._traj, self.t = traj, np.concatenate([[traj.t[0]], times])

    def __getitem__(self, column):
        return np.full(len(self.t), self._traj[column][0])


@pytest.mark.parametrize("name", CASES)
def test_rates_are_the_closed_forms_own_derivatives(solved, name):
    """v and a of each closed form against central differences of its own p
    and v, no kinem solve involved: h = 1e-5 s (truncation h^2 |p'''| / 6,
    and h |jump of p'''| where the difference straddles a spline knot, below
    1e-6 of the peak; rounding eps |p| / h about 1e-10 of it)."""
    model, r = solved[name]
    make = references.CLOSED_FORMS[name]
    h = 1e-5
    t = r.trajectory.t[1:-1:max(1, len(r.trajectory.t) // 25)]
    at = {s: make(model, Shifted(r.trajectory, t + s * h)) for s in (-1, 0, 1)}
    for k, (lo, mid, hi) in enumerate(zip(*(list(references._motions(at[s])) for s in (-1, 0, 1)))):
        for order in (1, 2):
            fd = (hi[order - 1][1:] - lo[order - 1][1:]) / (2 * h)
            peak = max(np.max(np.abs(mid[order][1:])), 1e-9 * model.length)
            assert np.max(np.abs(fd - mid[order][1:])) < 1e-6 * peak, (name, k, order)


# -- random dimensions: the closed form against kinem.solve of the same mechanism ---------------

def _case(name):
    with open(ROOT / "cases" / f"{name}.toml", "rb") as f:
        data = tomllib.load(f)
    data["time"] = {"end": 1.0, "steps": 12}
    return data


def _named(data, name):
    return next(c for c in data["constraints"] if c.get("name") == name)


def _check(data, name):
    model, r = _solve(kinem.load_dict(data, source=f"random {name}"))
    cf = references.closed_form(model, r)
    assert cf is not None
    f = references.error(model, r.trajectory, cf)
    assert f.position_rel < AGREE and f.velocity_rel < AGREE and f.acceleration_rel < AGREE, f


FAST = settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
poly = st.tuples(st.floats(-1, 1), st.floats(0.5, 3), st.floats(-1, 1))


@FAST
@given(st.floats(10, 80), st.floats(10, 80), st.floats(-0.5, 0.5), poly)
def test_gear_pair_random(ri, rj, phi2, d):
    data = _case("gear_pair")
    data["bodies"]["gear1"]["q"] = [0.0, 0.0, d[0]]
    data["bodies"]["gear2"]["q"] = [ri + rj, 0.0, phi2]
    _named(data, "O2")["sj"] = [ri + rj, 0.0]
    mesh = _named(data, "mesh")
    mesh["ri"], mesh["rj"] = ri, rj
    _named(data, "motor")["d"] = {"poly": list(d)}
    _check(data, "gear_pair")


@FAST
@given(st.floats(10, 40), st.floats(-1.5, 1.5), st.floats(0.2, 2.0), st.floats(0.5, 4.0))
def test_rack_pinion_random(radius, incline, amplitude, omega):
    data = _case("rack_pinion")
    foot = radius * np.exp(1j * (incline - np.pi / 2))          # -radius n: the pitch line below the centre
    data["bodies"]["rack"]["q"] = [foot.real, foot.imag, incline]
    data["points"]["line"]["at"] = [foot.real, foot.imag]
    _named(data, "mesh")["radius"] = radius
    _named(data, "motor")["d"] = {"harmonic": {"amplitude": amplitude, "omega": omega}}
    _check(data, "rack_pinion")


@FAST
@given(st.floats(15, 40), st.floats(0.1, 0.9), poly)
def test_flat_faced_cam_random(radius, eccentricity, d):
    data = _case("cam_flat_eccentric")
    e = eccentricity * radius
    data["bodies"]["cam"]["q"] = [0.0, 0.0, d[0]]
    data["bodies"]["follower"]["q"] = [0.0, radius + e * np.sin(d[0]), 0.0]
    contact = _named(data, "contact")
    contact["outline"] = {"circle": {"radius": radius}, "center": [e, 0.0]}
    contact["theta"] = np.pi / 2 - d[0]
    _named(data, "camshaft-drive")["d"] = {"poly": list(d)}
    _check(data, "cam_flat_eccentric")


@FAST
@given(st.floats(15, 40), st.floats(3, 12), st.floats(0.1, 0.8), poly)
def test_roller_cam_random(radius, roller, eccentricity, d):
    data = _case("cam_roller_circle")
    e, rho = eccentricity * radius, radius + roller
    centre = e * np.exp(1j * d[0])
    height = centre.imag + np.sqrt(rho**2 - centre.real**2)     # Example 4.4's d at phi = d0
    data["bodies"]["cam"]["q"] = [0.0, 0.0, d[0]]
    data["bodies"]["follower"]["q"] = [0.0, height + 15.0, 0.0]
    contact = _named(data, "contact")
    contact["outline"] = {"circle": {"radius": radius}, "center": [e, 0.0]}
    contact["radius"] = roller
    contact["theta"] = float(np.angle(1j * height - centre)) - d[0]
    _named(data, "camshaft-drive")["d"] = {"poly": list(d)}
    _check(data, "cam_roller_circle")


@FAST
@given(st.lists(st.floats(3.0, 5.0), min_size=12, max_size=12), st.floats(1.0, 8.0))
def test_spline_cam_random(table, omega):
    data = _case("cam_table41")
    s = table + table[:1]                                          # periodic: s(360) = s(0)
    contact = _named(data, "contact")
    contact["outline"]["spline"].update(theta=list(range(0, 361, 30)), s=s)
    data["bodies"]["follower"]["q"] = [0.0, s[3], 0.0]             # the tip at theta = 90 degrees
    _named(data, "camshaft-drive")["d"] = {"poly": [0.0, omega]}
    _check(data, "cam_table41")


# -- refusal ----------------------------------------------------------------------------------

def _refused(data, name):
    model, r = _solve(kinem.load_dict(data, source=f"refused {name}"))
    return references.closed_form(model, r) is None


def test_a_geometry_the_closed_form_does_not_fit_gets_none():
    """Each closed form refuses a case of its name that is another mechanism."""
    data = _case("gear_pair")
    _named(data, "mesh")["rj"] = 55.0                                # centres 100 apart, radii 40 + 55
    assert _refused(data, "gear_pair")
    data = _case("cam_roller_circle")
    _named(data, "guide")["sj"] = [6.0, 0.0]                         # the roller's line misses the camshaft
    data["bodies"]["follower"]["q"] = [6.0, 50.0, 0.0]
    assert _refused(data, "cam_roller_circle")
    data = _case("cam_table41")
    _named(data, "guide")["sj"] = [1.0, 0.0]                         # an offset follower, not a radial one
    data["bodies"]["follower"]["q"] = [1.0, 12.0, 0.0]
    assert _refused(data, "cam_table41")
    data = _case("rack_pinion")
    _named(data, "guide")["qi"] = [100.0, 5.0]                       # the guide is not along the pitch line
    assert _refused(data, "rack_pinion")
    data = _case("rolling_pinion")
    _named(data, "centre-line")["qj"] = [100.0, 25.0]                # the centre's line is not the pitch line's
    assert _refused(data, "rolling_pinion")
    data = _case("cam_flat_eccentric")
    _named(data, "contact")["normal"] = [0.1, 1.0]                   # a face not normal to the guide
    assert _refused(data, "cam_flat_eccentric")
    data = _case("four_bar")
    data["name"] = "planetary"                                       # another mechanism under the name
    assert _refused(data, "planetary")
    data = _case("pin_in_slot")
    data["constraints"] = [c for c in data["constraints"] if c.get("name") != "no-spin"]
    data["constraints"].append({"type": "driver", "name": "spin", "body": "pin", "coord": "phi",
                                "d": {"poly": [0.0, 1.0]}})        # a turning pin: not Eq. 4.30's still one
    assert _refused(data, "pin_in_slot")


# -- a wrong native fails the report, the figure named ----------------------------------------

def _report(tmp_path, monkeypatch, patch):
    from kinem.report import Options as ReportOptions
    from kinem.report import run
    from kinem.report.text import exceeded_text, passed

    text = (ROOT / "cases" / "gear_pair.toml").read_text().replace("steps = 200", "steps = 20")
    (tmp_path / "gear_pair.toml").write_text(text)
    patch()
    out = run(ReportOptions(cases=(str(tmp_path / "gear_pair.toml"),), engines=(), out=str(tmp_path / "o"),
                            quick=True, workers=0, progress=False))
    doc = out.value.doc
    native = doc["cases"][0]["runs"][0]
    return out, doc, native, exceeded_text(native), passed(doc)


def test_a_wrong_native_position_fails_the_report(tmp_path, monkeypatch):
    """A closed form whose gear ratio is off by 1e-7 stands for a native whose
    is: the native cell fails, naming position_error_rel and its limit."""
    from kinem import reference

    right = reference.gear_pair
    out, doc, native, over, ok = _report(tmp_path, monkeypatch, lambda: monkeypatch.setattr(
        reference, "gear_pair", lambda turn, ri, rj: right(turn, ri * (1 + 1e-7), rj)))
    assert native["verdict"] == "outside tolerance" and not native["within_tolerance"]
    assert "position_error_rel" in over and "> 1e-10" in over
    assert not ok and out.exit_code == 1
    assert "position_error_rel" in (tmp_path / "o" / "summary.md").read_text()


def velocities_off(solve):
    """``solve`` with its velocities x (1 + 1e-8): the trajectory's columns and qd."""
    from kinem.result import Trajectory

    def patched(*a, **k):
        r = solve(*a, **k)
        tr = r.trajectory
        scale = np.array([1 + 1e-8 if c.endswith((".vx", ".vy", ".omega")) else 1.0 for c in tr.columns])
        return dataclasses.replace(r, trajectory=Trajectory(tr.t.copy(), tr.columns, tr.data * scale),
                                   qd=r.qd * (1 + 1e-8))
    return patched


def test_native_velocities_off_fail_the_report(tmp_path, monkeypatch):
    """Native's velocities x (1 + 1e-8) (a patched solver: the reference run
    too, so native against native sees nothing): the closed form's rates
    catch it, the velocity figure named, positions within their limit."""
    import kinem.solver
    from kinem.report import runs

    patched = velocities_off(kinem.solver.solve)

    def patch():
        runs.reference.cache_clear()
        monkeypatch.setattr(kinem.solver, "solve", patched)

    out, doc, native, over, ok = _report(tmp_path, monkeypatch, patch)
    runs.reference.cache_clear()
    assert native["velocity_error_rel"] < 1e-12                     # against native itself: nothing to see
    assert 5e-9 < native["reference_velocity_error_rel"] < 2e-8     # against the closed form: the 1e-8 injected
    assert "reference_velocity_error_rel" in over and "position_error_rel" not in over
    assert not ok and out.exit_code == 1


def test_native_within_its_limits_passes_and_is_new_to_an_older_baseline(tmp_path, monkeypatch):
    """Native within its limits passes; against a baseline written before the
    rate figures (and before the case had a closed form) the gate reports
    them as new, not as a regression nor a crash."""
    from kinem.report.gate import gate
    from kinem.report.schema import SCHEMA, problems

    out, doc, native, over, ok = _report(tmp_path, monkeypatch, lambda: None)
    assert native["verdict"] == "within tolerance" and native["reference_kind"] == "closed-form"
    assert native["tolerance"] == references.LIMITS and over == "" and ok and out.exit_code == 0
    assert native["reference_acceleration_error_rel"] < AGREE
    base = copy.deepcopy(doc)
    run = base["cases"][0]["runs"][0]
    for k in ("reference_velocity_error", "reference_velocity_error_rel", "reference_acceleration_error",
              "reference_acceleration_error_rel"):
        del run[k]
    run.update(position_error=None, position_error_rel=None, tolerance={}, within_tolerance=True,
               verdict="no independent reference", reference="native at the reference tolerance",
               reference_kind="native")
    g = gate(doc, base, "base.json")
    assert problems(dict(doc, gate=g), SCHEMA) == []
    assert g["regressions"] == 0 and g["kinds"]["gear_pair/native"] == "new"
    assert g["verdicts"]["gear_pair/native"].startswith("new: no baseline for its position, velocity, acceleration "
                                                        "against closed form kinem.reference.gear_pair")
    assert gate(doc, doc, "same.json")["kinds"]["gear_pair/native"] == "pass"   # recorded: compared, unchanged


def test_compare_checks_native_against_the_closed_form(monkeypatch, capsys):
    """kinem compare's native row has the case's closed form: its figures
    shown, within tolerance; native's velocities x (1 + 1e-8) (a patched
    solver) put it outside tolerance, and the command exits 1."""
    import kinem.solver
    from kinem import cli

    path = str(ROOT / "cases" / "gear_pair.toml")

    def native_lines():
        lines = capsys.readouterr().out.splitlines()
        k = next(i for i, line in enumerate(lines) if line.startswith("native"))
        return lines[k], lines[k + 1]

    assert cli.main(["compare", path, "--engines", "native"]) == 0
    row, note = native_lines()
    assert row.endswith("within tolerance") and "no independent reference" not in row
    assert "closed form kinem.reference.gear_pair" in note
    monkeypatch.setattr(kinem.solver, "solve", velocities_off(kinem.solver.solve))
    assert cli.main(["compare", path, "--engines", "native"]) == 1
    row, _ = native_lines()
    assert "outside tolerance: velocity_error_rel" in row     # the figure named
    vel = float(row.split()[5])          # vel/V: the 1e-8 injected, against the closed form's peak
    assert 5e-9 < vel < 2e-8
