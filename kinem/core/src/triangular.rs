//! J_s in its block-triangular order (crate::decompose, issue 31): one
//! block of up to MASK coordinates whose pattern decomposes, its diagonal
//! blocks factorised one after the other, a 1x1 block as its entry and a
//! larger one in its own fixed pivot order (crate::order), each block's
//! positions in that order. A solve is block forward substitution: block
//! k's right side less the off-diagonal entries of its rows times the
//! coordinates already solved (a sparse product), then its diagonal
//! block's elimination, in place.
//!
//! When a block's order does not suit the values (a zero pivot, a
//! multiplier above crate::order::MULTIPLIER) or the pivots of all the
//! blocks span more than crate::lu::FALLBACK, the whole J_s is factorised
//! with partial pivoting in the model's own order instead (`whole`: LAPACK
//! getf2's pivots, as before the decomposition; on its nonzeros up to
//! MASK coordinates, dense above), so that every figure near the
//! acceptance test's floor is partial pivoting's.
use crate::lu::{dense_factor, dense_solve, masked_factor, masked_solve, Factors, FALLBACK, MASK};
use crate::order::{Order, Pivots};

/// The program's mark of a larger block's elimination.
pub const BLOCK: u32 = u32::MAX;

/// One diagonal block: its first position, size, where its s x s factors
/// start in Factors::j, and its fixed order (None for a 1x1 block).
#[derive(Clone, Debug)]
pub struct Diagonal {
    pub at: usize,
    pub s: usize,
    pub store: usize,
    pub order: Option<Order>,
    /// a 1x1 block's entries (Jacobian entry, scale): the last one sets it
    pub entries: Vec<(u32, f64)>,
}

/// The blocks in solve order, the entries below them, and the whole
/// matrix's partial-pivoting fallback.
#[derive(Clone, Debug)]
pub struct Triangular {
    pub blocks: Vec<Diagonal>,
    /// the off-diagonal entries (Jacobian entry, scale): Factors::off's values
    pub off_entries: Vec<(u32, f64)>,
    /// the forward substitution as one program over the positions: (r, c,
    /// v) is w[r] -= off[v] w[c] (an off-diagonal entry), w[r] /= j[v] when
    /// r == c (a 1x1 block), and block c's elimination when r is BLOCK;
    /// block k's entries come right before it
    pub program: Vec<(u32, u32, u32)>,
    /// per position p: the model row b[gather[p]] / its scale (gscale) goes
    /// there, and x[scatter[p]] = w[p] times the column's scale (sscale)
    pub gather: Vec<usize>,
    pub gscale: Vec<f64>,
    pub scatter: Vec<usize>,
    pub sscale: Vec<f64>,
    /// the sign of the permutation into the blocks' order
    pub sign: i32,
    /// the fallback in the model's own order: positions of rows and
    /// coordinates, its entries (Jacobian entry, position r n + c, scale),
    /// row and column patterns (up to MASK coordinates; none above), the
    /// sign of the model's order
    pub whole_row: Vec<usize>,
    pub whole_col: Vec<usize>,
    pub whole_entries: Vec<(u32, u32, f64)>,
    pub whole_patterns: Vec<(u64, u64)>,
    pub whole_sign: i32,
    /// the position (in the blocks' order) of the coordinate at each of the fallback's positions
    pub whole_to_pos: Vec<usize>,
}

impl Triangular {
    /// The factors' storage: the fallback's n x n, then the blocks'.
    pub fn stored(&self) -> usize {
        let n = self.gather.len();
        n * n + self.blocks.iter().map(|d| d.s * d.s).sum::<usize>()
    }

    /// The blocks factorised in order (f.fixed[0]: their pivots' figures),
    /// or the whole matrix with partial pivoting (f.fixed[0] None).
    pub fn factor(&self, values: &[f64], f: &mut Factors) {
        f.fixed[0] = self.blocks_factor(values, f).filter(|p| p.ratio() >= FALLBACK);
        if f.fixed[0].is_some() {
            return;
        }
        let n = self.gather.len();
        let a = &mut f.j[..n * n];
        a.fill(0.0);
        for &(e, pos, scale) in &self.whole_entries {
            a[pos as usize] = values[e as usize] * scale;
        }
        if n > MASK {
            return dense_factor(a, n, &mut f.piv);
        }
        for i in 0..n {
            (f.rm[i], f.cm[i]) = self.whole_patterns[i];
        }
        masked_factor(a, n, &mut f.piv, &mut f.rm, &mut f.cm);
    }

    fn blocks_factor(&self, values: &[f64], f: &mut Factors) -> Option<Pivots> {
        for (x, &(e, scale)) in f.off.iter_mut().zip(&self.off_entries) {
            *x = values[e as usize] * scale;
        }
        let mut acc = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det: self.sign };
        for d in &self.blocks {
            let a = &mut f.j[d.store..d.store + d.s * d.s];
            match &d.order {
                None => {
                    for &(e, scale) in &d.entries {
                        a[0] = values[e as usize] * scale;
                    }
                    let x = a[0];
                    if x == 0.0 || !x.is_finite() {
                        return None;
                    }
                    acc.det *= if x < 0.0 { -1 } else { 1 };
                    acc.take(x.abs(), d.at);
                    acc.big = acc.big.max(x.abs());
                }
                Some(o) => {
                    for &at in &o.fill_at {
                        a[at] = 0.0;
                    }
                    for &(e, at, scale) in &o.place {
                        a[at as usize] = values[e as usize] * scale;
                    }
                    // its det without the order's parity: the positions are in the order already
                    let p = o.numeric(a)?;
                    acc.det *= p.det * o.parity;
                    acc.take(p.small, d.at + o.inv_col[p.at]);
                    acc.big = acc.big.max(p.big);
                }
            }
        }
        Some(acc)
    }

    /// x = Phi_q^-1 b (model rows in, coordinates out); scale, col_scale:
    /// the layout's (the fallback's solve is Layout::solve's, to the bit).
    pub fn solve(&self, f: &mut Factors, b: &[f64], x: &mut [f64], scale: &[f64], col_scale: &[f64]) {
        let n = self.gather.len();
        let w = &mut f.w[..n];
        if f.fixed[0].is_none() {
            w.fill(0.0);
            for (i, &p) in self.whole_row.iter().enumerate() {
                w[p] = b[i] / scale[i];
            }
            if n > MASK {
                dense_solve(&f.j[..n * n], n, &f.piv, w);
            } else {
                masked_solve(&f.j[..n * n], n, &f.piv, &f.rm, w);
            }
            for (j, &p) in self.whole_col.iter().enumerate() {
                x[j] = w[p] * col_scale[j];
            }
            return;
        }
        for ((v, &i), &scale) in w.iter_mut().zip(&self.gather).zip(&self.gscale) {
            *v = b[i] * scale;
        }
        let (j, off) = (&f.j, &f.off);
        for &(r, c, v) in &self.program {
            let (r, c, v) = (r as usize, c as usize, v as usize);
            if r == c {
                w[r] /= j[v];
            } else if r == BLOCK as usize {
                let d = &self.blocks[c];
                if let Some(o) = &d.order {
                    o.eliminate(&j[d.store..d.store + d.s * d.s], &mut w[d.at..d.at + d.s]);
                }
            } else {
                let x = w[c];
                w[r] -= off[v] * x;
            }
        }
        for ((&v, &j), &scale) in w.iter().zip(&self.scatter).zip(&self.sscale) {
            x[j] = v * scale;
        }
    }

    /// (pivot ratio, det sign, position of the smallest |pivot| in the
    /// blocks' order) of the factors.
    pub fn pivots(&self, f: &Factors) -> (f64, i32, usize) {
        if let Some(p) = &f.fixed[0] {
            return (p.ratio(), p.det, p.at);
        }
        let n = self.gather.len();
        let mut acc = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det: self.whole_sign };
        for j in 0..n {
            if !acc.visit(f.j[j * n + j], f.piv[j] != j, true, self.whole_to_pos[j]) {
                return (0.0, acc.det, acc.at);
            }
        }
        (acc.ratio(), acc.det, acc.at)
    }
}
