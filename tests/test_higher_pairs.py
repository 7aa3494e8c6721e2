"""Higher pairs (Secs. 4.2.3-4.2.6): outlines against Examples 4.3 and 4.3a
and scipy, every higher-pair case against its closed form, the special
cases of the general rack and pinion, and bad outlines.

Tolerances: a case with an exact closed form must match it to 1e-9 of the
run's peak magnitude of each quantity. The solver stops at a scaled residual
of 1e-12, which leaves position errors near 1e-12 of the mechanism's size;
velocities and accelerations (linear solves at that position, well
conditioned here) inherit errors of that order. A wrong sign or term gives
errors of order 1. The
book's numbers carry 4 significant digits: they are checked to half a unit
of their last digit."""
import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import kinem
from kinem.outline import Outline, OutlineSet

from conftest import ROOT

EXACT = 1e-9


def run(case):
    r = kinem.solve(kinem.compile(kinem.load(ROOT / "cases" / f"{case}.toml")))
    assert r.success, r.message
    return r.trajectory


def close(got, want, tol=EXACT):
    """Max error relative to the run's peak magnitude of the quantity."""
    got, want = np.asarray(got), np.asarray(want)
    err = np.max(np.abs(got - want)) / max(np.max(np.abs(want)), 1e-300)
    assert err <= tol, f"relative error {err:.2e}"
    return err


# -- outlines (Sec. 4.2.4) ------------------------------------------------------

def example_43_s1(theta):
    return -6.538 * theta**3 + 3.230 * theta**2 - 2.173 * theta + 4.108


def test_example_43_cubic_s1():
    """Four points of s1 with not-a-knot ends give s1 itself (one cubic)."""
    theta = [0.1, 0.2, 0.3, 0.4]
    o = Outline.spline(theta, [example_43_s1(t) for t in theta])
    s, ds, dds = (float(v[0]) for v in o.radius_at([0.26]))
    assert (s, ds, dds) == pytest.approx((3.646, -1.819, -3.739), abs=5e-4)


def test_example_43a_point_and_tangent():
    """theta = 0.26, s = 3.646, ds/dtheta = -1.819 (a table whose s is
    linear in theta through that point): xi, eta (Eq. 4.21) and g' (Eq. 4.22)."""
    theta = 0.26 + np.arange(-1.0, 3.0)
    o = Outline.spline(theta, 3.646 - 1.819 * (theta - 0.26))
    p, g, _ = (complex(v[0]) for v in o.point_at([0.26]))
    assert (p.real, p.imag) == pytest.approx((3.523, 0.937), abs=5e-4)
    assert (g.real, g.imag) == pytest.approx((-2.695, 3.056), abs=5e-4)


TABLE_41 = (np.radians([0, 30, 60, 70, 80, 90, 100, 110, 120, 150, 180, 225, 270, 315, 360]),
            [3.70, 4.55, 6.80, 8.38, 10.65, 12.46, 11.10, 8.65, 7.04, 4.63, 3.80, 3.62, 3.80, 3.62, 3.70])


def test_outline_set_matches_scipy_and_circle():
    """Mixed outlines evaluated together, at accumulated and out-of-table
    angles, equal scipy's splines (wrapped) and the exact circle; the
    derivatives of p follow Eqs. 4.22 and 4.23."""
    t41 = Outline.spline(*TABLE_41, periodic=True, center=(0.5, -0.2))
    circle = Outline.circle(2.0, (0.5, 0.0))
    x = [0.0, 0.7, 1.5, 2.0, 3.1]
    natural = Outline.spline(x, [1.0, 1.4, 1.1, 0.9, 1.3], bc="natural")
    knot = Outline.spline(x, [1.0, 1.4, 1.1, 0.9, 1.3])
    rng = np.random.default_rng(4)
    theta = np.concatenate([rng.uniform(-20, 20, 50), rng.uniform(-20, 20, 50), rng.uniform(-0.5, 3.5, 100)])
    outlines = [t41] * 50 + [circle] * 50 + [natural] * 50 + [knot] * 50
    s = OutlineSet(outlines).radius(theta)
    p = OutlineSet(outlines).curve(theta)
    splines = [CubicSpline(*TABLE_41, bc_type="periodic"), None,
               CubicSpline(x, [1.0, 1.4, 1.1, 0.9, 1.3], bc_type="natural"),
               CubicSpline(x, [1.0, 1.4, 1.1, 0.9, 1.3])]
    for k, sp in enumerate(splines):
        part = slice(50 * k, 50 * (k + 1))
        th = theta[part]
        want = [np.full(50, 2.0), np.zeros(50), np.zeros(50)] if sp is None else \
            [sp(np.mod(th, 2 * np.pi) if k == 0 else th, m) for m in range(3)]
        for m in range(3):
            np.testing.assert_allclose(s[m][part], want[m], rtol=0, atol=1e-12 * np.max(np.abs(want[m]) + 1))
    c, sn = np.cos(theta), np.sin(theta)
    s0, s1, s2, _ = s
    center = np.array([complex(*o.center) for o in outlines])
    np.testing.assert_allclose(p[0], center + s0 * (c + 1j * sn), atol=1e-12)
    np.testing.assert_allclose(p[1].real, -s0 * sn + s1 * c, atol=1e-12)                 # Eq. 4.22
    np.testing.assert_allclose(p[1].imag, s0 * c + s1 * sn, atol=1e-12)
    np.testing.assert_allclose(p[2].real, -s0 * c - 2 * s1 * sn + s2 * c, atol=1e-12)    # Eq. 4.23
    np.testing.assert_allclose(p[2].imag, -s0 * sn + 2 * s1 * c + s2 * sn, atol=1e-12)


# -- cases against closed forms -------------------------------------------------

def test_gear_pair():
    """Eq. 4.17 integrated: phi2 = 0.1 - (40/60) phi1 (the estimates are the reference)."""
    tr = run("gear_pair")
    ratio = 40.0 / 60.0
    close(tr["gear2.phi"], 0.1 - ratio * tr["gear1.phi"])
    close(tr["gear2.omega"], -ratio * tr["gear1.omega"])
    close(tr["gear2.alpha"], -ratio * tr["gear1.alpha"])


def test_planetary_willis():
    """Willis: (w_sun - w_c) / (w_ring - w_c) = -R_ring / R_sun with the ring
    fixed, so w_c = w_sun R_s / (R_s + R_r); the planet turns at
    w_c - (R_s / R_p)(w_sun - w_c); its centre is on the carrier's arm."""
    tr = run("planetary")
    rs, rp, rr = 30.0, 15.0, 60.0
    for q, qc in (("phi", "phi"), ("omega", "omega"), ("alpha", "alpha")):
        sun = tr[f"sun.{q}"]
        carrier = sun * rs / (rs + rr)
        close(tr[f"carrier.{qc}"], carrier)
        close(tr[f"planet.{qc}"], carrier - rs / rp * (sun - carrier))
    phi_c = tr["carrier.phi"]
    close(tr["planet.x"] + 1j * tr["planet.y"], (rs + rp) * np.exp(1j * phi_c))


def test_rack_pinion_inclined():
    """Pinion on a fixed centre above a rack guided at 30 degrees: the rack
    moves along its line by rho (phi - phi0) (Eq. 4.19 along the rack)."""
    tr = run("rack_pinion")
    u = np.exp(1j * np.pi / 6)
    rho = 25.0
    z0 = 12.5 - 21.650635094610966j
    for pos, ang in (("", "phi"), ("v", "omega"), ("a", "alpha")):
        z = tr[f"rack.{pos}x" if pos else "rack.x"] + 1j * tr[f"rack.{pos}y" if pos else "rack.y"]
        ref = z0 if not pos else 0.0
        close(z - ref, rho * tr[f"pinion.{ang}"] * u)
    close(tr["rack.phi"], np.full(len(tr), np.pi / 6))


def test_rolling_pinion():
    """Eq. 4.20 with a fixed rack: x + rho (phi - phi0) = x0, centre at y = rho."""
    tr = run("rolling_pinion")
    rho = 20.0
    close(tr["pinion.phi"], 0.3 - tr["pinion.x"] / rho)
    close(tr["pinion.omega"], -tr["pinion.vx"] / rho)
    close(tr["pinion.alpha"], -tr["pinion.ax"] / rho)
    close(tr["pinion.y"], np.full(len(tr), rho))


def test_cam_table41():
    """Radial point follower on the y axis: the contact angle is
    theta = pi/2 - phi_cam, the lift the periodic spline of Table 4.1 there."""
    tr = run("cam_table41")
    sp = CubicSpline(*TABLE_41, bc_type="periodic")
    phi, w = tr["cam.phi"], tr["cam.omega"]
    close(tr["contact.theta"], np.pi / 2 - phi)
    th = np.mod(np.pi / 2 - phi, 2 * np.pi)
    close(tr["follower.y"], sp(th))
    close(tr["follower.vy"], -sp(th, 1) * w)
    close(tr["follower.ay"], sp(th, 2) * w * w)  # constant cam speed
    assert np.ptp(tr["follower.y"]) > 8.0       # the run covers the whole lift


def test_cam_roller_example_44():
    """Example 4.4: roller centre at y = e sin(phi) + sqrt(D^2 - e^2 cos^2(phi)),
    D = rho_cam + rho_roller, e the cam centre's offset; follower origin 15 above."""
    tr = run("cam_roller_circle")
    e, D = 10.0, 38.0
    phi, w, al = tr["cam.phi"], tr["cam.omega"], tr["cam.alpha"]
    c, s = np.cos(phi), np.sin(phi)
    r = np.sqrt(D * D - e * e * c * c)
    y1 = e * c + e * e * s * c / r                                              # dy/dphi
    y2 = -e * s + e * e * (c * c - s * s) / r - e**4 * s * s * c * c / r**3     # d2y/dphi2
    close(tr["follower.y"], e * s + r + 15.0)
    close(tr["follower.vy"], y1 * w)
    close(tr["follower.ay"], y2 * w * w + y1 * al)
    centre = e * np.exp(1j * phi)
    roller = 1j * (tr["follower.y"] - 15.0)
    close(np.exp(1j * (tr["contact.theta"] + phi)), (roller - centre) / D)


def test_cam_flat_eccentric():
    """Lift of a flat face on an eccentric circle: y = R + e sin(phi)."""
    tr = run("cam_flat_eccentric")
    R, e = 25.0, 8.0
    phi, w, al = tr["cam.phi"], tr["cam.omega"], tr["cam.alpha"]
    close(tr["follower.y"], R + e * np.sin(phi))
    close(tr["follower.vy"], e * np.cos(phi) * w)
    close(tr["follower.ay"], -e * np.sin(phi) * w * w + e * np.cos(phi) * al)
    close(tr["contact.theta"], np.pi / 2 - phi)


def test_pin_in_circular_slot():
    """x = sqrt(R^2 - y^2), x' = -y y'/x, x'' = -(x'^2 + y'^2 + y y'')/x."""
    tr = run("pin_in_slot")
    R = 50.0
    y, vy, ay = tr["pin.y"], tr["pin.vy"], tr["pin.ay"]
    x = np.sqrt(R * R - y * y)
    vx = -y * vy / x
    close(tr["pin.x"], x)
    close(tr["pin.vx"], vx)
    close(tr["pin.ax"], -(vx * vx + vy * vy + y * ay) / x)
    close(tr["slot.theta"], np.arctan2(y, x))


def test_pin_in_spline_slot_within_interpolation_bound():
    """The slot is a circle (R = 50 about the origin) tabulated every
    h = 10 degrees in polar form about Q = [-15, 0]. Bound on the spline's
    error: (5/384) h^4 max|s''''|, Hall and Meyer's (1976) for complete cubic
    splines, here for the periodic one, checked first on a dense grid. The
    pin's distance from the true circle is at most the spline's radial error
    (the distance to a circle is 1-Lipschitz)."""
    R, c, h = 50.0, 15.0, np.radians(10.0)
    exact = lambda t: c * np.cos(t) + np.sqrt(R * R - (c * np.sin(t)) ** 2)
    n = 64  # s is analytic and periodic (Fourier terms ~ 0.3^k): its spectral 4th derivative is good to ~1e-9
    k = np.fft.rfftfreq(n, 1.0 / n)
    d4 = np.fft.irfft(np.fft.rfft(exact(2 * np.pi * np.arange(n) / n)) * k**4, n)
    bound = 5.0 / 384.0 * h**4 * np.max(np.abs(d4))
    outline = kinem.load(ROOT / "cases" / "pin_in_spline_slot.toml").constraints[1]["outline"]
    grid = np.linspace(0.0, 2 * np.pi, 20001)
    spline_error = np.max(np.abs(outline.radius_at(grid)[0] - exact(grid)))
    assert spline_error <= bound
    tr = run("pin_in_spline_slot")
    distance = np.abs(np.hypot(tr["pin.x"], tr["pin.y"]) - R)
    assert distance.max() <= bound + EXACT * R
    assert distance.max() > 100 * EXACT * R  # the slot is not the exact circle: the bound is what is tested


# -- special cases of the general forms ----------------------------------------

def rack_model(pinion_q, rack_q, rho):
    return kinem.compile(kinem.load_dict({
        "name": "rp", "time": {"end": 1.0, "steps": 1},
        "bodies": {"p": {"q": pinion_q}, "r": {"q": rack_q}},
        "constraints": [{"type": "rack-pinion", "pinion": "p", "radius": rho, "rack": "r", "sj": [0.0, 0.0]}],
    }))


def test_rack_pinion_reduces_to_eqs_419_420():
    """Rack along x, not rotating: the general form is Eq. 4.20,
    (x_i - x_i^0) + (phi_i - phi_i^0) rho - (x_j - x_j^0); with the pinion
    centre fixed it is Eq. 4.19. Reference: the estimates."""
    rho, p0, r0 = 1.7, [0.4, 1.7, 0.9], [-2.0, 0.0, 0.0]
    m = rack_model(p0, r0, rho)
    rng = np.random.default_rng(7)
    for _ in range(20):
        xi, yi, phii, xj, yj = rng.uniform(-30, 30, 5)
        q = np.array([xi, yi, phii, xj, yj, 0.0])
        eq420 = (xi - p0[0]) + (phii - p0[2]) * rho - (xj - r0[0])
        assert m.phi(q, 0.0)[0] == pytest.approx(eq420, abs=1e-12 * 100)
        J = m.jacobian(q, 0.0, sparse=False)[0]
        assert J[:5] == pytest.approx([1.0, 0.0, rho, -1.0, 0.0], abs=1e-12)
        q[0] = p0[0]
        eq419 = (phii - p0[2]) * rho - (xj - r0[0])
        assert m.phi(q, 0.0)[0] == pytest.approx(eq419, abs=1e-12 * 100)


def test_a_pinion_on_the_other_side_of_u_is_an_input_error():
    """Phi rolls the pinion as if it lay on u's +90 degree side: a pinion
    estimated on the -90 degree side (here 1.7 below a line along +x) would
    roll the wrong way, so it is refused naming u; u reversed is accepted and
    rolls it by Eq. 4.20 with the sign of that side."""
    with pytest.raises(kinem.InputError, match="key 'u'.*-90 degrees") as e:
        rack_model([0.4, -1.7, 0.9], [-2.0, 0.0, 0.0], 1.7)
    assert "constraint 1" in str(e.value)
    m = kinem.compile(kinem.load_dict({
        "name": "rp", "time": {"end": 1.0, "steps": 1},
        "bodies": {"p": {"q": [0.4, -1.7, 0.9]}, "r": {"q": [-2.0, 0.0, 0.0]}},
        "constraints": [{"type": "rack-pinion", "pinion": "p", "radius": 1.7, "rack": "r", "sj": [0.0, 0.0],
                         "u": [-1.0, 0.0]}],
    }))
    q = np.array([0.4 + 0.3, -1.7, 0.9 + 0.3 / 1.7, -2.0, 0.0, 0.0])   # centre moved +x, turned + by x/rho
    assert m.phi(q, 0.0)[0] == pytest.approx(0.0, abs=1e-12)


def test_gear_forms_417_418():
    """Eqs. 4.17 and 4.18 with the estimates as phi^0; internal: opposite sign of rho_j."""
    bodies = {"a": {"q": [0, 0, 0.3]}, "b": {"q": [0, 0, -1.1]}, "k": {"q": [0, 0, 0.7]}}
    rng = np.random.default_rng(3)
    for carrier in (False, True):
        for internal in (False, True):
            con = {"type": "gear", "i": "a", "ri": 2.0, "j": "b", "rj": 3.0, "internal": internal}
            if carrier:
                con["carrier"] = "k"
            m = kinem.compile(kinem.load_dict({"name": "g", "time": {"end": 1, "steps": 1},
                                               "bodies": bodies, "constraints": [con]}))
            q = rng.uniform(-20, 20, 9)
            dk = q[8] - 0.7 if carrier else 0.0
            sign = -1.0 if internal else 1.0
            want = ((q[2] - 0.3) - dk) * 2.0 + sign * ((q[5] + 1.1) - dk) * 3.0
            assert m.phi(q, 0.0)[0] == pytest.approx(want, abs=1e-12)


def test_gear_phi0_meaning():
    """phi0 is phi_j - phi_k when phi_i - phi_k = 0."""
    m = kinem.compile(kinem.load_dict({
        "name": "g", "time": {"end": 1, "steps": 1},
        "bodies": {"a": {"q": [0, 0, 0]}, "b": {"q": [0, 0, 0]}},
        "constraints": [{"type": "gear", "i": "a", "ri": 2.0, "j": "b", "rj": 3.0, "phi0": 0.25}]}))
    assert m.phi(np.array([0, 0, 0, 0, 0, 0.25]), 0.0)[0] == 0.0


# -- bad outlines ----------------------------------------------------------------

def cam_case(outline, theta=0.5):
    return {"name": "bad", "time": {"end": 1.0, "steps": 1},
            "bodies": {"cam": {"q": [0, 0, 0]}, "f": {"q": [0, 1, 0]}},
            "constraints": [{"type": "cam-point", "cam": "cam", "follower": "f", "sj": [0, 0],
                             "theta": theta, "outline": outline}]}


BAD = {
    "theta not increasing": ({"spline": {"theta": [0, 1, 1, 2], "s": [1, 1, 1, 1]}}, "outline.spline.theta"),
    "fewer than 4 points": ({"spline": {"theta": [0, 1, 2], "s": [1, 1, 1]}}, "outline.spline.theta"),
    "periodic ends differ": ({"spline": {"theta": [0, 120, 240, 360], "s": [1, 2, 2, 1.5], "degrees": True,
                                         "periodic": True}}, "outline.spline.s"),
    "periodic not a full turn": ({"spline": {"theta": [0, 1, 2, 3], "s": [1, 2, 2, 1], "periodic": True}},
                                 "outline.spline.theta"),
    "zero radius": ({"circle": {"radius": 0.0}}, "outline.circle.radius"),
    "negative radius": ({"circle": {"radius": -2.0}}, "outline.circle.radius"),
    "non-positive s": ({"spline": {"theta": [0, 1, 2, 3], "s": [1, 0, 2, 1]}}, "outline.spline.s"),
    "unknown bc": ({"spline": {"theta": [0, 1, 2, 3], "s": [1, 2, 2, 1], "bc": "clamped"}}, "outline.spline.bc"),
    "lengths differ": ({"spline": {"theta": [0, 1, 2, 3, 4], "s": [1, 2, 2, 1]}}, "outline.spline"),
    "both kinds": ({"circle": {"radius": 1.0}, "spline": {"theta": [0, 1, 2, 3], "s": [1, 2, 2, 1]}}, "outline"),
    "unknown key": ({"circle": {"radius": 1.0}, "centre": [0, 0]}, "centre"),
}


@pytest.mark.parametrize("why", sorted(BAD))
def test_bad_outline_is_an_input_error(why):
    outline, key = BAD[why]
    with pytest.raises(kinem.InputError) as e:
        kinem.load_dict(cam_case(outline))
    first = e.value.problems[0]  # too short theta and s are two problems; theta's comes first
    assert f"key '{key}'" in first and "constraint 1" in first


def test_theta_outside_an_open_table_is_an_input_error():
    with pytest.raises(kinem.InputError, match="key 'theta'"):
        kinem.load_dict(cam_case({"spline": {"theta": [0, 1, 2, 3], "s": [1, 2, 2, 1]}}, theta=3.5))


def toml_outline(outline):
    def value(v):
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, bool):
            return "true" if v else "false"
        return repr(list(v)) if isinstance(v, list) else repr(v)
    return value(outline)


@pytest.mark.parametrize("why", ["theta not increasing", "fewer than 4 points", "periodic ends differ", "zero radius"])
def test_bad_outline_on_the_command_line(why, tmp_path):
    outline, key = BAD[why]
    path = tmp_path / "bad.toml"
    path.write_text(f'''name = "bad"
[time]
end = 1.0
steps = 1
[bodies]
cam = {{ q = [0.0, 0.0, 0.0] }}
f = {{ q = [0.0, 1.0, 0.0] }}
[[constraints]]
type = "cam-point"
cam = "cam"
follower = "f"
sj = [0.0, 0.0]
theta = 0.5
outline = {toml_outline(outline)}
''')
    p = subprocess.run([sys.executable, "-m", "kinem", "info", str(path)], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr
    assert str(path) in lines[0] and f"key '{key}'" in lines[0]
