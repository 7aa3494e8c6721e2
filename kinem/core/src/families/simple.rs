//! Simplified constraints (Eqs. 4.31-4.34) and driving constraints
//! (Eqs. 4.36-4.40); gamma Eq. 4.38 and the point forms.
//!
//! Every row has the form Phi = q_a [+ (A_i s'_i^P)_c] [- phi_k] - f(t):
//! q_a is x_i, y_i or phi_i, the point term mx Re(s) + my Im(s) with
//! s = A_i s'_i^P is present for the point forms (Eqs. 4.34, 4.39, 4.40),
//! the relative term for a motor between two moving bodies. ground,
//! absolute and driver rows all come here, one row each (ground: three).
use super::{lane, At, Dir, Shared};
use crate::real::{Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// Columns, one entry per row: a (the coordinate q_a), angle (phi_i's
/// column), k (phi_k's column when relative, else any valid column),
/// local (s'_i^P; 0 without a point), mx, my (1.0 for a point row's x or y
/// component, else 0.0), point and relative (flags: which Jacobian entries
/// the row has besides its 1 in column a), f (the driving function, an
/// index into the model's functions; a constant for ground and absolute).
///
/// Invariant (checked in `new`): every row's a, angle and k below n, so a
/// kernel that checked `At::holds(n)` reads their columns unchecked.
pub struct Simple<S = f64> {
    n: usize,
    rows: Vec<Row<S>>,
    entries: usize,
    /// the rows whose function is not a constant (row, function), once bound
    drivers: Vec<(usize, usize)>,
    /// the rows q_a - f(t) (no point term, not relative, Eqs. 4.31-4.33,
    /// 4.36): their kernels without the terms they lack, by whether f is a
    /// constant (a ground's, once bound) or a driver
    fixed: Vec<Plain<S>>,
    plain: Vec<Plain<S>>,
    /// the other rows (row, its first Jacobian entry): the general kernel
    general: Vec<(usize, usize)>,
}

/// A row q_a - f(t) (`Simple::fixed`, `plain`): its place k, coordinate a,
/// Jacobian entry e, and its function f or constant value.
struct Plain<S> {
    k: usize,
    a: usize,
    e: usize,
    f: usize,
    value: S,
    /// f's two coefficients where it is a polynomial of degree one
    /// (Functions::line, once bound): d(t) without its lookups
    line: Option<[S; 2]>,
}

/// d(t) = (0 t + c1) t + c0 of a function of two coefficients: `Functions::eval`'s
/// operations at order 0 (the same figures to the bit).
#[inline(always)]
fn line_at<S: Real>([c0, c1]: [S; 2], t: f64) -> S {
    (S::zero() * t + c1) * t + c0
}

/// One row's columns (see `Simple`), with w = 1.0 for a relative row (else
/// 0.0) and, once bound (`Simple::bind`), whether its function is not a
/// constant, else its constant value.
struct Row<S> {
    a: usize,
    angle: usize,
    k: usize,
    w: f64,
    local: Complex<S>,
    mx: f64,
    my: f64,
    point: bool,
    /// mx or my is not 0: the row has a point term (set in `new`)
    term: bool,
    relative: bool,
    f: usize,
    driven: bool,
    value: S,
}

impl<S: Real> Row<S> {
    /// The point term: mx Re(A_i s') + my Im(A_i s'), if the row has one.
    ///
    /// # Safety
    /// angle < e.len() (Simple's invariant where `At::holds(n)`).
    #[inline(always)]
    unsafe fn point_term(&self, at: &At<S>) -> Option<S> {
        if self.term {
            let s = self.local * *at.e.get_unchecked(self.angle);
            Some(s.re * self.mx + s.im * self.my)
        } else {
            None
        }
    }

    /// f(t) (order 0), f'(t), f''(t) of its function.
    #[inline(always)]
    fn drive(&self, t: f64, order: u8, s: &Shared<S>) -> S {
        if self.driven {
            s.functions.eval(self.f, t, order)
        } else if order == 0 {
            self.value
        } else {
            S::zero()
        }
    }
}

impl<S: Real> Simple<S> {
    pub fn new(t: &Table, n: usize, functions: usize) -> Result<Self, String> {
        let a = t.index("a", n)?;
        t.same_length(a.len(), &["angle", "k", "local", "mx", "my", "point", "relative", "f"])?;
        let (point, relative) = (t.flags("point")?, t.flags("relative")?);
        let (angle, k, f) = (t.index("angle", n)?, t.index("k", n)?, t.index("f", functions)?);
        let (local, mx, my) = (t.cplx_s("local")?, t.real("mx")?, t.real("my")?);
        let entries = a.len() + point.iter().filter(|&&p| p).count() + relative.iter().filter(|&&r| r).count();
        let rows = (0..a.len())
            .map(|r| Row {
                a: a[r],
                angle: angle[r],
                k: k[r],
                w: if relative[r] { 1.0 } else { 0.0 },
                local: local[r],
                mx: mx[r],
                my: my[r],
                point: point[r],
                term: mx[r] != 0.0 || my[r] != 0.0,
                relative: relative[r],
                f: f[r],
                driven: true,
                value: S::zero(),
            })
            .collect();
        let mut s =
            Simple { n, rows, entries, drivers: Vec::new(), fixed: Vec::new(), plain: Vec::new(), general: Vec::new() };
        s.group(None);
        Ok(s)
    }

    /// Takes each constant function's value (a ground's, an absolute
    /// constraint's) once, so that the kernels evaluate only the drivers.
    pub fn bind(&mut self, s: &Shared<S>) {
        for row in &mut self.rows {
            row.driven = !s.functions.constant(row.f);
            row.value = if row.driven { S::zero() } else { s.functions.eval(row.f, 0.0, 0) };
        }
        self.drivers = self.rows.iter().enumerate().filter(|(_, r)| r.driven).map(|(k, r)| (k, r.f)).collect();
        self.group(Some(s));
    }

    /// Sorts the rows into `fixed`, `plain` and `general` (before `bind`
    /// every function counts as a driver, and none is taken as a `line`).
    fn group(&mut self, s: Option<&Shared<S>>) {
        let (mut fixed, mut plain, mut general) = (Vec::new(), Vec::new(), Vec::new());
        let mut e = 0;
        for (k, r) in self.rows.iter().enumerate() {
            if r.point || r.relative || r.term {
                general.push((k, e));
            } else {
                let line = s.and_then(|s| s.functions.line(r.f)).filter(|_| r.driven);
                let p = Plain { k, a: r.a, e, f: r.f, value: r.value, line };
                if r.driven {
                    plain.push(p);
                } else {
                    fixed.push(p);
                }
            }
            e += 1 + r.point as usize + r.relative as usize;
        }
        (self.fixed, self.plain, self.general) = (fixed, plain, general);
    }

    pub fn rows(&self) -> usize {
        self.rows.len()
    }

    pub fn entries(&self) -> usize {
        self.entries
    }

    /// Whether any row's function is not a constant (a driver: nu, gamma terms).
    pub fn time_dependent(&self, s: &Shared<S>) -> bool {
        self.rows.iter().any(|r| !s.functions.constant(r.f))
    }

    /// Eqs. 4.31-4.40: q_a - w q_k + point term - f(t).
    /// (The rows q_a - f(t) without the products with w = 0: the figures
    /// of the general row to the bit but for the sign of an exact zero.)
    #[inline(always)]
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.rows.len());
        // SAFETY (the three loops): k < rows (group), out holds them; a, k, angle < n (new), q and e hold n (asserted above)
        for p in &self.fixed {
            unsafe { *out.get_unchecked_mut(p.k) = *at.q.get_unchecked(p.a) - p.value };
        }
        for p in &self.plain {
            let d = match p.line {
                Some(c) => line_at(c, at.t),
                None => s.functions.eval(p.f, at.t, 0),
            };
            unsafe { *out.get_unchecked_mut(p.k) = *at.q.get_unchecked(p.a) - d };
        }
        for &(k, _) in &self.general {
            unsafe {
                let row = self.rows.get_unchecked(k);
                let (qa, qk, p) = (*at.q.get_unchecked(row.a), *at.q.get_unchecked(row.k), row.point_term(at));
                let mut v = qa - qk * row.w - row.drive(at.t, 0, s);
                if let Some(p) = p {
                    v = v + p;
                }
                *out.get_unchecked_mut(k) = v;
            }
        }
    }

    /// 1 in column a; d(point term)/dphi_i = (B_i s')_c if a point; -1 in
    /// phi_k if relative (the pattern's order: a, angle, k, kept entries only).
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        self.jac_as::<true>(at, s, out)
    }

    /// `jac` where out holds the family's Jacobian from an earlier `jac`
    /// (its constant entries kept): the rows q_a - f(t), whose one entry is
    /// 1, are not written again.
    pub fn jac_over(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        self.jac_as::<false>(at, s, out)
    }

    /// `jac`, the constant rows' entries written when ALL.
    #[inline(always)]
    fn jac_as<const ALL: bool>(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.entries);
        if ALL {
            for p in self.fixed.iter().chain(&self.plain) {
                // SAFETY: e < entries (group), out holds them (asserted above)
                unsafe { *out.get_unchecked_mut(p.e) = S::one() };
            }
        }
        for &(k, mut e) in &self.general {
            let row = &self.rows[k];
            out[e] = S::one();
            e += 1;
            if row.point {
                // SAFETY: angle < n (new), e holds n (asserted above)
                let s = row.local * unsafe { *at.e.get_unchecked(row.angle) };
                out[e] = s.re * row.my - s.im * row.mx;
                e += 1;
            }
            if row.relative {
                out[e] = S::c(-row.w);
            }
        }
    }

    /// nu = -Phi_t = f'(t) per row (Eq. 4.37).
    pub fn nu(&self, t: f64, s: &Shared<S>, out: &mut [S]) {
        for (row, o) in self.rows.iter().zip(out) {
            *o = row.drive(t, 1, s);
        }
    }

    /// The rows whose nu may not be zero, (row, function) once bound:
    /// there nu = f'(t) (Eq. 4.37), elsewhere 0 (crate::model::Kin::nu).
    pub fn drivers(&self) -> &[(usize, usize)] {
        &self.drivers
    }

    /// Whether `jac_over` writes nothing: no point or relative row (the
    /// others' one entry is a constant 1, written by `jac`).
    pub fn jac_still(&self) -> bool {
        self.general.is_empty()
    }

    /// Whether every row `gamma_over` writes is +0 at any t, q and qd (once
    /// bound): no general row, and every driver's d'' +0 at every t
    /// (Functions::accel_zero; a crank at a constant speed). Over a room
    /// that holds this family's earlier gamma (+0 there too) or zeros it
    /// writes nothing new (crate::model::Kin::gamma_over leaves it out).
    pub fn gamma_still(&self, s: &Shared<S>) -> bool {
        self.general.is_empty() && self.plain.iter().all(|p| s.functions.accel_zero(p.f))
    }

    /// Eq. 4.38 and the point forms: f''(t) + (A_i s')_c w_i^2.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        self.gamma_as::<true>(at, qd, s, out)
    }

    /// `gamma` where out holds 0 at the rows q_a - c (a ground's: an
    /// earlier `gamma`'s, or zeros), which are not written again.
    pub fn gamma_over(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        self.gamma_as::<false>(at, qd, s, out)
    }

    /// `gamma`, the rows q_a - c (0) written when ALL.
    #[inline(always)]
    fn gamma_as<const ALL: bool>(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() >= self.rows.len());
        // SAFETY (the three loops): k < rows (group), out holds them; angle < n (new), e and qd hold n (asserted above)
        if ALL {
            for p in &self.fixed {
                unsafe { *out.get_unchecked_mut(p.k) = S::zero() };
            }
        }
        for p in &self.plain {
            unsafe { *out.get_unchecked_mut(p.k) = s.functions.eval(p.f, at.t, 2) };
        }
        for &(k, _) in &self.general {
            unsafe {
                let row = self.rows.get_unchecked(k);
                let mut v = row.drive(at.t, 2, s);
                if let Some(p) = row.point_term(at) {
                    let w = *qd.get_unchecked(row.angle);
                    v = v + p * (w * w);
                }
                *out.get_unchecked_mut(k) = v;
            }
        }
    }
}

/// The direct tangent kernels (super::Family::phi_tangent, jac_products,
/// gamma_tangent): the point term's s = A_i s'_i with its tangent
/// ds = i s s_phi_i + d(s') A_i, and the drivers' f(t) tangents (the
/// functions' tables), lane by lane.
impl<const N: usize> Simple<Lanes<N>> {
    /// -d/dp of Eqs. 4.31-4.40 at q' = 0: -(d(point term) - d f(t)).
    pub fn phi_tangent(&self, at: &At, s: &Shared<Lanes<N>>, out: &mut [[f64; N]]) {
        assert!(at.holds(self.n));
        for (row, o) in self.rows.iter().zip(out) {
            let f = row.drive(at.t, 0, s).d;
            if row.term {
                let mut v = f.map(|x| -x);
                // SAFETY: angle < n (new), e holds n (asserted above)
                let e = unsafe { *at.e.get_unchecked(row.angle) };
                for l in 0..N {
                    let ds = lane(row.local, l).1 * e;
                    v[l] += ds.re * row.mx + ds.im * row.my;
                }
                *o = v.map(|x| -x);
            } else {
                *o = f; // (-(-f), exactly)
            }
        }
    }

    /// The point term's s = A_i s' and its tangents ds (re, im per lane).
    ///
    /// # Safety
    /// angle < e.len(), s.len() (Simple's invariant where `At::holds(n)`).
    #[inline(always)]
    unsafe fn point(&self, row: &Row<Lanes<N>>, at: &At, s: &[[f64; N]], moved: bool) -> (C64, [f64; N], [f64; N]) {
        let (e, p) = (*at.e.get_unchecked(row.angle), s.get_unchecked(row.angle));
        let v = C64::new(row.local.re.v, row.local.im.v) * e;
        let (mut re, mut im) = (p.map(|x| -v.im * x), p.map(|x| v.re * x));
        if moved {
            for l in 0..N {
                let d = lane(row.local, l).1 * e;
                re[l] += d.re;
                im[l] += d.im;
            }
        }
        (v, re, im)
    }

    /// r2 -= D(J) v[0], r3 -= D(J) v[1]: a point row's (B_i s')_c entry
    /// alone has a tangent (the point rows are among `general`).
    pub fn jac_products(&self, d: &Dir<N>, v: &[&[f64]], r2: &mut [[f64; N]], r3: &mut [[f64; N]]) {
        let (at, s, moved) = (&d.at, d.s, d.moved);
        assert!(at.holds(self.n) && s.len() >= self.n && v.iter().all(|x| x.len() >= self.n));
        for &(k, _) in &self.general {
            let row = &self.rows[k];
            if !row.point {
                continue;
            }
            // SAFETY: angle < n (new), e, s and v hold n (asserted above)
            let (_, re, im) = unsafe { self.point(row, at, s, moved) };
            let d: [f64; N] = std::array::from_fn(|l| re[l] * row.my - im[l] * row.mx);
            for (w, r) in v.iter().zip([&mut *r2, &mut *r3]) {
                let w = w[row.angle];
                for l in 0..N {
                    r[k][l] -= d[l] * w;
                }
            }
        }
    }

    /// D(gamma) of Eq. 4.38 and the point forms: d f''(t) + d(p w^2)
    /// (d f'' only where a function that is not a constant moves:
    /// `Dir::drives`; the point terms' rows are among `general`).
    pub fn gamma_tangent(&self, d: &Dir<N>, sh: &Shared<Lanes<N>>, out: &mut [[f64; N]]) {
        let (at, qd, s, sd, moved) = (&d.at, d.qd, d.s, d.sd, d.moved);
        assert!(at.holds(self.n) && qd.len() >= self.n && s.len() >= self.n && sd.len() >= self.n);
        assert!(out.len() >= self.rows.len());
        if moved && d.drives {
            for (row, o) in self.rows.iter().zip(&mut *out) {
                let f = row.drive(at.t, 2, sh).d;
                for l in 0..N {
                    o[l] += f[l];
                }
            }
        }
        for &(k, _) in &self.general {
            let (row, o) = (&self.rows[k], &mut out[k]);
            if !row.term {
                continue;
            }
            // SAFETY: angle < n (new), e, qd, s and sd hold n (asserted above)
            let ((v, re, im), w, dw) =
                unsafe { (self.point(row, at, s, moved), *qd.get_unchecked(row.angle), sd.get_unchecked(row.angle)) };
            let (p, ww) = (v.re * row.mx + v.im * row.my, w * w);
            for l in 0..N {
                o[l] += (re[l] * row.mx + im[l] * row.my) * ww + p * (2.0 * w * dw[l]);
            }
        }
    }
}
