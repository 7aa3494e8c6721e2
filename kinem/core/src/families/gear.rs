//! Spur gears (Eqs. 4.17, 4.18), Sec. 4.2.3: the integrated no-slip
//! condition of the pitch circles, with angles accumulated.
use super::{At, Shared};
use crate::real::Real;
use crate::table::Table;

/// Phi = rho_i (phi_i - phi_k) + rho_j (phi_j - phi_k - phi0) (Eq. 4.18;
/// Eq. 4.17 without a carrier k, phi_k = 0). rho_j carries the sign sigma
/// (negative when one gear is internal). Columns: ai, aj, ak the angle
/// columns of gears i, j and carrier k (any valid column without one),
/// carrier (flag), ri, rj (signed), phi0.
///
/// Invariants (checked in `new`): aj, ak, w, ri, rj, phi0 as long as ai;
/// every ai, aj, ak below n; so Phi, having checked that q holds n, reads
/// them unchecked.
pub struct Gear<S = f64> {
    n: usize,
    ai: Vec<usize>,
    aj: Vec<usize>,
    ak: Vec<usize>,
    w: Vec<f64>, // 1.0 with a carrier, 0.0 without
    ri: Vec<S>,
    rj: Vec<S>,
    phi0: Vec<S>,
    values: Vec<S>, // the constant Jacobian values
}

impl<S: Real> Gear<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ai = t.index("ai", n)?;
        t.same_length(ai.len(), &["aj", "ak", "carrier", "ri", "rj", "phi0"])?;
        let carrier = t.flags("carrier")?;
        let (ri, rj): (Vec<S>, Vec<S>) = (t.real_s("ri")?, t.real_s("rj")?);
        let mut values = Vec::new();
        for c in 0..ai.len() {
            values.push(ri[c]);
            values.push(rj[c]);
            if carrier[c] {
                values.push(-(ri[c] + rj[c]));
            }
        }
        Ok(Gear {
            aj: t.index("aj", n)?,
            ak: t.index("ak", n)?,
            w: carrier.iter().map(|&k| if k { 1.0 } else { 0.0 }).collect(),
            phi0: t.real_s("phi0")?,
            n,
            ai,
            ri,
            rj,
            values,
        })
    }

    pub fn rows(&self) -> usize {
        self.ai.len()
    }

    pub fn entries(&self) -> usize {
        self.values.len()
    }

    /// Eq. 4.18 (Eq. 4.17 with w = 0).
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.q.len() >= self.n && out.len() <= self.ai.len());
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: c < out.len() <= ai.len() (the other columns as long), every index below n <= q.len()
            *o = unsafe {
                let q = |k: &Vec<usize>| *at.q.get_unchecked(*k.get_unchecked(c));
                let pk = q(&self.ak) * *self.w.get_unchecked(c);
                *self.ri.get_unchecked(c) * (q(&self.ai) - pk)
                    + *self.rj.get_unchecked(c) * (q(&self.aj) - pk - *self.phi0.get_unchecked(c))
            };
        }
    }

    /// Constant: [rho_i, rho_j, -(rho_i + rho_j)] in [phi_i, phi_j, phi_k]
    /// (the last only with a carrier).
    pub fn jac(&self, _: &At<S>, _: &Shared<S>, out: &mut [S]) {
        out.copy_from_slice(&self.values);
    }

    /// gamma = 0: the rows are linear in q.
    pub fn gamma(&self, _: &At<S>, _: &[S], _: &Shared<S>, out: &mut [S]) {
        out.fill(S::zero());
    }
}
