//! Disk cam with a roller follower (Eq. 4.28) and with a flat-faced
//! follower (Eq. 4.29), Sec. 4.2.5. Each has the artificial coordinate
//! theta of the contact point P_i on the cam's outline (curve.rs):
//! a = A_i p(theta), g = A_i g'(theta) the tangent there, h its derivative.
use super::curve::Outline;
use super::rack::unit;
use super::{dot, i, At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// The cam i (columns cc, ct, outline), the follower j (x column cj) and
/// its point Q_j (sj). Each kernel checks `At::holds(n)` once per call,
/// then reads the columns its table was checked against n unchecked.
struct Pair<S> {
    n: usize,
    curve: Outline,
    cj: Vec<usize>,
    sj: Vec<Complex<S>>,
}

impl<S: Real> Pair<S> {
    /// The x columns of constraint c's cam and follower, its follower's s'_j.
    ///
    /// # Safety
    /// c < curve.len() (every column has its rows: `new`).
    #[inline(always)]
    unsafe fn cols(&self, c: usize) -> (usize, usize, Complex<S>) {
        (*self.curve.cc.get_unchecked(c), *self.cj.get_unchecked(c), *self.sj.get_unchecked(c))
    }

    fn new(t: &Table, n: usize, outlines: usize, extra: &[&str]) -> Result<Self, String> {
        let curve = Outline::new(t, n, outlines)?;
        t.same_length(curve.len(), &["cj", "sj"])?;
        t.same_length(curve.len(), extra)?;
        Ok(Pair { n, cj: t.index("cj", n.saturating_sub(2))?, sj: t.cplx_s("sj")?, curve })
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
    ///
    /// # Safety
    /// c < rows() / 2 and `at.holds(n)`.
    #[inline(always)]
    unsafe fn d(&self, at: &At<S>, c: usize, a: Complex<S>) -> (Complex<S>, Complex<S>) {
        let (x, y, sj) = self.p.cols(c);
        let b = sj * at.rot_at(y);
        (at.r_at(y) + b - at.r_at(x) - a, b)
    }

    /// Eq. 4.28: [g . d, d . d - rho^2].
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.p.n) && out.len() >= 2 * self.rho2.len());
        for (c, o) in out.chunks_exact_mut(2).take(self.rho2.len()).enumerate() {
            // SAFETY: c < rho2.len() = the table's length (new), q and e hold n (asserted above)
            let (k, (d, _), rho2) = unsafe {
                let k = self.p.curve.at_unchecked(at, s, c);
                (k, self.d(at, c, k.a), *self.rho2.get_unchecked(c))
            };
            (o[0], o[1]) = (dot(k.g, d), dot(d, d) - rho2);
        }
    }

    /// Columns [r_i, phi_i, theta, r_j, phi_j] of both rows.
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.p.n) && out.len() >= 14 * self.rho2.len());
        let i = i::<S>();
        for (c, o) in out.chunks_exact_mut(14).take(self.rho2.len()).enumerate() {
            // SAFETY: c < rho2.len(), q and e hold n (asserted above)
            let (k, (d, b)) = unsafe {
                let k = self.p.curve.at_unchecked(at, s, c);
                (k, self.d(at, c, k.a))
            };
            let (a, g) = (k.a, k.g);
            o.copy_from_slice(&[
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
        assert!(at.holds(self.p.n) && qd.len() >= self.p.n && out.len() >= 2 * self.rho2.len());
        let i = i::<S>();
        for (c, o) in out.chunks_exact_mut(2).take(self.rho2.len()).enumerate() {
            // SAFETY: c < rho2.len(), q, e and qd hold n (asserted above), cc, cj < n - 2, ct < n (new)
            let (k, r, (d, b), wj, rx, ry) = unsafe {
                let (x, y, _) = self.p.cols(c);
                let (k, r) = self.p.curve.moving_unchecked(at, qd, s, c);
                let v = |j: usize| Complex::new(*qd.get_unchecked(j), *qd.get_unchecked(j + 1));
                (k, r, self.d(at, c, k.a), *qd.get_unchecked(y + 2), v(x), v(y))
            };
            let d1 = ry + i * b * wj - rx - r.a1;
            let d2 = -b * (wj * wj) - r.a2;
            (o[0], o[1]) = (-(dot(r.g2, d) + dot(r.g1, d1) * 2.0 + dot(k.g, d2)), (dot(d1, d1) + dot(d, d2)) * -2.0);
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
    ///
    /// # Safety
    /// c < rows() / 2 and `at.holds(n)`.
    #[inline(always)]
    unsafe fn parts(&self, at: &At<S>, c: usize, a: Complex<S>) -> (Complex<S>, Complex<S>, Complex<S>) {
        let (x, y, sj) = self.p.cols(c);
        let e = at.rot_at(y);
        let b = sj * e;
        (at.r_at(x) + a - at.r_at(y) - b, b, *self.n.get_unchecked(c) * e)
    }

    /// Eq. 4.29: [g . n, d . n].
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.p.n) && out.len() >= 2 * self.n.len());
        for (c, o) in out.chunks_exact_mut(2).take(self.n.len()).enumerate() {
            // SAFETY: c < n.len() = the table's length (new), q and e hold n (asserted above)
            let (k, (d, _, n)) = unsafe {
                let k = self.p.curve.at_unchecked(at, s, c);
                (k, self.parts(at, c, k.a))
            };
            (o[0], o[1]) = (dot(k.g, n), dot(d, n));
        }
    }

    /// Row 1 in [phi_i, theta, phi_j], row 2 in [r_i, phi_i, theta, r_j, phi_j].
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.p.n) && out.len() >= 10 * self.n.len());
        let i = i::<S>();
        for (c, o) in out.chunks_exact_mut(10).take(self.n.len()).enumerate() {
            // SAFETY: c < n.len(), q and e hold n (asserted above)
            let (k, (d, b, n)) = unsafe {
                let k = self.p.curve.at_unchecked(at, s, c);
                (k, self.parts(at, c, k.a))
            };
            let (a, g) = (k.a, k.g);
            o.copy_from_slice(&[
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
        assert!(at.holds(self.p.n) && qd.len() >= self.p.n && out.len() >= 2 * self.n.len());
        let i = i::<S>();
        for (c, o) in out.chunks_exact_mut(2).take(self.n.len()).enumerate() {
            // SAFETY: c < n.len(), q, e and qd hold n (asserted above), cc, cj < n - 2, ct < n (new)
            let (k, r, (d, b, n), wj, rx, ry) = unsafe {
                let (x, y, _) = self.p.cols(c);
                let (k, r) = self.p.curve.moving_unchecked(at, qd, s, c);
                let v = |j: usize| Complex::new(*qd.get_unchecked(j), *qd.get_unchecked(j + 1));
                (k, r, self.parts(at, c, k.a), *qd.get_unchecked(y + 2), v(x), v(y))
            };
            let (n1, n2) = (i * n * wj, -n * (wj * wj));
            let d1 = rx + r.a1 - ry - i * b * wj;
            let d2 = r.a2 + b * (wj * wj);
            o[0] = -(dot(r.g2, n) + dot(r.g1, n1) * 2.0 + dot(k.g, n2));
            o[1] = -(dot(d2, n) + dot(d1, n1) * 2.0 + dot(d, n2));
        }
    }
}
