//! Point on a line fixed in a body: the translational joint (Eqs.
//! 4.10-4.12, Table 4.2) and the revolute-translational joint (Eq. 4.16);
//! gamma from Table 4.3.
//!
//! Both are the scalar cross product u x d = 0 of the line direction u (two
//! points of the line body a) and the vector d from the line's base point
//! to a point of the other body b: Eq. 4.12's first row with a = i,
//! u = P_i - Q_i, d = P_j - P_i, and Eq. 4.16 with a = j, u = Q_j - P_j,
//! d = P_i - P_j. A translational joint adds the row
//! phi_i - phi_j - (phi_i^0 - phi_j^0) = 0 (Eq. 4.10 as corrected).
use super::{cross, dot, rd, At, Shared, I};
use crate::table::Table;
use num_complex::Complex64 as C64;

/// Columns: ca, cb the x columns of the line body a and the other body b;
/// pa (the line's base point on a), ua (its direction, local to a), ob
/// (the point on b); ai, aj, phi0 the angle row's columns and constant,
/// either all empty (revolute-translational: one row per constraint) or
/// one per constraint (translational: two rows).
pub struct Line {
    ca: Vec<usize>,
    pa: Vec<C64>,
    ua: Vec<C64>,
    cb: Vec<usize>,
    ob: Vec<C64>,
    ai: Vec<usize>,
    aj: Vec<usize>,
    phi0: Vec<f64>,
    angle: bool,
}

/// u = A_a u'_a, d = r_b + A_b s'_b - r_a - A_a s'_a, A_a s'_a, A_b s'_b.
struct Parts {
    u: C64,
    d: C64,
    sa: C64,
    sb: C64,
}

impl Line {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ca = t.index("ca", n.saturating_sub(2))?;
        let c = ca.len();
        t.same_length(c, &["pa", "ua", "cb", "ob"])?;
        let ai = t.index("ai", n)?;
        let angle = !ai.is_empty();
        t.same_length(if angle { c } else { 0 }, &["ai", "aj", "phi0"])?;
        Ok(Line {
            pa: t.cplx("pa")?,
            ua: t.cplx("ua")?,
            cb: t.index("cb", n.saturating_sub(2))?,
            ob: t.cplx("ob")?,
            aj: t.index("aj", n)?,
            phi0: t.real("phi0")?,
            ca,
            ai,
            angle,
        })
    }

    fn per(&self) -> usize {
        if self.angle {
            2
        } else {
            1
        }
    }

    pub fn rows(&self) -> usize {
        self.per() * self.ca.len()
    }

    pub fn entries(&self) -> usize {
        (if self.angle { 8 } else { 6 }) * self.ca.len()
    }

    #[inline(always)]
    fn parts(&self, at: &At, c: usize) -> Parts {
        let (a, b) = (self.ca[c], self.cb[c]);
        let (ea, eb) = (at.rot(a), at.rot(b));
        let (sa, sb) = (self.pa[c] * ea, self.ob[c] * eb);
        Parts { u: self.ua[c] * ea, d: at.r(b) + sb - at.r(a) - sa, sa, sb }
    }

    /// u x d (Eqs. 4.12, 4.16), then phi_i - phi_j - phi0 for translational joints.
    pub fn phi(&self, at: &At, _: &Shared, out: &mut [f64]) {
        let per = self.per();
        for c in 0..self.ca.len() {
            let p = self.parts(at, c);
            out[per * c] = cross(p.u, p.d);
            if self.angle {
                out[2 * c + 1] = at.q[self.ai[c]] - at.q[self.aj[c]] - self.phi0[c];
            }
        }
    }

    /// Columns [x_a, y_a, phi_a, x_b, y_b, phi_b] of u x d (Table 4.2), then
    /// [phi_i, phi_j] = [1, -1] for translational joints.
    pub fn jac(&self, at: &At, _: &Shared, out: &mut [f64]) {
        let width = if self.angle { 8 } else { 6 };
        for c in 0..self.ca.len() {
            let p = self.parts(at, c);
            let o = &mut out[width * c..width * c + width];
            o[..6].copy_from_slice(&[p.u.im, -p.u.re, -dot(p.u, p.d + p.sa), -p.u.im, p.u.re, dot(p.u, p.sb)]);
            if self.angle {
                o[6] = 1.0;
                o[7] = -1.0;
            }
        }
    }

    /// -(u x d)'' without the acceleration terms (Table 4.3), then 0.
    pub fn gamma(&self, at: &At, qd: &[f64], _: &Shared, out: &mut [f64]) {
        let per = self.per();
        for c in 0..self.ca.len() {
            let p = self.parts(at, c);
            let (a, b) = (self.ca[c], self.cb[c]);
            let (wa, wb) = (qd[a + 2], qd[b + 2]);
            let dd = rd(qd, b) + I * p.sb * wb - rd(qd, a) - I * p.sa * wa;
            out[per * c] =
                wa * wa * cross(p.u, p.d) + 2.0 * wa * dot(p.u, dd) + cross(p.u, p.sb * (wb * wb) - p.sa * (wa * wa));
            if self.angle {
                out[2 * c + 1] = 0.0;
            }
        }
    }
}
