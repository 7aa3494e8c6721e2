//! Design sensitivities of a trajectory by direct differentiation of the
//! kinematic equations (docs/design.md, Eqs. S1-S3): at each solved instant
//! (q, qd, qdd at t), for a design parameter p, with J = Phi_q,
//! s = dq/dp, sd = dqd/dp,
//!
//! ```text
//! J s   = -Phi_p                                   (S1)
//! J sd  = nu_p - A s - J_p qd                      (S2)
//! J sdd = D(gamma) - B s - J_p qdd                 (S3)
//! ```
//!
//! D(Phi_q) v = Phi_qq[s, v] + J_p v, and Phi_qq is symmetric in its two q
//! slots, so Phi_qq[s, v] = (D_v J) s: A = D_qd(J) and B = D_qdd(J), the
//! Jacobian's tangents along q' = qd and q' = qdd, are the same for every
//! parameter and taken once per instant (S6). Phi_p, J_p and nu_p are
//! nonzero only on the rows and entries of the families whose tables (or
//! functions, outlines) p moves: each parameter's `Tangent` holds only those
//! families, evaluated over dual numbers (crate::real::Dual) with their
//! tables' tangents. D(gamma), gamma's tangent along q' = s, qd' = sd and
//! the tables', is one dual evaluation per parameter: the model's gamma for
//! the families p does not move, the tangent's for those it does. All three
//! share one factorisation of J at the instant (the march's layout,
//! crate::lu): no finite differences anywhere.
use crate::families::At;
use crate::lu::Layout;
use crate::model::Kin;
use crate::real::{lift_c, Dual, Lanes, Real};
use num_complex::{Complex, Complex64 as C64};

/// A design parameter's tangent of the model: the families it moves
/// (`kin`: over dual numbers, their tables' tangents seeded, with the
/// model's functions and outlines and their tangents) and their places
/// among the model's families (`families`, ascending).
pub struct Tangent {
    pub kin: Kin<Dual>,
    pub families: Vec<usize>,
}

impl Tangent {
    /// Checks that every family has the rows and Jacobian entries of the
    /// model's family in its place; returns its (rows, entries) spans there:
    /// (first row in kin, first row in the model, count) and the same for
    /// entries.
    fn spans(&self, model: &Kin) -> Result<Spans, String> {
        let k = &self.kin;
        if k.n != model.n || self.families.len() != k.families.len() {
            return Err("sensitivity: a parameter's tangent does not fit the model".into());
        }
        let (mut rows, mut entries) = (Vec::new(), Vec::new());
        for (j, &g) in self.families.iter().enumerate() {
            let ok = g < model.families.len()
                && k.families[j].rows() == model.families[g].rows()
                && k.families[j].entries() == model.families[g].entries();
            if !ok {
                return Err(format!(
                    "sensitivity: a parameter's tangent family {j} does not fit the model's family {g}"
                ));
            }
            rows.push((k.row_off[j], model.row_off[g], k.families[j].rows()));
            entries.push((k.entry_off[j], model.entry_off[g], k.families[j].entries()));
        }
        Ok(Spans { rows, entries })
    }
}

/// Where a tangent's rows and entries sit in the model's.
struct Spans {
    rows: Vec<(usize, usize, usize)>,
    entries: Vec<(usize, usize, usize)>,
}

/// How many parameters share one evaluation of gamma and of the named
/// points' columns (crate::real::Lanes).
pub const LANES: usize = 4;
type L = Lanes<LANES>;

/// x[0] (K, n): q at `times`; x[1], x[2]: qd, qdd (as many levels as
/// given); rows, cols: the Jacobian's pattern. Fills out (levels, P, K, n)
/// with dq/dp, dqd/dp, dqdd/dp for every tangent p, and ratio (K) with the
/// pivot ratio of Phi_q (the caller flags singular instants).
#[allow(clippy::too_many_arguments)]
pub fn sensitivities(
    kin: &Kin,
    layout: &Layout,
    tangents: &[Tangent],
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
    let spans = tangents.iter().map(|t| t.spans(kin)).collect::<Result<Vec<_>, _>>()?;
    // the model over two directions (A and B, S6) and over LANES (D(gamma)), its tables' tangents zero
    let (two, lanes): (Kin<Lanes<2>>, Kin<L>) = (kin.over()?, kin.over()?);
    let mut f = layout.factors();
    let mut e = vec![C64::new(1.0, 0.0); n];
    let mut values = vec![0.0; nnz];
    let mut e0 = vec![Complex::new(Dual::c(0.0), Dual::c(0.0)); n];
    let (mut q0, mut qd0) = (vec![Dual::c(0.0); n], vec![Dual::c(0.0); n]);
    let mut q2 = vec![Lanes::<2>::c(0.0); n];
    let (mut e2, mut j2) = (vec![Complex::new(Lanes::c(0.0), Lanes::c(0.0)); n], vec![Lanes::<2>::c(0.0); nnz]);
    let (mut ql, mut qdl, mut gl) = (vec![L::c(0.0); n], vec![L::c(0.0); n], vec![L::c(0.0); m]);
    let mut el = vec![Complex::new(L::c(0.0), L::c(0.0)); n];
    let (mut rd, mut jd) = (vec![Dual::c(0.0); m], vec![vec![Dual::c(0.0); nnz]; LANES]);
    let (mut a, mut b) = (vec![0.0; nnz], vec![0.0; nnz]);
    let (mut rhs, mut sol) = (vec![0.0; m], vec![0.0; n]);
    let (mut s, mut by) = (vec![[0.0; LANES]; n], vec![[0.0; LANES]; m]); // s (lanes), A s or B s
    let csr = Csr::of(rows, cols, m);
    for k in 0..kk {
        let (t, q) = (times[k], &x[0][k * n..(k + 1) * n]);
        let row = |level: usize| &x[level][k * n..(k + 1) * n];
        kin.rotate(q, &mut e);
        kin.jac(&At { q, e: &e, t }, &mut values);
        layout.factor(&values, &mut f);
        ratio[k] = layout.pivots(&f).0;
        lift(q, None, &mut q0);
        for &j in &kin.angles {
            e0[j] = lift_c(e[j], C64::new(0.0, 0.0));
        }
        let at0 = At { q: &q0, e: &e0, t };
        // A = D_qd(J), B = D_qdd(J) (S6): once per instant, one evaluation
        if levels > 1 {
            let (qd, qdd) = (row(1), if levels > 2 { row(2) } else { row(1) });
            for j in 0..n {
                q2[j] = Lanes::of(q[j], [qd[j], qdd[j]]);
            }
            two.rotate(&q2, &mut e2);
            two.jac(&At { q: &q2, e: &e2, t }, &mut j2);
            for ((x, y), v) in a.iter_mut().zip(b.iter_mut()).zip(&j2) {
                (*x, *y) = (v.d[0], v.d[1]);
            }
            lift(qd, None, &mut qd0);
        }
        for first in (0..np).step_by(LANES) {
            let group = first..(first + LANES).min(np);
            for p in group.clone() {
                let (tk, sp, lane) = (&tangents[p].kin, &spans[p], p - first);
                let at = |level: usize| (level * np + p) * kk * n + k * n;
                // S1: Phi_p, the tangent of the moved families' Phi at q' = 0
                tk.phi(&at0, &mut rd);
                rhs.fill(0.0);
                place(&rd, &sp.rows, -1.0, &mut rhs);
                layout.solve(&mut f, &rhs, &mut sol);
                out[at(0)..at(0) + n].copy_from_slice(&sol);
                if levels == 1 {
                    continue;
                }
                for (x, &v) in s.iter_mut().zip(&sol) {
                    x[lane] = v;
                }
            }
            if levels == 1 {
                continue;
            }
            csr.product(&a, &s, &mut by);
            for p in group.clone() {
                let (tk, sp, lane) = (&tangents[p].kin, &spans[p], p - first);
                let at = (np + p) * kk * n + k * n;
                // S2: nu_p - A s - J_p qd
                tk.jac(&at0, &mut jd[lane]);
                tk.nu(t, &mut rd);
                for (r, x) in rhs.iter_mut().zip(&by) {
                    *r = -x[lane];
                }
                add(&rd, &sp.rows, &mut rhs);
                moved_product(&jd[lane], row(1), &sp.entries, rows, cols, &mut rhs);
                layout.solve(&mut f, &rhs, &mut sol);
                out[at..at + n].copy_from_slice(&sol);
            }
            if levels < 3 {
                continue;
            }
            // S3: D(gamma) = gamma's tangent along q' = s, qd' = sd (the
            // group's lanes, one evaluation) + gamma_p (the moved families at
            // q' = 0, qd' = 0); minus B s and J_p qdd
            let (q, qd) = (row(0), row(1));
            for j in 0..n {
                let (mut dq, mut dqd) = ([0.0; LANES], [0.0; LANES]);
                for p in group.clone() {
                    dq[p - first] = s[j][p - first];
                    dqd[p - first] = out[(np + p) * kk * n + k * n + j];
                }
                ql[j] = Lanes::of(q[j], dq);
                qdl[j] = Lanes::of(qd[j], dqd);
            }
            lanes.rotate(&ql, &mut el);
            lanes.gamma(&At { q: &ql, e: &el, t }, &qdl, &mut gl);
            csr.product(&b, &s, &mut by);
            for p in group.clone() {
                let (tk, sp, lane) = (&tangents[p].kin, &spans[p], p - first);
                let at = (2 * np + p) * kk * n + k * n;
                for ((r, g), x) in rhs.iter_mut().zip(&gl).zip(&by) {
                    *r = g.d[lane] - x[lane];
                }
                tk.gamma(&at0, &qd0, &mut rd);
                add(&rd, &sp.rows, &mut rhs);
                moved_product(&jd[lane], row(2), &sp.entries, rows, cols, &mut rhs);
                layout.solve(&mut f, &rhs, &mut sol);
                out[at..at + n].copy_from_slice(&sol);
            }
        }
    }
    Ok(())
}

/// rhs = sign x the tangents of a tangent model's rows, in their places
/// (spans: first row in rd, first in the model, count).
fn place(rd: &[Dual], spans: &[(usize, usize, usize)], sign: f64, rhs: &mut [f64]) {
    for &(from, to, len) in spans {
        for r in 0..len {
            rhs[to + r] = sign * rd[from + r].d;
        }
    }
}

/// rhs += the tangents of a tangent model's rows, in their places.
fn add(rd: &[Dual], spans: &[(usize, usize, usize)], rhs: &mut [f64]) {
    for &(from, to, len) in spans {
        for r in 0..len {
            rhs[to + r] += rd[from + r].d;
        }
    }
}

/// The Jacobian's pattern by rows: entry order[i] of row r for i in
/// start[r]..start[r + 1].
struct Csr {
    order: Vec<usize>,
    start: Vec<usize>,
    cols: Vec<usize>,
}

impl Csr {
    fn of(rows: &[usize], cols: &[usize], m: usize) -> Csr {
        let mut order: Vec<usize> = (0..rows.len()).collect();
        order.sort_by_key(|&e| rows[e]);
        let mut start = vec![0; m + 1];
        for &r in rows {
            start[r + 1] += 1;
        }
        for r in 0..m {
            start[r + 1] += start[r];
        }
        Csr { cols: order.iter().map(|&e| cols[e]).collect(), order, start }
    }

    /// out = M v for LANES vectors v at once, M's values on the pattern.
    fn product(&self, mat: &[f64], v: &[[f64; LANES]], out: &mut [[f64; LANES]]) {
        for (r, o) in out.iter_mut().enumerate() {
            let mut acc = [0.0; LANES];
            for i in self.start[r]..self.start[r + 1] {
                let (a, x) = (mat[self.order[i]], &v[self.cols[i]]);
                for l in 0..LANES {
                    acc[l] += a * x[l];
                }
            }
            *o = acc;
        }
    }
}

/// rhs -= J_p v, J_p's values the tangents `jd` of the moved families'
/// entries (spans: first entry in jd, first in the model's pattern, count).
fn moved_product(
    jd: &[Dual],
    v: &[f64],
    spans: &[(usize, usize, usize)],
    rows: &[usize],
    cols: &[usize],
    rhs: &mut [f64],
) {
    for &(from, to, len) in spans {
        for e in 0..len {
            rhs[rows[to + e]] -= jd[from + e].d * v[cols[to + e]];
        }
    }
}

/// out = v + d eps (d = 0 when None).
fn lift(v: &[f64], d: Option<&[f64]>, out: &mut [Dual]) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = Dual::lift(v[j], d.map_or(0.0, |d| d[j]));
    }
}

/// The trajectory's columns' tangents (crate::columns over LANES
/// parameters' tangents at once) for every parameter from the coordinates'
/// (`out` of `sensitivities`, (levels, P, K, n)) and the named points'
/// local tangents (dlocal: P rows of as many as `local`): data (K, P W),
/// row k the W columns' tangents along the first parameter, then the
/// second, ... (`cols`: src, pc, local as crate::columns::columns, checked
/// by crate::columns::check).
pub fn tangent_columns(x: &[&[f64]], n: usize, out: &[f64], cols: Cols, data: &mut [f64]) {
    let (src, pc, local, dlocal) = cols;
    let (levels, w, points) = (x.len(), src.len(), local.len());
    let kk = x[0].len().checked_div(n).unwrap_or(0);
    let np = out.len().checked_div(levels * kk * n).unwrap_or(0);
    let mut xs = vec![vec![L::default(); kk * n]; levels];
    let mut buf = vec![L::default(); kk * w];
    let mut loc = vec![Complex::new(L::default(), L::default()); points];
    for first in (0..np).step_by(LANES) {
        let group = first..(first + LANES).min(np);
        for (l, xl) in xs.iter_mut().enumerate() {
            for (j, o) in xl.iter_mut().enumerate() {
                o.v = x[l][j];
                for p in group.clone() {
                    o.d[p - first] = out[(l * np + p) * kk * n + j];
                }
            }
        }
        for (j, o) in loc.iter_mut().enumerate() {
            let (mut re, mut im) = ([0.0; LANES], [0.0; LANES]);
            for p in group.clone() {
                (re[p - first], im[p - first]) = (dlocal[p * points + j].re, dlocal[p * points + j].im);
            }
            *o = Complex::new(Lanes::of(local[j].re, re), Lanes::of(local[j].im, im));
        }
        let stages: Vec<&[L]> = xs.iter().map(|v| v.as_slice()).collect();
        crate::columns::columns(&stages, n, src, pc, &loc, &mut buf);
        for k in 0..kk {
            for p in group.clone() {
                let row = &mut data[(k * np + p) * w..(k * np + p + 1) * w];
                for (o, b) in row.iter_mut().zip(&buf[k * w..(k + 1) * w]) {
                    *o = b.d[p - first];
                }
            }
        }
    }
}

/// The trajectory's column sources, points' body columns, their local
/// coordinates and (P rows of) tangents: see `tangent_columns`.
pub type Cols<'a> = (&'a [usize], &'a [usize], &'a [C64], &'a [C64]);
