//! Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47.
use super::{At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y.
/// Columns: ci, cj the bodies' x columns; si, sj the joint centre on each.
pub struct Revolute<S = f64> {
    ci: Vec<usize>,
    cj: Vec<usize>,
    si: Vec<Complex<S>>,
    sj: Vec<Complex<S>>,
}

impl<S: Real> Revolute<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ci = t.index("ci", n.saturating_sub(2))?;
        t.same_length(ci.len(), &["cj", "si", "sj"])?;
        Ok(Revolute { cj: t.index("cj", n.saturating_sub(2))?, ci, si: t.cplx_s("si")?, sj: t.cplx_s("sj")? })
    }

    pub fn rows(&self) -> usize {
        2 * self.ci.len()
    }

    pub fn entries(&self) -> usize {
        8 * self.ci.len()
    }

    /// Eq. 4.7.
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        for c in 0..self.ci.len() {
            let (a, b) = (self.ci[c], self.cj[c]);
            let d = at.r(a) + self.si[c] * at.rot(a) - at.r(b) - self.sj[c] * at.rot(b);
            out[2 * c] = d.re;
            out[2 * c + 1] = d.im;
        }
    }

    /// Eq. 4.46: [I, B_i s'_i, -I, -B_j s'_j]; B s' = i A s'. Pattern per
    /// constraint: row x: x_i, phi_i, x_j, phi_j; row y: y_i, phi_i, y_j, phi_j.
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        let (one, minus) = (S::one(), -S::one());
        for c in 0..self.ci.len() {
            let a = self.si[c] * at.rot(self.ci[c]);
            let b = self.sj[c] * at.rot(self.cj[c]);
            let o = &mut out[8 * c..8 * c + 8];
            o.copy_from_slice(&[one, -a.im, minus, b.im, one, a.re, minus, -b.re]);
        }
    }

    /// Eq. 4.47: A_i s'_i w_i^2 - A_j s'_j w_j^2.
    pub fn gamma(&self, at: &At<S>, qd: &[S], _: &Shared<S>, out: &mut [S]) {
        for c in 0..self.ci.len() {
            let (a, b) = (self.ci[c], self.cj[c]);
            let (wi, wj) = (qd[a + 2], qd[b + 2]);
            let g = self.si[c] * at.rot(a) * (wi * wi) - self.sj[c] * at.rot(b) * (wj * wj);
            out[2 * c] = g.re;
            out[2 * c + 1] = g.im;
        }
    }
}
