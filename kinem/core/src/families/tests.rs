//! Unit tests of the outlines and the families: the outline's radius and
//! curve against its cubic and finite differences, and each family's
//! Jacobian, nu and gamma against finite differences of its Phi along a
//! straight path (as tests/fd.py does in Python): with q(s) = q + s qd,
//! t(s) = t + s, d/ds Phi = Phi_q qd - nu and d2/ds2 Phi = -gamma.
use crate::functions::{HARMONIC, POLY};
use crate::model::Kin;
use crate::outline::Outlines;
use crate::real::{Dual, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};
use std::f64::consts::PI;

const H: f64 = 1e-3;

fn c(re: f64, im: f64) -> C64 {
    C64::new(re, im)
}

fn table(ints: &[(&str, Vec<i64>)], reals: &[(&str, Vec<f64>)], complex: &[(&str, Vec<C64>)]) -> Table {
    let mut t = Table::default();
    for (k, v) in ints {
        t.ints.insert(k.to_string(), v.clone());
    }
    for (k, v) in reals {
        t.reals.insert(k.to_string(), v.clone());
    }
    for (k, v) in complex {
        t.complex.insert(k.to_string(), v.clone());
    }
    t
}

/// Functions: 0 a constant 1.3, 1 a cubic, 2 a harmonic.
fn functions() -> Table {
    let data = vec![1.3, 0.9, 0.5, -0.2, 0.1, 0.7, 2.0, 0.3, 0.1];
    table(&[("kind", vec![POLY, POLY, HARMONIC]), ("start", vec![0, 1, 5, 9])], &[("data", data)], &[])
}

/// Outlines: 0 a circle of radius 1.2 about (0.1, -0.2); 1 a periodic
/// outline of two cubic pieces over [0.5, 0.5 + 2 pi); 2 an open one of
/// one piece over [-1, 1].
fn outlines() -> Table {
    let coef = vec![
        0.0, 0.0, 0.0, 1.2, // circle
        0.02, -0.1, 0.3, 1.0, // periodic, piece 1
        -0.03, 0.05, -0.2, 1.4, // periodic, piece 2
        0.1, 0.2, -0.3, 1.1, // open
    ];
    table(
        &[("first", vec![0, 1, 3]), ("last", vec![0, 2, 3]), ("periodic", vec![1, 1, 0])],
        &[
            ("t0", vec![0.0, 0.5, -1.0]),
            ("span", vec![2.0 * PI, 2.0 * PI, 2.0]),
            ("starts", vec![0.0, 0.0, 3.0, 0.0]),
            ("coef", coef),
        ],
        &[("center", vec![c(0.1, -0.2), c(0.3, 0.1), c(-0.2, 0.0)])],
    )
}

#[test]
fn outline_radius_is_its_cubic_and_wraps() {
    let o = Outlines::from_table(&outlines()).unwrap();
    assert_eq!(o.radius(0, 0.7), [1.2, 0.0, 0.0, 0.0]);
    assert_eq!(o.radius(0, -40.0), [1.2, 0.0, 0.0, 0.0]);
    // periodic, second piece: h = theta - 0.5 - 3.0
    let th = 0.5 + 3.7;
    let h = 0.7;
    let want =
        [-0.03 * h * h * h + 0.05 * h * h - 0.2 * h + 1.4, -0.09 * h * h + 0.1 * h - 0.2, -0.18 * h + 0.1, -0.18];
    for turns in [-3.0, 0.0, 2.0] {
        let r = o.radius(1, th + turns * 2.0 * PI);
        for k in 0..4 {
            assert!((r[k] - want[k]).abs() < 1e-12, "derivative {k}: {} != {}", r[k], want[k]);
        }
    }
    // open: beyond its table, the end cubic continues
    let h = 2.5;
    let r = o.radius(2, -1.0 + h);
    assert!((r[0] - (0.1 * h * h * h + 0.2 * h * h - 0.3 * h + 1.1)).abs() < 1e-12);
    let h = -0.5;
    let r = o.radius(2, -1.0 + h);
    assert!((r[1] - (0.3 * h * h + 0.4 * h - 0.3)).abs() < 1e-12);
}

#[test]
fn outline_curve_derivatives_match_finite_differences() {
    let o = Outlines::from_table(&outlines()).unwrap();
    let rot = C64::from_polar(1.0, 0.8);
    let at = |k: usize, th: f64| o.curve(k, th, C64::from_polar(1.0, th), rot);
    for (k, th) in [(0, 2.0), (1, 1.3), (1, 4.9 + 4.0 * PI), (2, 0.2)] {
        let p = at(k, th);
        let d = |f: &dyn Fn(f64) -> C64| (-f(2.0 * H) + 8.0 * f(H) - 8.0 * f(-H) + f(-2.0 * H)) / (12.0 * H);
        let g = d(&|s| at(k, th + s).a);
        let h = d(&|s| at(k, th + s).g);
        let kk = d(&|s| at(k, th + s).h);
        assert!((g - p.g).norm() < 1e-9, "outline {k}: g {} != {}", p.g, g);
        assert!((h - p.h).norm() < 1e-9, "outline {k}: h {} != {}", p.h, h);
        assert!((kk - p.k).norm() < 1e-9, "outline {k}: k {} != {}", p.k, kk);
        // a = A_c (Q + s e^{i theta})
        let s = o.radius(k, th)[0];
        let q = [c(0.1, -0.2), c(0.3, 0.1), c(-0.2, 0.0)][k];
        assert!((p.a - rot * (q + s * C64::from_polar(1.0, th))).norm() < 1e-14);
    }
}

#[test]
fn malformed_outlines_are_refused() {
    let mut t = outlines();
    t.ints.insert("last".into(), vec![0, 2, 9]);
    assert!(Outlines::<f64>::from_table(&t).is_err());
    let mut t = outlines();
    t.reals.get_mut("coef").unwrap().pop();
    assert!(Outlines::<f64>::from_table(&t).is_err());
}

/// Three bodies (columns 0..9) and `art` artificial coordinates after them.
fn kin(kind: &str, t: Table, art: usize) -> Kin {
    kin_with(kind, t, art, &functions(), &outlines())
}

fn kin_with<S: Real>(kind: &str, t: Table, art: usize, f: &Table, o: &Table) -> Kin<S> {
    let n = 9 + art;
    let angles = [2, 5, 8].into_iter().chain(9..n as i64).collect();
    Kin::new(n, vec![(kind.to_string(), t)], f, o, angles).unwrap()
}

/// Phi, Jacobian values, nu and gamma over dual numbers: their tangents.
fn tangents(k: &Kin<Dual>, q: &[Dual], qd: &[Dual], t: f64) -> [Vec<f64>; 4] {
    use crate::families::At;
    let mut e = vec![Complex::new(Dual::c(1.0), Dual::c(0.0)); k.n];
    k.rotate(q, &mut e);
    let at = At { q, e: &e, t };
    let (mut phi, mut jac, mut nu, mut gamma) =
        (vec![Dual::c(0.0); k.m], vec![Dual::c(0.0); k.nnz], vec![Dual::c(0.0); k.m], vec![Dual::c(0.0); k.m]);
    k.phi(&at, &mut phi);
    k.jac(&at, &mut jac);
    k.nu(t, &mut nu);
    k.gamma(&at, qd, &mut gamma);
    [phi, jac, nu, gamma].map(|v| v.iter().map(|x| x.d).collect())
}

fn all_f64(k: &Kin, q: &[f64], qd: &[f64], t: f64) -> [Vec<f64>; 4] {
    [eval(k, q, t, 0, qd), eval(k, q, t, 1, qd), eval(k, q, t, 2, qd), eval(k, q, t, 3, qd)]
}

fn fourth(f: &dyn Fn(f64) -> [Vec<f64>; 4]) -> [Vec<f64>; 4] {
    let (a, b, c, d) = (f(2.0 * H), f(H), f(-H), f(-2.0 * H));
    std::array::from_fn(|w| {
        (0..a[w].len()).map(|r| (-a[w][r] + 8.0 * b[w][r] - 8.0 * c[w][r] + d[w][r]) / (12.0 * H)).collect()
    })
}

fn close(what: &str, exact: &[Vec<f64>; 4], fd: &[Vec<f64>; 4]) {
    for (w, name) in ["Phi", "Jacobian", "nu", "gamma"].iter().enumerate() {
        for (r, (x, y)) in exact[w].iter().zip(&fd[w]).enumerate() {
            assert!((x - y).abs() / y.abs().max(1.0) < 1e-7, "{what}: d{name}[{r}] {x} != {y} (finite differences)");
        }
    }
}

/// Columns that select (a row's component, a sign) or place (abscissae):
/// no design parameter moves them.
const STRUCTURAL: [&str; 6] = ["mx", "my", "sign", "starts", "t0", "span"];

/// The design-parameter derivatives of a family (crate::sensitivity): the
/// dual kernels' tangents of Phi, the Jacobian values, nu and gamma along
/// every number of its table, of the functions' and of the outlines'
/// tables, and along a direction in q and qd, against fourth-order central
/// differences of the f64 kernels.
fn check_parameters(kind: &str, t: &Table, art: usize, q: &[f64], qd: &[f64], time: f64) {
    let (f, o) = (functions(), outlines());
    let lift = |v: &[f64], d: &[f64]| -> Vec<Dual> { v.iter().zip(d).map(|(&a, &b)| Dual::lift(a, b)).collect() };
    let zeros = vec![0.0; q.len()];
    // every real and complex number of the three tables
    let mut seeds: Vec<(usize, String, usize, bool)> = Vec::new(); // (table, column, entry, imaginary)
    for (w, tab) in [t, &f, &o].iter().enumerate() {
        for (key, v) in &tab.reals {
            seeds.extend((0..v.len()).map(|e| (w, key.clone(), e, false)));
        }
        for (key, v) in &tab.complex {
            seeds.extend((0..v.len()).flat_map(|e| [(w, key.clone(), e, false), (w, key.clone(), e, true)]));
        }
    }
    for (w, key, e, im) in seeds {
        if (w == 1 && key == "data" && e == 0) || STRUCTURAL.contains(&key.as_str()) {
            continue; // the constant 1.3 is evaluated without its data (Functions::value); selectors and abscissae
        }
        let moved = |h: f64| -> [Table; 3] {
            let mut tabs = [t.clone(), f.clone(), o.clone()];
            let tab = &mut tabs[w];
            if let Some(v) = tab.reals.get_mut(&key) {
                v[e] += h;
            } else {
                let v = tab.complex.get_mut(&key).unwrap();
                v[e] += if im { C64::new(0.0, h) } else { C64::new(h, 0.0) };
            }
            tabs
        };
        let [s0, s1, s2] = moved(0.0);
        let mut seeded = [s0, s1, s2];
        let tab = &mut seeded[w];
        if let Some(v) = tab.reals.get(&key) {
            let mut d = vec![0.0; v.len()];
            d[e] = 1.0;
            tab.d_reals.insert(key.clone(), d);
        } else {
            let mut d = vec![C64::new(0.0, 0.0); tab.complex[&key].len()];
            d[e] = if im { C64::new(0.0, 1.0) } else { C64::new(1.0, 0.0) };
            tab.d_complex.insert(key.clone(), d);
        }
        check_direct(kind, &seeded, art, q, qd, time, true);
        let [a, b, c] = seeded;
        let exact = tangents(&kin_with(kind, a, art, &b, &c), &lift(q, &zeros), &lift(qd, &zeros), time);
        let fd = fourth(&|h| {
            let [a, b, c] = moved(h);
            all_f64(&kin_with(kind, a, art, &b, &c), q, qd, time)
        });
        close(&format!("{kind}: table {w} column {key}[{e}]{}", if im { ".im" } else { "" }), &exact, &fd);
    }
    check_direct(kind, &[t.clone(), f.clone(), o.clone()], art, q, qd, time, false);
    // along q and qd (the tangents of S2 and S3)
    let dq: Vec<f64> = (0..q.len()).map(|j| (j as f64 * 0.7).cos()).collect();
    let dqd: Vec<f64> = (0..q.len()).map(|j| (j as f64 * 1.1).sin()).collect();
    let exact = tangents(&kin_with(kind, t.clone(), art, &f, &o), &lift(q, &dq), &lift(qd, &dqd), time);
    let k = kin(kind, t.clone(), art);
    let fd = fourth(&|h| {
        let qs: Vec<f64> = q.iter().zip(&dq).map(|(a, b)| a + h * b).collect();
        let qds: Vec<f64> = qd.iter().zip(&dqd).map(|(a, b)| a + h * b).collect();
        all_f64(&k, &qs, &qds, time)
    });
    close(&format!("{kind}: along q and qd"), &exact, &fd);
}

/// The direct tangent kernels of a family over Lanes<1> (Family::
/// phi_tangent, jac_products, gamma_tangent, where its kind has them) with
/// the tables `tabs` (their tangents seeded or none: `moved`), at (q, qd)
/// along q' = dq, qd' = dqd: Phi_p against the dual kernels' Phi tangent
/// at q' = 0, D(gamma) against their gamma's tangent along (dq, dqd) (both
/// within 1e-12 of the peak: the same derivatives, checked against finite
/// differences in check_parameters), and the products D(J) qd, D(J) w
/// against fourth-order differences of the dual Phi's tangent along qd and
/// w (J v = d/de Phi(q + e v), so D(J) v = d/de of Phi's tangent there).
fn check_direct(kind: &str, tabs: &[Table; 3], art: usize, q: &[f64], qd: &[f64], time: f64, moved: bool) {
    use crate::families::{At, Dir, Kept, Shared};
    use crate::real::Lanes;
    let n = q.len();
    let dq: Vec<f64> = (0..n).map(|j| (j as f64 * 0.7).cos()).collect();
    let dqd: Vec<f64> = (0..n).map(|j| (j as f64 * 1.1).sin()).collect();
    let w: Vec<f64> = (0..n).map(|j| 0.3 - (j as f64 * 0.4).sin()).collect();
    let lift = |v: &[f64], d: &[f64]| -> Vec<Dual> { v.iter().zip(d).map(|(&a, &b)| Dual::lift(a, b)).collect() };
    let [a, b, c] = tabs.clone();
    let dual = kin_with::<Dual>(kind, a.clone(), art, &b, &c);
    let lanes = kin_with::<Lanes<1>>(kind, a.clone(), art, &b, &c);
    let plain = kin_with::<f64>(kind, a, art, &b, &c);
    let (fam, shared) = (&lanes.families[0], Shared { functions: &lanes.functions, outlines: &lanes.outlines });
    let mut e = vec![C64::new(1.0, 0.0); n];
    for &j in &lanes.angles {
        e[j] = C64::new(q[j].cos(), q[j].sin());
    }
    let at = At { q, e: &e, t: time };
    let (s, sd): (Vec<[f64; 1]>, Vec<[f64; 1]>) =
        (dq.iter().map(|&x| [x]).collect(), dqd.iter().map(|&x| [x]).collect());
    let m = lanes.m;
    let near = |what: &str, x: &[f64], y: &[f64], tol: f64| {
        let peak = y.iter().fold(1.0f64, |p, v| p.max(v.abs()));
        for (r, (a, b)) in x.iter().zip(y).enumerate() {
            assert!((a - b).abs() <= tol * peak, "{kind}: direct {what}[{r}] {a} != {b} (peak {peak})");
        }
    };
    let mut out = vec![[0.0]; m];
    if moved && fam.phi_tangent(&at, &shared, &mut out, Kept::none()) {
        let zeros = vec![0.0; n];
        let want = tangents(&dual, &lift(q, &zeros), &lift(qd, &zeros), time)[0].clone();
        near("Phi_p", &out.iter().map(|x| -x[0]).collect::<Vec<_>>(), &want, 1e-12);
    }
    out.fill([0.0]);
    let dir = Dir { at: At { q, e: &e, t: time }, qd, s: &s, sd: &sd, moved, drives: moved };
    if fam.gamma_tangent(&dir, &shared, &mut out, Kept::none()) {
        let want = tangents(&dual, &lift(q, &dq), &lift(qd, &dqd), time)[3].clone();
        near("D(gamma)", &out.iter().map(|x| x[0]).collect::<Vec<_>>(), &want, 1e-12);
    }
    let (mut r2, mut r3) = (vec![[0.0]; m], vec![[0.0]; m]);
    let (vn, dn) = fam.kept();
    let (mut kv, mut kd) = (vec![C64::new(f64::NAN, 0.0); vn], vec![[f64::NAN]; dn]);
    if fam.jac_products(&dir, &shared, &[qd, &w], &mut r2, &mut r3, Kept::of(&mut kv, &mut kd)) {
        // what jac_products kept gives gamma_tangent's figures to the bit
        let mut again = vec![[0.0]; m];
        assert!(fam.gamma_tangent(&dir, &shared, &mut again, Kept::of(&mut kv, &mut kd)));
        assert!(again.iter().zip(&out).all(|(a, b)| a[0].to_bits() == b[0].to_bits()), "{kind}: kept D(gamma)");
        if moved && fam.hands() {
            // what phi_tangent kept is jac_products' to the bit, and jac_products reading it (held) gives its figures
            let (mut hv, mut hd) = (vec![C64::new(f64::NAN, 0.0); vn], vec![[f64::NAN]; dn]);
            let mut phi = vec![[0.0]; m];
            assert!(fam.phi_tangent(&at, &shared, &mut phi, Kept::of(&mut hv, &mut hd)));
            let bits = |a: &[C64], b: &[C64]| a.iter().zip(b).all(|(x, y)| (x.re, x.im) == (y.re, y.im));
            assert!(
                bits(&hv, &kv) && hd.iter().zip(&kd).all(|(x, y)| x[0].to_bits() == y[0].to_bits()),
                "{kind}: kept"
            );
            let (mut h2, mut h3) = (vec![[0.0]; m], vec![[0.0]; m]);
            let held = Kept { v: &mut hv, d: &mut hd, held: true, pieces: &[] };
            assert!(fam.jac_products(&dir, &shared, &[qd, &w], &mut h2, &mut h3, held));
            let same = |a: &[[f64; 1]], b: &[[f64; 1]]| a.iter().zip(b).all(|(x, y)| x[0].to_bits() == y[0].to_bits());
            assert!(same(&h2, &r2) && same(&h3, &r3), "{kind}: jac_products from phi_tangent's place");
            // the pieces the analysis' Jacobian kept (Kin::jac_over_keeping, the march's hand-over): its
            // values jac's, and phi_tangent and jac_products at them give the same figures to the bit
            let (mut values, mut again, mut pieces) =
                (vec![0.0; plain.nnz], vec![0.0; plain.nnz], vec![crate::outline::Piece::default(); plain.m]);
            plain.jac(&at, &mut values);
            plain.jac_over_keeping(&at, &mut again, &mut pieces);
            assert!(values.iter().zip(&again).all(|(x, y)| x.to_bits() == y.to_bits()), "{kind}: kept jac");
            let (mut pv, mut pd) = (vec![C64::new(f64::NAN, 0.0); vn], vec![[f64::NAN]; dn]);
            let mut handed = vec![[0.0]; m];
            assert!(fam.phi_tangent(&at, &shared, &mut handed, Kept { pieces: &pieces, ..Kept::of(&mut pv, &mut pd) }));
            assert!(same(&handed, &phi) && bits(&pv, &hv) && same(&pd, &hd), "{kind}: phi_tangent at the pieces");
            let (mut p2, mut p3) = (vec![[0.0]; m], vec![[0.0]; m]);
            let (mut qv, mut qdk) = (vec![C64::new(f64::NAN, 0.0); vn], vec![[f64::NAN]; dn]);
            let keep = Kept { pieces: &pieces, ..Kept::of(&mut qv, &mut qdk) };
            assert!(fam.jac_products(&dir, &shared, &[qd, &w], &mut p2, &mut p3, keep));
            assert!(same(&p2, &r2) && same(&p3, &r3), "{kind}: jac_products at the pieces");
        }
        for (v, r) in [(qd, &r2), (&w[..], &r3)] {
            let phi = |h: f64| -> Vec<f64> {
                let qs: Vec<f64> = q.iter().zip(v).map(|(a, b)| a + h * b).collect();
                tangents(&dual, &lift(&qs, &dq), &lift(qd, &dqd), time)[0].clone()
            };
            let (a, b, c, d) = (phi(2.0 * H), phi(H), phi(-H), phi(-2.0 * H));
            let fd: Vec<f64> = (0..m).map(|k| -(-a[k] + 8.0 * b[k] - 8.0 * c[k] + d[k]) / (12.0 * H)).collect();
            near("D(J) v", &r.iter().map(|x| x[0]).collect::<Vec<_>>(), &fd, 1e-8);
        }
    }
}

fn eval(k: &Kin, q: &[f64], t: f64, what: u8, qd: &[f64]) -> Vec<f64> {
    use crate::families::At;
    let mut e = vec![C64::new(1.0, 0.0); k.n];
    k.rotate(q, &mut e);
    let at = At { q, e: &e, t };
    match what {
        0 => {
            let mut o = vec![0.0; k.m];
            k.phi(&at, &mut o);
            o
        }
        1 => {
            let mut o = vec![0.0; k.nnz];
            k.jac(&at, &mut o);
            o
        }
        2 => {
            let mut o = vec![0.0; k.m];
            k.nu(t, &mut o);
            o
        }
        _ => {
            let mut o = vec![0.0; k.m];
            k.gamma(&at, qd, &mut o);
            o
        }
    }
}

/// Checks the Jacobian (pattern rows, cols), nu and gamma of `k` at
/// (q, qd, t) against fourth-order central differences of Phi.
fn check(k: &Kin, rows: &[usize], cols: &[usize], q: &[f64], qd: &[f64], t: f64) {
    assert_eq!(rows.len(), k.nnz);
    let phi = |s: f64, dir: &[f64], dt: f64| {
        let qs: Vec<f64> = q.iter().zip(dir).map(|(a, b)| a + s * b).collect();
        eval(k, &qs, t + s * dt, 0, qd)
    };
    let d1 = |dir: &[f64], dt: f64| -> Vec<f64> {
        let (a, b, c, d) = (phi(2.0 * H, dir, dt), phi(H, dir, dt), phi(-H, dir, dt), phi(-2.0 * H, dir, dt));
        (0..k.m).map(|r| (-a[r] + 8.0 * b[r] - 8.0 * c[r] + d[r]) / (12.0 * H)).collect()
    };
    let values = eval(k, q, t, 1, qd);
    let mut jac = vec![vec![0.0; k.n]; k.m];
    for (e, v) in values.iter().enumerate() {
        jac[rows[e]][cols[e]] += v;
    }
    for col in 0..k.n {
        let mut dir = vec![0.0; k.n];
        dir[col] = 1.0;
        let fd = d1(&dir, 0.0);
        for r in 0..k.m {
            let err = (jac[r][col] - fd[r]).abs() / fd[r].abs().max(1.0);
            assert!(err < 1e-8, "Jacobian ({r}, {col}): {} != {} (finite differences)", jac[r][col], fd[r]);
        }
    }
    // along the path: d Phi/ds = Phi_q qd - nu, d2 Phi/ds2 = -gamma
    let rate = d1(qd, 1.0);
    let nu = eval(k, q, t, 2, qd);
    let gamma = eval(k, q, t, 3, qd);
    let (a, b, c0, d, e) =
        (phi(2.0 * H, qd, 1.0), phi(H, qd, 1.0), phi(0.0, qd, 1.0), phi(-H, qd, 1.0), phi(-2.0 * H, qd, 1.0));
    for r in 0..k.m {
        let jq: f64 = (0..k.n).map(|c| jac[r][c] * qd[c]).sum();
        let err = (jq - nu[r] - rate[r]).abs() / rate[r].abs().max(1.0);
        assert!(err < 1e-8, "nu, row {r}: {} != {} (finite differences)", jq - rate[r], nu[r]);
        let second = (-a[r] + 16.0 * b[r] - 30.0 * c0[r] + 16.0 * d[r] - e[r]) / (12.0 * H * H);
        let err = (gamma[r] + second).abs() / second.abs().max(1.0);
        assert!(err < 1e-6, "gamma, row {r}: {} != {} (finite differences)", gamma[r], -second);
    }
}

fn state(art: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut q = vec![0.3, -0.4, 7.1, 1.2, 0.5, -2.3, -0.6, 0.9, 13.4];
    q.extend_from_slice(art);
    let qd: Vec<f64> = (0..q.len()).map(|k| 1.7 * ((k as f64) * 1.3).sin() + 0.2).collect();
    (q, qd)
}

/// Per constraint, entries (row within the constraint, column).
fn pattern(per: usize, entries: &[&[(usize, usize)]]) -> (Vec<usize>, Vec<usize>) {
    let mut rows = Vec::new();
    let mut cols = Vec::new();
    for (k, e) in entries.iter().enumerate() {
        for &(r, c) in e.iter() {
            rows.push(per * k + r);
            cols.push(c);
        }
    }
    (rows, cols)
}

#[test]
fn distance_derivatives_match_finite_differences() {
    // revolute-revolute (constant length) between bodies 0 and 1, and a
    // distance driver (the cubic) between 1 and 2
    let t = table(
        &[("ci", vec![0, 3]), ("cj", vec![3, 6]), ("f", vec![0, 1])],
        &[],
        &[("si", vec![c(0.4, 0.1), c(-0.3, 0.2)]), ("sj", vec![c(0.0, -0.5), c(0.6, 0.6)])],
    );
    let k = kin("distance", t.clone(), 0);
    let (rows, cols) = pattern(
        1,
        &[&[(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (0, 5)], &[(0, 3), (0, 4), (0, 5), (0, 6), (0, 7), (0, 8)]],
    );
    let (q, qd) = state(&[]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("distance", &t, 0, &q, &qd, 0.8);
}

#[test]
fn revolute_derivatives_match_finite_differences() {
    // bodies 0-1 and 1-2
    let t = table(
        &[("ci", vec![0, 3]), ("cj", vec![3, 6])],
        &[],
        &[("si", vec![c(0.4, 0.1), c(-0.3, 0.2)]), ("sj", vec![c(0.0, -0.5), c(0.6, 0.6)])],
    );
    let k = kin("revolute", t.clone(), 0);
    let joint =
        |i: usize, j: usize| [(0, i), (0, i + 2), (0, j), (0, j + 2), (1, i + 1), (1, i + 2), (1, j + 1), (1, j + 2)];
    let (rows, cols) = pattern(2, &[&joint(0, 3), &joint(3, 6)]);
    let (q, qd) = state(&[]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("revolute", &t, 0, &q, &qd, 0.8);
}

/// x of a point of body 1 = a constant; phi_2 - phi_0 = the harmonic; y_0 = the cubic;
/// y_1 = the constant (a ground's row: q_a - f alone).
fn simple_table() -> Table {
    table(
        &[
            ("a", vec![3, 8, 1, 4]),
            ("angle", vec![5, 8, 2, 5]),
            ("k", vec![0, 2, 0, 0]),
            ("point", vec![1, 0, 0, 0]),
            ("relative", vec![0, 1, 0, 0]),
            ("f", vec![0, 2, 1, 0]),
        ],
        &[("mx", vec![1.0, 0.0, 0.0, 0.0]), ("my", vec![0.0, 0.0, 0.0, 0.0])],
        &[("local", vec![c(0.7, -0.2), c(0.0, 0.0), c(0.0, 0.0), c(0.0, 0.0)])],
    )
}

#[test]
fn simple_derivatives_match_finite_differences() {
    let t = simple_table();
    let k = kin("simple", t.clone(), 0);
    let (rows, cols) = (vec![0, 0, 1, 1, 2, 3], vec![3, 5, 8, 2, 1, 4]);
    let (q, qd) = state(&[]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("simple", &t, 0, &q, &qd, 0.8);
}

#[test]
fn line_and_rack_derivatives_match_finite_differences() {
    let (q, qd) = state(&[]);
    // translational joint: line on body 0, point on body 1, the angle row
    let t = table(
        &[("ca", vec![0]), ("cb", vec![3]), ("ai", vec![2]), ("aj", vec![5])],
        &[("phi0", vec![0.3])],
        &[("pa", vec![c(0.2, 0.1)]), ("ua", vec![c(-0.5, 0.8)]), ("ob", vec![c(0.4, -0.3)])],
    );
    let k = kin("line", t.clone(), 0);
    let (rows, cols) = pattern(2, &[&[(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (0, 5), (1, 2), (1, 5)]]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("line", &t, 0, &q, &qd, 0.8);
    // revolute-translational: no angle row
    let t = table(
        &[("ca", vec![6]), ("cb", vec![0]), ("ai", vec![]), ("aj", vec![])],
        &[("phi0", vec![])],
        &[("pa", vec![c(0.2, 0.1)]), ("ua", vec![c(-0.5, 0.8)]), ("ob", vec![c(0.4, -0.3)])],
    );
    let k = kin("line", t.clone(), 0);
    let (rows, cols) = pattern(1, &[&[(0, 6), (0, 7), (0, 8), (0, 0), (0, 1), (0, 2)]]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("line", &t, 0, &q, &qd, 0.8);
    // rack and pinion: pinion 1, rack 2
    let t = table(
        &[("ci", vec![3]), ("cj", vec![6])],
        &[("rho", vec![0.4]), ("phi0", vec![0.2])],
        &[("c", vec![c(0.1, 0.05)]), ("s", vec![c(-0.3, 0.2)]), ("u", vec![C64::from_polar(1.0, 0.6)])],
    );
    let k = kin("rack-pinion", t.clone(), 0);
    let (rows, cols) = pattern(1, &[&[(0, 3), (0, 4), (0, 5), (0, 6), (0, 7), (0, 8)]]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("rack-pinion", &t, 0, &q, &qd, 0.8);
}

#[test]
fn curve_derivatives_match_finite_differences() {
    // theta of each constraint on its outline: off the periodic outline's knot (0.5 + 3 + 2 pi k)
    let (q, qd) = state(&[2.1 - 4.0 * PI, 5.5, 0.4]);
    let curve = |cb: &str| {
        table(
            &[("cc", vec![0, 3, 6]), ("ct", vec![9, 10, 11]), ("outline", vec![0, 1, 2]), (cb, vec![3, 6, 0])],
            &[],
            &[],
        )
    };
    let mut t = curve("cb");
    t.complex.insert("sb".into(), vec![c(0.3, -0.1), c(-0.2, 0.4), c(0.5, 0.5)]);
    t.reals.insert("sign".into(), vec![1.0, -1.0, 1.0]);
    let k = kin("point-on-curve", t.clone(), 3);
    let per = |cc: usize, ct: usize, cb: usize| {
        [
            (0, cc),
            (0, cc + 2),
            (0, ct),
            (0, cb),
            (0, cb + 2),
            (1, cc + 1),
            (1, cc + 2),
            (1, ct),
            (1, cb + 1),
            (1, cb + 2),
        ]
    };
    let (a, b, d) = (per(0, 9, 3), per(3, 10, 6), per(6, 11, 0));
    let (rows, cols) = pattern(2, &[&a, &b, &d]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("point-on-curve", &t, 3, &q, &qd, 0.8);

    let body = |cc: usize, ct: usize, cj: usize| [cc, cc + 1, cc + 2, ct, cj, cj + 1, cj + 2];
    let mut t = curve("cj");
    t.complex.insert("sj".into(), vec![c(2.3, -0.1), c(-0.2, 2.4), c(0.5, 1.5)]);
    t.reals.insert("rho".into(), vec![0.5, 0.4, 0.5f64.sqrt()]);
    let k = kin("cam-roller", t.clone(), 3);
    let per = |cc, ct, cj| -> Vec<(usize, usize)> {
        let b = body(cc, ct, cj);
        b.iter().map(|&x| (0, x)).chain(b.iter().map(|&x| (1, x))).collect()
    };
    let (a, b, d) = (per(0, 9, 3), per(3, 10, 6), per(6, 11, 0));
    let (rows, cols) = pattern(2, &[&a, &b, &d]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("cam-roller", &t, 3, &q, &qd, 0.8);

    let mut t = curve("cj");
    t.complex.insert("sj".into(), vec![c(2.3, -0.1), c(-0.2, 2.4), c(0.5, 1.5)]);
    t.complex
        .insert("n".into(), vec![C64::from_polar(1.0, 0.3), C64::from_polar(1.0, -2.0), C64::from_polar(1.0, 1.0)]);
    let k = kin("cam-flat", t.clone(), 3);
    let per = |cc: usize, ct: usize, cj: usize| -> Vec<(usize, usize)> {
        [(0, cc + 2), (0, ct), (0, cj + 2)].into_iter().chain(body(cc, ct, cj).iter().map(|&x| (1, x))).collect()
    };
    let (a, b, d) = (per(0, 9, 3), per(3, 10, 6), per(6, 11, 0));
    let (rows, cols) = pattern(2, &[&a, &b, &d]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("cam-flat", &t, 3, &q, &qd, 0.8);
}

#[test]
fn gear_jacobian_is_constant_and_matches_finite_differences() {
    let t = table(
        &[("ai", vec![2, 2]), ("aj", vec![5, 8]), ("ak", vec![0, 5]), ("carrier", vec![0, 1])],
        &[("ri", vec![0.5, 0.3]), ("rj", vec![0.8, -1.1]), ("phi0", vec![0.1, -0.4])],
        &[],
    );
    let k = kin("gear", t.clone(), 0);
    let (rows, cols) = (vec![0, 0, 1, 1, 1], vec![2, 5, 2, 8, 5]);
    let (q, qd) = state(&[]);
    check(&k, &rows, &cols, &q, &qd, 0.8);
    check_parameters("gear", &t, 0, &q, &qd, 0.8);
}

#[test]
fn malformed_family_tables_are_refused() {
    let ok = || {
        table(
            &[("ci", vec![0, 3]), ("cj", vec![3, 6]), ("f", vec![0, 1])],
            &[],
            &[("si", vec![c(0.4, 0.1), c(-0.3, 0.2)]), ("sj", vec![c(0.0, -0.5), c(0.6, 0.6)])],
        )
    };
    let build =
        |t: Table| Kin::<f64>::new(9, vec![("distance".to_string(), t)], &functions(), &outlines(), vec![2, 5, 8]);
    assert!(build(ok()).is_ok());
    let mut t = ok();
    t.ints.insert("cj".into(), vec![3, 7]); // 7 + 2 = 9: outside the coordinates
    assert!(build(t).is_err());
    let mut t = ok();
    t.ints.insert("f".into(), vec![0, 3]); // three functions
    assert!(build(t).is_err());
    let mut t = ok();
    t.complex.insert("sj".into(), vec![c(0.0, -0.5)]);
    assert!(build(t).is_err());
    let mut t = ok();
    t.ints.remove("ci");
    assert!(build(t).is_err());
}

/// Phi, Jacobian values, nu and gamma of `k` over duals at (q, qd, t)
/// (tangents zero): their values.
fn values(k: &Kin<Dual>, q: &[f64], qd: &[f64], t: f64) -> [Vec<f64>; 4] {
    use crate::families::At;
    let (q, qd): (Vec<Dual>, Vec<Dual>) =
        (q.iter().map(|&x| Dual::c(x)).collect(), qd.iter().map(|&x| Dual::c(x)).collect());
    let mut e = vec![Complex::new(Dual::c(1.0), Dual::c(0.0)); k.n];
    k.rotate(&q, &mut e);
    let at = At { q: &q, e: &e, t };
    let (mut phi, mut jac, mut nu, mut gamma) =
        (vec![Dual::c(0.0); k.m], vec![Dual::c(0.0); k.nnz], vec![Dual::c(0.0); k.m], vec![Dual::c(0.0); k.m]);
    k.phi(&at, &mut phi);
    k.jac(&at, &mut jac);
    k.nu(t, &mut nu);
    k.gamma(&at, &qd, &mut gamma);
    [phi, jac, nu, gamma].map(|v| v.iter().map(|x| x.v).collect())
}

/// Joints whose local points are exactly zero (the revolute's s'_i, s'_j,
/// the line's base point and point, each alone and both) are evaluated
/// without the products with them: the figures of the full kernels to the
/// bit but for the sign of an exact zero (tolerance 0). The full kernels'
/// are the dual kernels' values with a tangent seeded on every local point
/// (not zero: the full group). Their derivatives against finite
/// differences as the other families'.
#[test]
fn zero_local_points_left_out_give_the_full_kernels_figures() {
    let (q, qd) = state(&[]);
    let z = c(0.0, 0.0);
    let revolute = table(
        &[("ci", vec![0, 3, 0, 6, 3]), ("cj", vec![3, 6, 6, 0, 0])],
        &[],
        &[("si", vec![z, c(-0.3, 0.2), z, c(0.2, 0.0), z]), ("sj", vec![c(0.0, -0.5), z, z, c(0.6, 0.6), z])],
    );
    let line = |angle: bool| {
        let (ai, aj, phi0) = if angle {
            (vec![2, 5, 8, 2], vec![5, 8, 2, 8], vec![0.3, -0.1, 0.0, 0.2])
        } else {
            (vec![], vec![], vec![])
        };
        table(
            &[("ca", vec![0, 3, 6, 0]), ("cb", vec![3, 6, 0, 6]), ("ai", ai), ("aj", aj)],
            &[("phi0", phi0)],
            &[
                ("pa", vec![z, c(0.2, 0.1), z, c(-0.1, 0.3)]),
                ("ua", vec![c(-0.5, 0.8), c(0.3, 0.4), c(1.0, 0.0), c(0.0, -0.7)]),
                ("ob", vec![c(0.4, -0.3), z, z, c(0.2, 0.2)]),
            ],
        )
    };
    for (kind, t) in [("revolute", revolute), ("line", line(true)), ("line", line(false))] {
        let mut full = t.clone();
        for key in ["si", "sj", "pa", "ob"] {
            if let Some(v) = t.complex.get(key) {
                full.d_complex.insert(key.to_string(), vec![c(1.0, 0.0); v.len()]);
            }
        }
        let k = kin(kind, t.clone(), 0);
        let want = values(&kin_with(kind, full, 0, &functions(), &outlines()), &q, &qd, 0.8);
        let got = all_f64(&k, &q, &qd, 0.8);
        let mut zeros = 0;
        for (w, name) in ["Phi", "Jacobian", "nu", "gamma"].iter().enumerate() {
            assert_eq!(got[w].len(), want[w].len());
            for (r, (x, y)) in got[w].iter().zip(&want[w]).enumerate() {
                assert!(x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0), "{kind}: {name}[{r}] {x} != {y}");
                zeros += (*x == 0.0) as usize;
            }
        }
        assert!(zeros > 0, "{kind}: no entry left out");
        let (rows, cols): (Vec<usize>, Vec<usize>) = if kind == "revolute" {
            let joint = |i: usize, j: usize| {
                [(0, i), (0, i + 2), (0, j), (0, j + 2), (1, i + 1), (1, i + 2), (1, j + 1), (1, j + 2)]
            };
            pattern(2, &[&joint(0, 3), &joint(3, 6), &joint(0, 6), &joint(6, 0), &joint(3, 0)])
        } else {
            let per = if t.ints["ai"].is_empty() { 1 } else { 2 };
            let ai = t.ints["ai"].iter().map(|&x| x as usize).collect::<Vec<_>>();
            let aj = t.ints["aj"].iter().map(|&x| x as usize).collect::<Vec<_>>();
            let mut entries: Vec<Vec<(usize, usize)>> = Vec::new();
            for (c, (&a, &b)) in [0usize, 3, 6, 0].iter().zip(&[3usize, 6, 0, 6]).enumerate() {
                let mut e = vec![(0, a), (0, a + 1), (0, a + 2), (0, b), (0, b + 1), (0, b + 2)];
                if per == 2 {
                    e.extend([(1, ai[c]), (1, aj[c])]);
                }
                entries.push(e);
            }
            let refs: Vec<&[(usize, usize)]> = entries.iter().map(|e| &e[..]).collect();
            pattern(per, &refs)
        };
        check(&k, &rows, &cols, &q, &qd, 0.8);
        check_parameters(kind, &t, 0, &q, &qd, 0.8);
    }
}

/// gamma reading the revolutes' rotated local points from the Jacobian
/// values at the same q (Kin::gamma_with, the march's rates) gives
/// `gamma`'s figures to the bit (tolerance 0), over the four groups of
/// zero local points, at configurations turned through a full circle.
#[test]
fn gamma_from_the_jacobian_equals_gamma_to_the_bit() {
    use crate::families::At;
    let z = c(0.0, 0.0);
    let t = table(
        &[("ci", vec![0, 3, 0, 6, 3, 0]), ("cj", vec![3, 6, 6, 0, 0, 3])],
        &[],
        &[
            ("si", vec![z, c(-0.3, 0.2), z, c(0.2, 0.0), z, c(0.4, 0.1)]),
            ("sj", vec![c(0.0, -0.5), z, z, c(0.6, 0.6), z, c(1e-3, -7.0)]),
        ],
    );
    let k = kin("revolute", t, 0);
    let (q0, qd) = state(&[]);
    for step in 0..40 {
        let q: Vec<f64> =
            q0.iter().enumerate().map(|(j, x)| x + 0.157 * step as f64 * (1.0 + j as f64 * 0.1)).collect();
        let mut e = vec![C64::new(1.0, 0.0); k.n];
        k.rotate(&q, &mut e);
        let at = At { q: &q, e: &e, t: 0.8 };
        let (mut jac, mut want, mut got) = (vec![0.0; k.nnz], vec![0.0; k.m], vec![f64::NAN; k.m]);
        k.jac(&at, &mut jac);
        k.gamma(&at, &qd, &mut want);
        k.gamma_with(&at, &qd, Some(&jac), &mut got);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got), bits(&want), "at step {step}");
        assert!(want.iter().filter(|x| **x != 0.0).count() >= 6);
    }
}

/// The entries Kin::zero_entries marks (a revolute's B s' where s' is
/// exactly zero: two per zero side; a line's u . A_b s'_b where ob is) are
/// exactly 0 at every configuration (tolerance 0), and none is marked
/// where the local points are nonzero; the simple family marks none.
#[test]
fn the_zero_entries_are_zero_at_every_configuration() {
    use crate::families::At;
    let z = c(0.0, 0.0);
    let (q0, _) = state(&[]);
    // the marked entries of kind's table t, then at 40 configurations: those 0, the others not
    // (a line's -ta may cross 0 at some: `all` only for the revolute's)
    let zeros = |kind: &str, t: Table, all: bool| -> Vec<usize> {
        let k = kin(kind, t, 0);
        let zero = k.zero_entries();
        for step in 0..40 {
            let q: Vec<f64> =
                q0.iter().enumerate().map(|(j, x)| x + 0.157 * step as f64 * (1.0 + j as f64 * 0.1)).collect();
            let mut e = vec![C64::new(1.0, 0.0); k.n];
            k.rotate(&q, &mut e);
            let mut jac = vec![f64::NAN; k.nnz];
            k.jac(&At { q: &q, e: &e, t: 0.8 }, &mut jac);
            assert!((0..k.nnz).all(|e| !zero[e] || jac[e] == 0.0), "{kind} at step {step}: {jac:?}");
            assert!(!all || (0..k.nnz).all(|e| zero[e] || jac[e] != 0.0), "{kind} at step {step}: {jac:?}");
        }
        (0..k.nnz).filter(|&e| zero[e]).collect()
    };
    let revolute = table(
        &[("ci", vec![0, 3, 0, 6]), ("cj", vec![3, 6, 6, 0])],
        &[],
        &[("si", vec![z, c(-0.3, 0.2), z, c(0.2, 0.0)]), ("sj", vec![c(0.0, -0.5), z, z, c(0.6, 0.6)])],
    );
    // joints 0 (s_i = 0), 1 (s_j = 0), 2 (both), 3 (neither): 2 + 2 + 4 + 0 entries
    assert_eq!(zeros("revolute", revolute, true), vec![1, 5, 11, 15, 17, 19, 21, 23]);
    assert_eq!(zeros("simple", simple_table(), false), Vec::<usize>::new());
    // the line family, with and without its angle row: constraints 1 and 2 have ob = 0
    for (ai, aj, phi0, width) in
        [(vec![2, 5, 8, 2], vec![5, 8, 2, 8], vec![0.3, -0.1, 0.0, 0.2], 8), (vec![], vec![], vec![], 6)]
    {
        let line = table(
            &[("ca", vec![0, 3, 6, 0]), ("cb", vec![3, 6, 0, 6]), ("ai", ai), ("aj", aj)],
            &[("phi0", phi0)],
            &[
                ("pa", vec![z, c(0.2, 0.1), z, c(-0.1, 0.3)]),
                ("ua", vec![c(-0.5, 0.8), c(0.3, 0.4), c(1.0, 0.0), c(0.0, -0.7)]),
                ("ob", vec![c(0.4, -0.3), z, z, c(0.2, 0.2)]),
            ],
        );
        assert_eq!(zeros("line", line, false), vec![width + 5, 2 * width + 5]);
    }
}

/// `jac_over` on the Jacobian of another configuration (its constant
/// entries kept) gives `jac`'s values to the bit (tolerance 0), and
/// `gamma_over` on the last gamma (zeros at first) gamma's: the simple,
/// revolute (every `Sides` group), line (with and without its angle row)
/// and distance (the full kernel) families.
#[test]
fn the_jacobian_and_gamma_over_their_constant_entries_equal_jac_and_gamma_to_the_bit() {
    use crate::families::At;
    let z = c(0.0, 0.0);
    let kinds = [
        ("simple", simple_table()),
        (
            "revolute",
            table(
                &[("ci", vec![0, 3, 0, 6]), ("cj", vec![3, 6, 6, 0])],
                &[],
                &[("si", vec![z, c(-0.3, 0.2), z, c(0.2, 0.0)]), ("sj", vec![c(0.0, -0.5), z, z, c(0.6, 0.6)])],
            ),
        ),
        (
            "line",
            table(
                &[("ca", vec![0, 3]), ("cb", vec![3, 6]), ("ai", vec![2, 5]), ("aj", vec![5, 8])],
                &[("phi0", vec![0.3, -0.1])],
                &[("pa", vec![c(0.2, 0.1), z]), ("ua", vec![c(-0.5, 0.8), c(0.6, 0.8)]), ("ob", vec![c(0.4, -0.3), z])],
            ),
        ),
        (
            "line",
            table(
                &[("ca", vec![6]), ("cb", vec![0]), ("ai", vec![]), ("aj", vec![])],
                &[("phi0", vec![])],
                &[("pa", vec![c(0.2, 0.1)]), ("ua", vec![c(-0.5, 0.8)]), ("ob", vec![c(0.4, -0.3)])],
            ),
        ),
    ];
    for (kind, t) in kinds {
        let k = kin(kind, t, 0);
        let (q0, _) = state(&[]);
        let at_step = |step: usize| -> (Vec<f64>, Vec<C64>) {
            let q: Vec<f64> =
                q0.iter().enumerate().map(|(j, x)| x + 0.157 * step as f64 * (1.0 + j as f64 * 0.1)).collect();
            let mut e = vec![C64::new(1.0, 0.0); k.n];
            k.rotate(&q, &mut e);
            (q, e)
        };
        let (q, e) = at_step(0);
        let (mut over, mut gamma_over) = (vec![0.0; k.nnz], vec![0.0; k.m]);
        k.jac(&At { q: &q, e: &e, t: 0.8 }, &mut over);
        let qd: Vec<f64> = (0..k.n).map(|j| 0.3 - 0.07 * j as f64).collect();
        for step in 1..20 {
            let (q, e) = at_step(step);
            let at = At { q: &q, e: &e, t: 0.8 + 0.01 * step as f64 };
            let mut want = vec![f64::NAN; k.nnz];
            k.jac(&at, &mut want);
            k.jac_over(&at, &mut over);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&over), bits(&want), "{kind} at step {step}");
            // gamma over the last one (zeros first): gamma's figures
            let mut gamma = vec![f64::NAN; k.m];
            k.gamma_with(&at, &qd, Some(&want), &mut gamma);
            k.gamma_over(&at, &qd, Some(&over), &mut gamma_over);
            assert_eq!(bits(&gamma_over), bits(&gamma), "{kind}'s gamma at step {step}");
        }
    }
}

/// A simple family of grounds and cranks at a constant speed (d'' +0 at
/// every t: a constant, a polynomial of degree one) is still
/// (Simple::gamma_still): `Kin::gamma_over` leaves its rows as they were
/// (a room of NaN stays NaN), and over zeros gives gamma's figures to the
/// bit at every t; a quadratic driver or a general row makes it move.
#[test]
fn grounds_and_constant_speed_cranks_are_left_out_of_gamma_over() {
    use crate::families::At;
    let f = table(
        &[("kind", vec![POLY, POLY, POLY]), ("start", vec![0, 1, 3, 6])],
        &[("data", vec![1.3, 0.4, 2.0, 0.1, 0.2, 0.3])],
        &[],
    );
    let rows = |fs: Vec<i64>, point: i64| {
        table(
            &[
                ("a", vec![0, 1, 2, 5]),
                ("angle", vec![2, 2, 2, 5]),
                ("k", vec![0, 1, 0, 0]),
                ("point", vec![0, 0, 0, point]),
                ("relative", vec![0, 0, 0, 0]),
                ("f", fs),
            ],
            &[("mx", vec![0.0, 0.0, 0.0, point as f64]), ("my", vec![0.0; 4])],
            &[("local", vec![c(0.0, 0.0), c(0.0, 0.0), c(0.0, 0.0), c(0.3 * point as f64, 0.1)])],
        )
    };
    let (q, qd) = state(&[]);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (fs, point, still) in [(vec![0, 0, 0, 1], 0, true), (vec![0, 0, 0, 2], 0, false), (vec![0, 0, 0, 1], 1, false)]
    {
        let k = kin_with::<f64>("simple", rows(fs, point), 0, &f, &outlines());
        let mut e = vec![C64::new(1.0, 0.0); k.n];
        k.rotate(&q, &mut e);
        let mut zeros = vec![0.0; k.m];
        for t in [0.0, -0.0, 0.37, -1.9, 1e3] {
            let at = At { q: &q, e: &e, t };
            let (mut gamma, mut nan) = (vec![f64::NAN; k.m], vec![f64::NAN; k.m]);
            k.gamma_with(&at, &qd, None, &mut gamma);
            k.gamma_over(&at, &qd, None, &mut zeros);
            assert_eq!(bits(&zeros), bits(&gamma), "t {t}");
            k.gamma_over(&at, &qd, None, &mut nan);
            assert_eq!(nan.iter().all(|x| x.is_nan()), still, "t {t}");
            if still {
                assert!(gamma.iter().all(|x| x.to_bits() == 0), "{gamma:?}");
            }
        }
    }
}

/// `Kin::jac_over` leaves untouched what is constant: a simple family of
/// grounds and drivers alone (Simple::jac_still: its entries are 1) is not
/// visited, and a revolute writes neither the B s' entries of a side whose
/// local point is zero nor the gamma rows (`gamma_over`) of a joint with
/// neither point (rooms of NaN keep their NaN there, every other place is
/// written); over `jac`'s values and zeros they give `jac`'s and gamma's
/// figures to the bit (the test above).
#[test]
fn constant_entries_and_rows_are_left_out_of_jac_over_and_gamma_over() {
    use crate::families::At;
    let z = c(0.0, 0.0);
    let (q, qd) = state(&[]);
    let rev = table(
        &[("ci", vec![0, 3, 0, 6]), ("cj", vec![3, 6, 6, 0])],
        &[],
        &[("si", vec![z, c(-0.3, 0.2), z, c(0.2, 0.0)]), ("sj", vec![c(0.0, -0.5), z, z, c(0.6, 0.6)])],
    );
    let k = kin("revolute", rev, 0);
    let mut e = vec![C64::new(1.0, 0.0); k.n];
    k.rotate(&q, &mut e);
    let at = At { q: &q, e: &e, t: 0.4 };
    let (mut jac, mut gamma) = (vec![f64::NAN; k.nnz], vec![f64::NAN; k.m]);
    k.jac_over(&at, &mut jac);
    // per joint: (s'_i zero, s'_j zero); entries 1, 5 are B_i s'_i's, 3, 7 -B_j s'_j's
    for (p, (zi, zj)) in [(true, false), (false, true), (true, true), (false, false)].into_iter().enumerate() {
        let o = &jac[8 * p..8 * p + 8];
        assert!(o[0].is_nan() && o[2].is_nan() && o[4].is_nan() && o[6].is_nan(), "{o:?}");
        assert_eq!((o[1].is_nan(), o[5].is_nan()), (zi, zi), "joint {p}: {o:?}");
        assert_eq!((o[3].is_nan(), o[7].is_nan()), (zj, zj), "joint {p}: {o:?}");
        let mut v = vec![0.0; k.nnz];
        k.jac(&at, &mut v);
        k.gamma_over(&at, &qd, Some(&v), &mut gamma);
        let g = &gamma[2 * p..2 * p + 2];
        assert_eq!(g.iter().all(|x| x.is_nan()), zi && zj, "joint {p}: {g:?}");
    }
    let grounds = table(
        &[
            ("a", vec![0, 1, 2, 5]),
            ("angle", vec![2, 2, 2, 5]),
            ("k", vec![0, 1, 0, 0]),
            ("point", vec![0, 0, 0, 0]),
            ("relative", vec![0, 0, 0, 0]),
            ("f", vec![0, 0, 0, 1]),
        ],
        &[("mx", vec![0.0; 4]), ("my", vec![0.0; 4])],
        &[("local", vec![z; 4])],
    );
    let k = kin("simple", grounds, 0);
    let mut nan = vec![f64::NAN; k.nnz];
    k.jac_over(&at, &mut nan);
    assert!(nan.iter().all(|x| x.is_nan()), "{nan:?}");
    let mut general = vec![f64::NAN; kin("simple", simple_table(), 0).nnz];
    kin("simple", simple_table(), 0).jac_over(&at, &mut general);
    assert!(general.iter().any(|x| !x.is_nan()), "{general:?}");
}

/// A driver of two coefficients (Functions::line) is evaluated in Phi
/// without the functions' lookups (`line_at`): the same figures as
/// `Functions::eval` to the bit, signed zeros among the coefficients and
/// the times, and an infinite or NaN time; a constant, a quadratic and a
/// one-coefficient polynomial keep `eval`.
#[test]
fn a_two_coefficient_driver_in_phi_equals_eval_to_the_bit() {
    use crate::families::At;
    let (q, _) = state(&[]);
    let mut e = vec![C64::new(1.0, 0.0); q.len()];
    for data in [vec![1.3, 0.4], vec![-0.0, -0.0], vec![0.0, -0.0], vec![-0.0, 2.5], vec![0.7], vec![0.1, 0.2, 0.3]] {
        let f = table(
            &[("kind", vec![POLY, POLY]), ("start", vec![0, 1, 1 + data.len() as i64])],
            &[("data", [vec![0.25], data.clone()].concat())],
            &[],
        );
        let rows = table(
            &[
                ("a", vec![0, 5]),
                ("angle", vec![2, 5]),
                ("k", vec![0, 0]),
                ("point", vec![0, 0]),
                ("relative", vec![0, 0]),
                ("f", vec![0, 1]),
            ],
            &[("mx", vec![0.0; 2]), ("my", vec![0.0; 2])],
            &[("local", vec![c(0.0, 0.0); 2])],
        );
        let k = kin_with::<f64>("simple", rows, 0, &f, &outlines());
        assert_eq!(k.functions.line(1).is_some(), data.len() == 2, "{data:?}");
        k.rotate(&q, &mut e);
        for t in [0.0, -0.0, 0.37, -1.9, 1e3, f64::INFINITY, f64::NAN] {
            let mut phi = vec![0.0; k.m];
            k.phi(&At { q: &q, e: &e, t }, &mut phi);
            let want = q[5] - k.functions.eval(1, t, 0);
            assert_eq!(phi[1].to_bits(), want.to_bits(), "{data:?} at t {t}");
        }
    }
}
