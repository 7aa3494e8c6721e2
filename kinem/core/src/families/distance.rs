//! Revolute-revolute composite joint (Eq. 4.13; Jacobian Table 4.2; gamma
//! Table 4.3) and the distance driver, its extension with a length l(t)
//! that follows a function (a linear actuator between two points).
use super::{dot, i, At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Phi = d . d - l(t)^2 with d = r_j^P - r_i^P (Eq. 4.13): one row.
/// Columns: ci, cj the bodies' x columns; si, sj the points P on each;
/// f the length's function (a constant for revolute-revolute), an index
/// into the model's functions.
///
/// Invariants (checked in `new`): cj, si, sj, f as long as ci; every ci, cj
/// below n - 2; so a kernel that checked `At::holds(n)` reads them unchecked.
pub struct Distance<S = f64> {
    n: usize,
    ci: Vec<usize>,
    cj: Vec<usize>,
    si: Vec<Complex<S>>,
    sj: Vec<Complex<S>>,
    f: Vec<usize>,
}

impl<S: Real> Distance<S> {
    pub fn new(t: &Table, n: usize, functions: usize) -> Result<Self, String> {
        let ci = t.index("ci", n.saturating_sub(2))?;
        t.same_length(ci.len(), &["cj", "si", "sj", "f"])?;
        Ok(Distance {
            cj: t.index("cj", n.saturating_sub(2))?,
            si: t.cplx_s("si")?,
            sj: t.cplx_s("sj")?,
            f: t.index("f", functions)?,
            n,
            ci,
        })
    }

    pub fn rows(&self) -> usize {
        self.ci.len()
    }

    pub fn entries(&self) -> usize {
        6 * self.ci.len()
    }

    /// Whether any length is not a constant (a distance driver).
    pub fn time_dependent(&self, s: &Shared<S>) -> bool {
        self.f.iter().any(|&f| !s.functions.constant(f))
    }

    /// d = r_j + A_j s'_j - r_i - A_i s'_i, A_i s'_i, A_j s'_j.
    ///
    /// # Safety
    /// c < ci.len() and `at.holds(n)` (Distance's invariants).
    #[inline(always)]
    unsafe fn parts(&self, at: &At<S>, c: usize) -> (Complex<S>, Complex<S>, Complex<S>) {
        let (a, b) = (*self.ci.get_unchecked(c), *self.cj.get_unchecked(c));
        let (sa, sb) = (*self.si.get_unchecked(c) * at.rot_at(a), *self.sj.get_unchecked(c) * at.rot_at(b));
        (at.r_at(b) + sb - at.r_at(a) - sa, sa, sb)
    }

    /// Eq. 4.13: d . d - l(t)^2.
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() <= self.ci.len());
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: c < out.len() <= ci.len(), q and e hold n (asserted above)
            let (d, _, _) = unsafe { self.parts(at, c) };
            let l = s.functions.eval(self.f[c], at.t, 0);
            *o = d.re * d.re + d.im * d.im - l * l;
        }
    }

    /// 2 [-d^T, -d^T B_i s'_i, d^T, d^T B_j s'_j] (Table 4.2).
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= 6 * self.ci.len());
        for (c, o) in out.chunks_exact_mut(6).take(self.ci.len()).enumerate() {
            // SAFETY: c < ci.len(), q and e hold n (asserted above)
            let (d, a, b) = unsafe { self.parts(at, c) };
            o.copy_from_slice(&[
                d.re * -2.0,
                d.im * -2.0,
                (d.im * a.re - d.re * a.im) * -2.0,
                d.re * 2.0,
                d.im * 2.0,
                (d.im * b.re - d.re * b.im) * 2.0,
            ]);
        }
    }

    /// nu = -Phi_t = (l^2)' = 2 l l'.
    pub fn nu(&self, t: f64, s: &Shared<S>, out: &mut [S]) {
        for (c, o) in out.iter_mut().enumerate() {
            *o = s.functions.eval(self.f[c], t, 0) * s.functions.eval(self.f[c], t, 1) * 2.0;
        }
    }

    /// -2 d'.d' - 2 d.(A_i s'_i w_i^2 - A_j s'_j w_j^2) (Table 4.3), plus
    /// (l^2)'' = 2 (l'^2 + l l'') for a distance driver.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() <= self.ci.len());
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: c < out.len() <= ci.len(), q, e and qd hold n (asserted above), x, y < n - 2
            let ((d, a, b), wi, wj, rx, ry) = unsafe {
                let (x, y) = (*self.ci.get_unchecked(c), *self.cj.get_unchecked(c));
                let r = |k: usize| Complex::new(*qd.get_unchecked(k), *qd.get_unchecked(k + 1));
                (self.parts(at, c), *qd.get_unchecked(x + 2), *qd.get_unchecked(y + 2), r(x), r(y))
            };
            let dd = ry + i::<S>() * b * wj - rx - i::<S>() * a * wi;
            let e = a * (wi * wi) - b * (wj * wj);
            let f = self.f[c];
            let second = if s.functions.constant(f) {
                S::zero()
            } else {
                let (l, l1, l2) =
                    (s.functions.eval(f, at.t, 0), s.functions.eval(f, at.t, 1), s.functions.eval(f, at.t, 2));
                (l1 * l1 + l * l2) * 2.0
            };
            *o = (dd.re * dd.re + dd.im * dd.im) * -2.0 - dot(d, e) * 2.0 + second;
        }
    }
}
