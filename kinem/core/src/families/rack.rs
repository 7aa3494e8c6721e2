//! Rack and pinion (Eqs. 4.19, 4.20 and their general form, Problem 4.15),
//! Sec. 4.2.3: the integrated no-slip condition of the pitch circle on the
//! pitch line.
use super::{dot, i, rd, At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Phi = u . (C - P) + rho (phi_i - phi_j - phi0): pinion i with pitch
/// radius rho and centre C = r_i + A_i c'; rack j with pitch line through
/// P = r_j + A_j s'_j along the unit vector u = A_j u'. Rack fixed along x:
/// Eq. 4.20; pinion centre fixed too: Eq. 4.19. Columns: ci (pinion), cj
/// (rack) x columns; c (c'), s (s'_j), u (u', any length: normalised
/// here), rho, phi0.
pub struct Rack<S = f64> {
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

    #[inline(always)]
    fn parts(&self, at: &At<S>, c: usize) -> Parts<S> {
        let (x, y) = (self.ci[c], self.cj[c]);
        let (ei, ej) = (at.rot(x), at.rot(y));
        let (a, b) = (self.cc[c] * ei, self.s[c] * ej);
        Parts { u: self.u[c] * ej, d: at.r(x) + a - at.r(y) - b, a, b }
    }

    /// u . d + rho (phi_i - phi_j - phi0) (Eqs. 4.19, 4.20, Problem 4.15).
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        for (c, o) in out.iter_mut().enumerate() {
            let p = self.parts(at, c);
            *o = dot(p.u, p.d) + self.rho[c] * (at.q[self.ci[c] + 2] - at.q[self.cj[c] + 2] - self.phi0[c]);
        }
    }

    /// [u^T, u . (i A_i c') + rho, -u^T, (i u) . d - u . (i A_j s'_j) - rho].
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        for c in 0..self.ci.len() {
            let Parts { u, d, a, b } = self.parts(at, c);
            out[6 * c..6 * c + 6].copy_from_slice(&[
                u.re,
                u.im,
                u.im * a.re - u.re * a.im + self.rho[c],
                -u.re,
                -u.im,
                (u.re * d.im - u.im * d.re) - (u.im * b.re - u.re * b.im) - self.rho[c],
            ]);
        }
    }

    /// -(u . d)'' without the acceleration terms.
    pub fn gamma(&self, at: &At<S>, qd: &[S], _: &Shared<S>, out: &mut [S]) {
        let i = i::<S>();
        for (c, o) in out.iter_mut().enumerate() {
            let (x, y) = (self.ci[c], self.cj[c]);
            let Parts { u, d, a, b } = self.parts(at, c);
            let (wi, wj) = (qd[x + 2], qd[y + 2]);
            let dd = rd(qd, x) + i * a * wi - rd(qd, y) - i * b * wj;
            let iu = i * u;
            *o = wj * wj * dot(u, d) - wj * dot(iu, dd) * 2.0 + wi * wi * dot(u, a) - wj * wj * dot(u, b);
        }
    }
}
