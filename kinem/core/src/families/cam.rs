//! Disk cam with a roller follower (Eq. 4.28) and with a flat-faced
//! follower (Eq. 4.29), Sec. 4.2.5. Each has the artificial coordinate
//! theta of the contact point P_i on the cam's outline (curve.rs):
//! a = A_i p(theta), g = A_i g'(theta) the tangent there, h its derivative.
use super::curve::Outline;
use super::rack::unit;
use super::{dot, i, rd, At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// The cam i (columns cc, ct, outline), the follower j (x column cj) and
/// its point Q_j (sj).
struct Pair<S> {
    curve: Outline,
    cj: Vec<usize>,
    sj: Vec<Complex<S>>,
}

impl<S: Real> Pair<S> {
    fn new(t: &Table, n: usize, outlines: usize, extra: &[&str]) -> Result<Self, String> {
        let curve = Outline::new(t, n, outlines)?;
        t.same_length(curve.len(), &["cj", "sj"])?;
        t.same_length(curve.len(), extra)?;
        Ok(Pair { cj: t.index("cj", n.saturating_sub(2))?, sj: t.cplx_s("sj")?, curve })
    }
}

/// Phi = [g . d, d . d - rho^2] with d = r_j + A_j s'_j^Q - r_i - a, from
/// the contact point P_i to the roller centre Q_j (Eq. 4.28): d is normal
/// to the outline and as long as the roller's radius. Columns: cc, ct,
/// outline, cj, sj, rho (squared here).
pub struct Roller<S = f64> {
    p: Pair<S>,
    rho2: Vec<S>,
}

impl<S: Real> Roller<S> {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        let rho: Vec<S> = t.real_s("rho")?;
        Ok(Roller { p: Pair::new(t, n, outlines, &["rho"])?, rho2: rho.iter().map(|&r| r * r).collect() })
    }

    pub fn rows(&self) -> usize {
        2 * self.rho2.len()
    }

    pub fn entries(&self) -> usize {
        14 * self.rho2.len()
    }

    /// d = r_j + A_j s'_j - r_i - a, and A_j s'_j.
    #[inline(always)]
    fn d(&self, at: &At<S>, c: usize, a: Complex<S>) -> (Complex<S>, Complex<S>) {
        let (x, y) = (self.p.curve.cc[c], self.p.cj[c]);
        let b = self.p.sj[c] * at.rot(y);
        (at.r(y) + b - at.r(x) - a, b)
    }

    /// Eq. 4.28: [g . d, d . d - rho^2].
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        for c in 0..self.rho2.len() {
            let k = self.p.curve.at(at, s, c);
            let (d, _) = self.d(at, c, k.a);
            out[2 * c] = dot(k.g, d);
            out[2 * c + 1] = dot(d, d) - self.rho2[c];
        }
    }

    /// Columns [r_i, phi_i, theta, r_j, phi_j] of both rows.
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        let i = i::<S>();
        for c in 0..self.rho2.len() {
            let k = self.p.curve.at(at, s, c);
            let (a, g) = (k.a, k.g);
            let (d, b) = self.d(at, c, a);
            out[14 * c..14 * c + 14].copy_from_slice(&[
                -g.re,
                -g.im,
                dot(i * g, d) - dot(g, i * a),
                dot(k.h, d) - dot(g, g),
                g.re,
                g.im,
                dot(g, i * b),
                d.re * -2.0,
                d.im * -2.0,
                dot(d, i * a) * -2.0,
                dot(d, g) * -2.0,
                d.re * 2.0,
                d.im * 2.0,
                dot(d, i * b) * 2.0,
            ]);
        }
    }

    /// -(d/dt)^2 Phi without the acceleration terms: (g.d)'' = g''.d + 2 g'.d' + g.d''.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        let i = i::<S>();
        for c in 0..self.rho2.len() {
            let (x, y) = (self.p.curve.cc[c], self.p.cj[c]);
            let (k, r) = self.p.curve.moving(at, qd, s, c);
            let (d, b) = self.d(at, c, k.a);
            let wj = qd[y + 2];
            let d1 = rd(qd, y) + i * b * wj - rd(qd, x) - r.a1;
            let d2 = -b * (wj * wj) - r.a2;
            out[2 * c] = -(dot(r.g2, d) + dot(r.g1, d1) * 2.0 + dot(k.g, d2));
            out[2 * c + 1] = (dot(d1, d1) + dot(d, d2)) * -2.0;
        }
    }
}

/// Phi = [g . n, d . n] with n = A_j n'_j the unit normal of the follower's
/// face and d = r_i + a - r_j - A_j s'_j^Q, from a point Q_j of the face
/// to the contact point P_i (Eq. 4.29): the face is tangent to the outline
/// at P_i. Columns: cc, ct, outline, cj, sj, n (n'_j, any length: normalised here).
pub struct Flat<S = f64> {
    p: Pair<S>,
    n: Vec<Complex<S>>,
}

impl<S: Real> Flat<S> {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        Ok(Flat { p: Pair::new(t, n, outlines, &["n"])?, n: t.cplx_s("n")?.into_iter().map(unit).collect() })
    }

    pub fn rows(&self) -> usize {
        2 * self.n.len()
    }

    pub fn entries(&self) -> usize {
        10 * self.n.len()
    }

    /// d = r_i + a - r_j - A_j s'_j, A_j s'_j and n = A_j n'_j.
    #[inline(always)]
    fn parts(&self, at: &At<S>, c: usize, a: Complex<S>) -> (Complex<S>, Complex<S>, Complex<S>) {
        let (x, y) = (self.p.curve.cc[c], self.p.cj[c]);
        let e = at.rot(y);
        let b = self.p.sj[c] * e;
        (at.r(x) + a - at.r(y) - b, b, self.n[c] * e)
    }

    /// Eq. 4.29: [g . n, d . n].
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        for c in 0..self.n.len() {
            let k = self.p.curve.at(at, s, c);
            let (d, _, n) = self.parts(at, c, k.a);
            out[2 * c] = dot(k.g, n);
            out[2 * c + 1] = dot(d, n);
        }
    }

    /// Row 1 in [phi_i, theta, phi_j], row 2 in [r_i, phi_i, theta, r_j, phi_j].
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        let i = i::<S>();
        for c in 0..self.n.len() {
            let k = self.p.curve.at(at, s, c);
            let (a, g) = (k.a, k.g);
            let (d, b, n) = self.parts(at, c, a);
            out[10 * c..10 * c + 10].copy_from_slice(&[
                dot(i * g, n),
                dot(k.h, n),
                dot(g, i * n),
                n.re,
                n.im,
                dot(i * a, n),
                dot(g, n),
                -n.re,
                -n.im,
                dot(d, i * n) - dot(i * b, n),
            ]);
        }
    }

    /// -(g . n)'' and -(d . n)'' without the acceleration terms.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        let i = i::<S>();
        for c in 0..self.n.len() {
            let (x, y) = (self.p.curve.cc[c], self.p.cj[c]);
            let (k, r) = self.p.curve.moving(at, qd, s, c);
            let (d, b, n) = self.parts(at, c, k.a);
            let wj = qd[y + 2];
            let (n1, n2) = (i * n * wj, -n * (wj * wj));
            let d1 = rd(qd, x) + r.a1 - rd(qd, y) - i * b * wj;
            let d2 = r.a2 + b * (wj * wj);
            out[2 * c] = -(dot(r.g2, n) + dot(r.g1, n1) * 2.0 + dot(k.g, n2));
            out[2 * c + 1] = -(dot(d2, n) + dot(d1, n1) * 2.0 + dot(d, n2));
        }
    }
}
