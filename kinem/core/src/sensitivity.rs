//! Design sensitivities of a trajectory by direct differentiation of the
//! kinematic equations (docs/design.md, Eqs. S1-S3): at each solved instant
//! (q, qd, qdd at t), for a design parameter p,
//!
//! ```text
//! Phi_q dq/dp   = -Phi_p                                   (S1)
//! Phi_q dqd/dp  = D(nu) - D(Phi_q) qd                      (S2)
//! Phi_q dqdd/dp = D(gamma) - D(Phi_q) qdd                  (S3)
//! ```
//!
//! where D(.) is the total derivative along p: the families' own kernels
//! evaluated over dual numbers (crate::real::Dual) with the tables' tangent
//! along p (Kin<Dual>, built from the tables and their tangents) and the
//! coordinates' tangents: q' = 0 for Phi_p (S1), q' = dq/dp in S2 and S3,
//! qd' = dqd/dp in gamma (S3). All three share one factorisation of Phi_q
//! at the instant (the march's layout, crate::lu), so the cost per
//! parameter is one evaluation of Phi, the Jacobian, nu and gamma in dual
//! numbers and three solves: no finite differences anywhere.
use crate::families::At;
use crate::lu::Layout;
use crate::model::Kin;
use crate::real::{Dual, Real};
use num_complex::{Complex, Complex64 as C64};

/// The model's tangent along one parameter: Kin<Dual> with the same rows
/// and Jacobian entries as the model's Kin.
pub fn check(kin: &Kin, tangent: &Kin<Dual>) -> Result<(), String> {
    if tangent.n != kin.n || tangent.m != kin.m || tangent.nnz != kin.nnz {
        return Err(format!(
            "sensitivity: a parameter's tangent model has {} coordinates, {} rows, {} entries; the model {}, {}, {}",
            tangent.n, tangent.m, tangent.nnz, kin.n, kin.m, kin.nnz
        ));
    }
    Ok(())
}

/// x[0] (K, n): q at `times`; x[1], x[2]: qd, qdd (as many levels as
/// given); rows, cols: the Jacobian's pattern. Fills out (levels, P, K, n)
/// with dq/dp, dqd/dp, dqdd/dp for every tangent p, and ratio (K) with the
/// pivot ratio of Phi_q (the caller flags singular instants).
#[allow(clippy::too_many_arguments)]
pub fn sensitivities(
    kin: &Kin,
    layout: &Layout,
    tangents: &[Kin<Dual>],
    rows: &[usize],
    cols: &[usize],
    times: &[f64],
    x: &[&[f64]],
    out: &mut [f64],
    ratio: &mut [f64],
) -> Result<(), String> {
    let (n, m, nnz, kk, levels, np) = (kin.n, kin.m, kin.nnz, times.len(), x.len(), tangents.len());
    if levels == 0 || levels > 3 || x.iter().any(|a| a.len() != kk * n) {
        return Err("sensitivity: 1 to 3 arrays of K x n coordinates expected".into());
    }
    if rows.len() != nnz || cols.len() != nnz || rows.iter().any(|&r| r >= m) || cols.iter().any(|&c| c >= n) {
        return Err("sensitivity: the Jacobian's pattern does not fit the model".into());
    }
    if out.len() != levels * np * kk * n || ratio.len() != kk {
        return Err("sensitivity: output arrays of the wrong size".into());
    }
    for t in tangents {
        check(kin, t)?;
    }
    let mut f = layout.factors();
    let mut e = vec![C64::new(1.0, 0.0); n];
    let mut values = vec![0.0; nnz];
    let zero = Complex::new(Dual::c(1.0), Dual::c(0.0));
    let (mut ed, mut qdual, mut qddual) = (vec![zero; n], vec![Dual::c(0.0); n], vec![Dual::c(0.0); n]);
    let (mut rd, mut jd) = (vec![Dual::c(0.0); m], vec![Dual::c(0.0); nnz]);
    let (mut rhs, mut sol) = (vec![0.0; m], vec![0.0; n]);
    for k in 0..kk {
        let (t, q) = (times[k], &x[0][k * n..(k + 1) * n]);
        kin.rotate(q, &mut e);
        kin.jac(&At { q, e: &e, t }, &mut values);
        layout.factor(&values, &mut f);
        ratio[k] = layout.pivots(&f).0;
        for (p, tan) in tangents.iter().enumerate() {
            let at = |level: usize| (level * np + p) * kk * n + k * n;
            // S1: Phi_p, the tangent of Phi with q' = 0
            lift(q, None, &mut qdual);
            tan.rotate(&qdual, &mut ed);
            tan.phi(&At { q: &qdual, e: &ed, t }, &mut rd);
            for r in 0..m {
                rhs[r] = -rd[r].d;
            }
            layout.solve(&mut f, &rhs, &mut sol);
            out[at(0)..at(0) + n].copy_from_slice(&sol);
            if levels == 1 {
                continue;
            }
            // S2: q' = dq/dp
            lift(q, Some(&sol), &mut qdual);
            tan.rotate(&qdual, &mut ed);
            let atd = At { q: &qdual, e: &ed, t };
            tan.jac(&atd, &mut jd);
            tan.nu(t, &mut rd);
            let qd = &x[1][k * n..(k + 1) * n];
            difference(&rd, &jd, qd, rows, cols, &mut rhs);
            layout.solve(&mut f, &rhs, &mut sol);
            out[at(1)..at(1) + n].copy_from_slice(&sol);
            if levels == 2 {
                continue;
            }
            // S3: q' = dq/dp (as in S2), qd' = dqd/dp
            lift(qd, Some(&sol), &mut qddual);
            tan.gamma(&atd, &qddual, &mut rd);
            difference(&rd, &jd, &x[2][k * n..(k + 1) * n], rows, cols, &mut rhs);
            layout.solve(&mut f, &rhs, &mut sol);
            out[at(2)..at(2) + n].copy_from_slice(&sol);
        }
    }
    Ok(())
}

/// rhs = D(b) - D(Phi_q) v: the right-hand side of S2 (b = nu, v = qd) and
/// S3 (b = gamma, v = qdd), from the tangents of b and of the Jacobian's
/// values (pattern rows, cols).
fn difference(b: &[Dual], jac: &[Dual], v: &[f64], rows: &[usize], cols: &[usize], rhs: &mut [f64]) {
    for (r, x) in rhs.iter_mut().zip(b) {
        *r = x.d;
    }
    for e in 0..jac.len() {
        rhs[rows[e]] -= jac[e].d * v[cols[e]];
    }
}

/// out = v + d eps (d = 0 when None).
fn lift(v: &[f64], d: Option<&[f64]>, out: &mut [Dual]) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = Dual::lift(v[j], d.map_or(0.0, |d| d[j]));
    }
}
