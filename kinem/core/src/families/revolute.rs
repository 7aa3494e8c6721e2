//! Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47.
use super::{At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y.
/// Columns: ci, cj the bodies' x columns; si, sj the joint centre on each.
/// Invariant (checked in `new`): every ci, cj below n - 2, so a kernel
/// that checked `At::holds(n)` reads their columns unchecked.
pub struct Revolute<S = f64> {
    n: usize,
    ci: Vec<usize>,
    cj: Vec<usize>,
    si: Vec<Complex<S>>,
    sj: Vec<Complex<S>>,
}

impl<S: Real> Revolute<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ci = t.index("ci", n.saturating_sub(2))?;
        t.same_length(ci.len(), &["cj", "si", "sj"])?;
        Ok(Revolute { n, cj: t.index("cj", n.saturating_sub(2))?, ci, si: t.cplx_s("si")?, sj: t.cplx_s("sj")? })
    }

    pub fn rows(&self) -> usize {
        2 * self.ci.len()
    }

    pub fn entries(&self) -> usize {
        8 * self.ci.len()
    }

    /// Eq. 4.7.
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n));
        let joints = self.ci.iter().zip(&self.cj).zip(self.si.iter().zip(&self.sj));
        for (o, ((&a, &b), (&si, &sj))) in out.chunks_exact_mut(2).zip(joints) {
            // SAFETY: a, b < n - 2 (new), q and e hold n (asserted above)
            let d = unsafe { at.r_at(a) + si * at.rot_at(a) - at.r_at(b) - sj * at.rot_at(b) };
            o[0] = d.re;
            o[1] = d.im;
        }
    }

    /// Eq. 4.46: [I, B_i s'_i, -I, -B_j s'_j]; B s' = i A s'. Pattern per
    /// constraint: row x: x_i, phi_i, x_j, phi_j; row y: y_i, phi_i, y_j, phi_j.
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n));
        let (one, minus) = (S::one(), -S::one());
        let joints = self.ci.iter().zip(&self.cj).zip(self.si.iter().zip(&self.sj));
        for (o, ((&ci, &cj), (&si, &sj))) in out.chunks_exact_mut(8).zip(joints) {
            // SAFETY: ci, cj < n - 2 (new), e holds n (asserted above)
            let (a, b) = unsafe { (si * at.rot_at(ci), sj * at.rot_at(cj)) };
            o.copy_from_slice(&[one, -a.im, minus, b.im, one, a.re, minus, -b.re]);
        }
    }

    /// Eq. 4.47: A_i s'_i w_i^2 - A_j s'_j w_j^2.
    pub fn gamma(&self, at: &At<S>, qd: &[S], _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n);
        let joints = self.ci.iter().zip(&self.cj).zip(self.si.iter().zip(&self.sj));
        for (o, ((&a, &b), (&si, &sj))) in out.chunks_exact_mut(2).zip(joints) {
            // SAFETY: a, b < n - 2 (new), e and qd hold n (asserted above)
            let g = unsafe {
                let (wi, wj) = (*qd.get_unchecked(a + 2), *qd.get_unchecked(b + 2));
                si * at.rot_at(a) * (wi * wi) - sj * at.rot_at(b) * (wj * wj)
            };
            o[0] = g.re;
            o[1] = g.im;
        }
    }
}
