//! Rack and pinion (Eqs. 4.19, 4.20 and their general form, Problem 4.15),
//! Sec. 4.2.3: the integrated no-slip condition of the pitch circle on the
//! pitch line.
use super::{dot, i, At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Phi = u . (C - P) + rho (phi_i - phi_j - phi0): pinion i with pitch
/// radius rho and centre C = r_i + A_i c'; rack j with pitch line through
/// P = r_j + A_j s'_j along the unit vector u = A_j u'. Rack fixed along x:
/// Eq. 4.20; pinion centre fixed too: Eq. 4.19. Columns: ci (pinion), cj
/// (rack) x columns; c (c'), s (s'_j), u (u', any length: normalised
/// here), rho, phi0. Each kernel checks `At::holds(n)` once per call,
/// then reads the columns its table was checked against n unchecked.
pub struct Rack<S = f64> {
    n: usize,
    ci: Vec<usize>,
    cj: Vec<usize>,
    cc: Vec<Complex<S>>,
    s: Vec<Complex<S>>,
    u: Vec<Complex<S>>,
    rho: Vec<S>,
    phi0: Vec<S>,
}

/// u = A_j u', d = C - P = r_i + A_i c' - r_j - A_j s'_j, A_i c', A_j s'_j.
struct Parts<S> {
    u: Complex<S>,
    d: Complex<S>,
    a: Complex<S>,
    b: Complex<S>,
}

/// u / |u|.
pub fn unit<S: Real>(u: Complex<S>) -> Complex<S> {
    let r = (u.re * u.re + u.im * u.im).sqrt();
    Complex::new(u.re / r, u.im / r)
}

impl<S: Real> Rack<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ci = t.index("ci", n.saturating_sub(2))?;
        t.same_length(ci.len(), &["cj", "c", "s", "u", "rho", "phi0"])?;
        Ok(Rack {
            n,
            cj: t.index("cj", n.saturating_sub(2))?,
            cc: t.cplx_s("c")?,
            s: t.cplx_s("s")?,
            u: t.cplx_s("u")?.into_iter().map(unit).collect(),
            rho: t.real_s("rho")?,
            phi0: t.real_s("phi0")?,
            ci,
        })
    }

    pub fn rows(&self) -> usize {
        self.ci.len()
    }

    pub fn entries(&self) -> usize {
        6 * self.ci.len()
    }

    /// # Safety
    /// c < ci.len() (so every column of the table has row c: `new`), and
    /// `at.holds(n)`.
    #[inline(always)]
    unsafe fn parts(&self, at: &At<S>, c: usize) -> Parts<S> {
        let (x, y) = (*self.ci.get_unchecked(c), *self.cj.get_unchecked(c));
        let (ei, ej) = (at.rot_at(x), at.rot_at(y));
        let (a, b) = (*self.cc.get_unchecked(c) * ei, *self.s.get_unchecked(c) * ej);
        Parts { u: *self.u.get_unchecked(c) * ej, d: at.r_at(x) + a - at.r_at(y) - b, a, b }
    }

    /// u . d + rho (phi_i - phi_j - phi0) (Eqs. 4.19, 4.20, Problem 4.15).
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() <= self.ci.len());
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: c < out.len() <= ci.len(), q and e hold n (asserted above), ci, cj < n - 2 (new)
            unsafe {
                let p = self.parts(at, c);
                let (x, y) = (*self.ci.get_unchecked(c), *self.cj.get_unchecked(c));
                let turn = *at.q.get_unchecked(x + 2) - *at.q.get_unchecked(y + 2) - *self.phi0.get_unchecked(c);
                *o = dot(p.u, p.d) + *self.rho.get_unchecked(c) * turn;
            }
        }
    }

    /// [u^T, u . (i A_i c') + rho, -u^T, (i u) . d - u . (i A_j s'_j) - rho].
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= 6 * self.ci.len());
        for (c, o) in out.chunks_exact_mut(6).take(self.ci.len()).enumerate() {
            // SAFETY: c < ci.len(), q and e hold n (asserted above)
            let (Parts { u, d, a, b }, rho) = unsafe { (self.parts(at, c), *self.rho.get_unchecked(c)) };
            o.copy_from_slice(&[
                u.re,
                u.im,
                u.im * a.re - u.re * a.im + rho,
                -u.re,
                -u.im,
                (u.re * d.im - u.im * d.re) - (u.im * b.re - u.re * b.im) - rho,
            ]);
        }
    }

    /// -(u . d)'' without the acceleration terms.
    pub fn gamma(&self, at: &At<S>, qd: &[S], _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() <= self.ci.len());
        let i = i::<S>();
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: c < out.len() <= ci.len(), q, e and qd hold n (asserted above), ci, cj < n - 2 (new)
            let (Parts { u, d, a, b }, wi, wj, rx, ry) = unsafe {
                let (x, y) = (*self.ci.get_unchecked(c), *self.cj.get_unchecked(c));
                let r = |k: usize| Complex::new(*qd.get_unchecked(k), *qd.get_unchecked(k + 1));
                (self.parts(at, c), *qd.get_unchecked(x + 2), *qd.get_unchecked(y + 2), r(x), r(y))
            };
            let dd = rx + i * a * wi - ry - i * b * wj;
            let iu = i * u;
            *o = wj * wj * dot(u, d) - wj * dot(iu, dd) * 2.0 + wi * wi * dot(u, a) - wj * wj * dot(u, b);
        }
    }
}
