//! The linear algebra of the march: J_s = diag(1/scale) Phi_q diag(col_scale)
//! (the dimensionless Jacobian, docs/solver.md) laid out once per model
//! (kinem.model.Blocks or Band) and factorised with partial pivoting.
//!
//! Blocks: J_s's independent diagonal blocks (one for a small model, one per
//! variant of merged variants), each dense; blocks of up to 64 coordinates
//! visit only their structural nonzeros (row and column patterns as 64-bit
//! masks, grown by fill-in). The elimination is LAPACK getf2's: partial
//! pivoting on the first largest |entry| of the column, whole-row
//! interchanges, so the pivots (and the conditioning figure and det sign)
//! are LAPACK's. Band: a large chain's J_s in LAPACK gbtrf storage after its
//! single-entry rows (grounds, drivers) are taken out (gbtf2's elimination).
//! Triangular: one block that decomposes, in its block-triangular order
//! (crate::triangular).

use crate::order::{Order, Pivots};
use crate::triangular::Triangular;
use rayon::prelude::*;

/// Models of at least this many diagonal blocks (merged variants)
/// factorise their blocks in parallel: below it the threads' start-up and
/// join cost more than the blocks' LUs (about 0.1 us each).
pub const PARALLEL: usize = 64;

/// One block's share of the factors: its storage, pivots, row and column
/// masks, and whether it is in its fixed order.
type BlockParts<'a> = (((&'a mut [f64], &'a mut [usize]), (&'a mut [u64], &'a mut [u64])), &'a mut Option<Pivots>);

/// Blocks of up to this many coordinates are factorised on their nonzeros.
pub const MASK: usize = 64;
/// A block whose fixed-order pivots span more than this ratio (smallest over
/// largest) is factorised again with partial pivoting, so that every figure
/// near the acceptance test's floor (about 1.5e-6) and every decision taken
/// on it is partial pivoting's, as in the step-by-step analysis before the
/// fixed order existed; regular configurations keep the fixed order's.
pub const FALLBACK: f64 = 1e-3;

/// How J_s is stored and factorised (kinem.model.Blocks / Band).
#[derive(Clone, Debug)]
pub enum Shape {
    /// `count` dense blocks of `size` (padding positions hold 1 on the
    /// diagonal); blocks of up to MASK coordinates have their patterns as
    /// bit masks and, where the structure allows one, a fixed pivot order.
    Blocks { count: usize, size: usize, pad: Vec<usize>, patterns: Vec<(u64, u64)>, orders: Vec<Option<Order>> },
    /// The band: kl, ku, the reduced system's size, the rows with a single
    /// entry (their count `singles`), and the reduced rows' entries in
    /// single-entry columns (coupling: reduced row, single index).
    Band { kl: usize, ku: usize, size: usize, singles: usize, couple_row: Vec<usize>, couple_col: Vec<usize> },
    /// One block whose diagonal blocks have up to MASK coordinates each, in its block-triangular order
    /// (crate::decompose, crate::triangular, built by crate::plan): row_pos
    /// and col_pos are the positions in that order (the permutation's sign
    /// and the partial-pivoting fallback's own layout are the Triangular's).
    Triangular(Box<Triangular>),
}

/// Where each Jacobian entry goes and how it is scaled.
#[derive(Clone, Debug)]
pub struct Layout {
    pub shape: Shape,
    pub n: usize,
    pub m: usize,
    pub height: usize,
    pub width: usize,
    pub count: usize,
    /// per entry: (block, row, column) of the stored matrix
    pub at: Vec<(usize, usize, usize)>,
    pub entry_scale: Vec<f64>,
    pub row_pos: Vec<usize>,
    pub col_pos: Vec<usize>,
    pub real: Vec<bool>,
    pub sign: i32,
    pub scale: Vec<f64>,
    pub col_scale: Vec<f64>,
    /// the entries of each block (by_block[start[c]..start[c + 1]])
    pub by_block: Vec<usize>,
    pub block_start: Vec<usize>,
}

/// A factorisation's storage: J (count, height, width), pivots, masks, work.
#[derive(Debug)]
pub struct Factors {
    pub j: Vec<f64>,
    pub piv: Vec<usize>,
    pub rm: Vec<u64>,
    pub cm: Vec<u64>,
    pub w: Vec<f64>,
    /// per block: factorised in its fixed order, with its pivots' figures
    /// (None: with partial pivoting)
    pub fixed: Vec<Option<Pivots>>,
    y: Vec<f64>,
    /// the values factorised here are a Kin's whose exact zeros cover the
    /// entries the layout takes for zero (`Layout::zeros_hold`: the march
    /// sets it for its own Kin); false (made so): each factorisation checks
    /// those entries (a variant's Kin on the nominal's layout, the lanes')
    pub zeros_hold: bool,
    /// the values factorised here hold exactly 1 at the folded pivots'
    /// entries and -1 at the negated ones' (Factoring::one_entries,
    /// minus_entries), and nothing writes those entries again
    /// (`Layout::signs_hold`: the march's own values, whose constant
    /// entries Kin::jac_over never writes); false (made so): each
    /// factorisation checks them
    pub signs_hold: bool,
    /// the placements of a factorisation where the march's constant entries
    /// were placed once (`Layout::place_once`): the others, in order
    pub again: Vec<[u32; 2]>,
    /// `again` stands for every placement (the constants placed once)
    pub once: bool,
    /// the constants placed once are in j (a factorisation with partial
    /// pivoting overwrites them: the next one places every entry)
    pub placed: bool,
}

impl Factors {
    /// No storage (nothing allocated): room to clone into.
    pub fn empty() -> Self {
        Factors {
            j: Vec::new(),
            piv: Vec::new(),
            rm: Vec::new(),
            cm: Vec::new(),
            w: Vec::new(),
            fixed: Vec::new(),
            y: Vec::new(),
            zeros_hold: false,
            signs_hold: false,
            again: Vec::new(),
            once: false,
            placed: false,
        }
    }
}

impl Clone for Factors {
    fn clone(&self) -> Self {
        let mut f = Factors::empty();
        f.clone_from(self);
        f
    }

    /// Field by field, in the buffers self has (crate::march::Room::set: no allocation).
    fn clone_from(&mut self, s: &Self) {
        let Factors { j, piv, rm, cm, w, fixed, y, zeros_hold, signs_hold, again, once, placed } = self;
        j.clone_from(&s.j);
        piv.clone_from(&s.piv);
        rm.clone_from(&s.rm);
        cm.clone_from(&s.cm);
        w.clone_from(&s.w);
        fixed.clone_from(&s.fixed);
        y.clone_from(&s.y);
        again.clone_from(&s.again);
        (*zeros_hold, *signs_hold, *once, *placed) = (s.zeros_hold, s.signs_hold, s.once, s.placed);
    }
}

impl Layout {
    /// Whether kin's exact zeros (Kin::zero_entries) cover the Jacobian
    /// entries this layout takes for zero (Factoring::zero_entries): then a
    /// factorisation of its values need not check them (Factors::zeros_hold).
    pub fn zeros_hold(&self, kin: &crate::model::Kin) -> bool {
        let Shape::Triangular(t) = &self.shape else { return true };
        let zero = kin.zero_entries();
        t.factoring.zero_entries.iter().all(|&e| zero.get(e as usize) == Some(&true))
    }

    /// Whether `values` hold exactly 1 at every folded pivot's entry and
    /// -1 at every negated one's (Factoring::one_entries, minus_entries),
    /// each of them `kept` (never written again: Kin::over_kept): then a
    /// factorisation of those values need not check them (Factors::signs_hold).
    pub fn signs_hold(&self, values: &[f64], kept: &[bool]) -> bool {
        let Shape::Triangular(t) = &self.shape else { return false };
        let holds = |e: u32, v: f64| kept.get(e as usize) == Some(&true) && values.get(e as usize) == Some(&v);
        let f = &t.factoring;
        f.one_entries.iter().all(|&e| holds(e, 1.0)) && f.minus_entries.iter().all(|&e| holds(e, -1.0))
    }

    /// Places the Jacobian's constant entries (`kept`: never written again
    /// into `values`, Kin::over_kept) into f's factors once, where nothing
    /// else writes their places (Factoring::place_free); f's factorisations
    /// then place only the others (Factors::again), the same figures.
    pub fn place_once(&self, values: &[f64], kept: &[bool], f: &mut Factors) {
        let Shape::Triangular(t) = &self.shape else { return };
        let p = &t.factoring;
        let once = |k: usize, e: u32| p.place_free[k] && kept.get(e as usize) == Some(&true);
        let mut again = Vec::with_capacity(p.place.len());
        for (k, &[e, at]) in p.place.iter().enumerate() {
            if once(k, e) {
                f.j[at as usize] = values[e as usize];
            } else {
                again.push([e, at]);
            }
        }
        if again.len() < p.place.len() {
            (f.again, f.once, f.placed) = (again, true, true);
        }
    }

    /// Every placement at each factorisation again (`place_once` undone).
    pub fn place_every(&self, f: &mut Factors) {
        (f.once, f.placed) = (false, false);
        f.again.clear();
    }

    pub fn factors(&self) -> Factors {
        let per = match &self.shape {
            Shape::Blocks { size, .. } => *size,
            Shape::Band { size, .. } => *size,
            Shape::Triangular(t) => {
                let mut j = vec![0.0; t.stored()];
                t.factoring.init(&mut j);
                return Factors {
                    j,
                    piv: vec![0; self.n.max(1)],
                    rm: vec![0; self.n.max(1)],
                    cm: vec![0; self.n.max(1)],
                    w: vec![0.0; self.n.max(1)],
                    fixed: vec![None],
                    ..Factors::empty()
                };
            }
        };
        Factors {
            j: vec![0.0; self.count * self.height * self.width],
            piv: vec![0; self.count * per.max(1)],
            rm: vec![0; self.count * per.max(1)],
            cm: vec![0; self.count * per.max(1)],
            w: vec![0.0; (self.count * per).max(self.n).max(self.width)],
            fixed: vec![None; self.count],
            y: vec![0.0; per.max(1)],
            ..Factors::empty()
        }
    }

    /// Groups the entries by block (`by_block`); called once when built.
    pub fn group(&mut self) {
        let mut lists = vec![Vec::new(); self.count];
        for (e, &(b, _, _)) in self.at.iter().enumerate() {
            lists[b].push(e);
        }
        self.block_start = vec![0];
        self.by_block.clear();
        for l in lists {
            self.by_block.extend(l);
            self.block_start.push(self.by_block.len());
        }
    }

    /// Block c of a Blocks layout as a layout of its own (one block at the
    /// same positions, det sign without the model's reordering): rows, cols
    /// and entries are the block's global rows, coordinates and Jacobian
    /// entries, ascending (a part of the model, crate::model::Kin::split).
    pub fn part(&self, c: usize, rows: &[usize], cols: &[usize], entries: &[usize]) -> Option<Layout> {
        let Shape::Blocks { size, pad, patterns, .. } = &self.shape else { return None };
        let (s, o) = (*size, c * size);
        let mut l = Layout {
            shape: Shape::Blocks {
                count: 1,
                size: s,
                pad: pad.iter().filter(|&&p| p / s == c).map(|&p| p - o).collect(),
                patterns: if patterns.is_empty() { Vec::new() } else { patterns[o..o + s].to_vec() },
                orders: Vec::new(),
            },
            n: cols.len(),
            m: rows.len(),
            height: s,
            width: s,
            count: 1,
            at: entries.iter().map(|&e| (0, self.at[e].1, self.at[e].2)).collect(),
            entry_scale: entries.iter().map(|&e| self.entry_scale[e]).collect(),
            row_pos: rows.iter().map(|&g| self.row_pos[g] - o).collect(),
            col_pos: cols.iter().map(|&g| self.col_pos[g] - o).collect(),
            real: self.real[o..o + s].to_vec(),
            sign: 1,
            scale: rows.iter().map(|&g| self.scale[g]).collect(),
            col_scale: cols.iter().map(|&g| self.col_scale[g]).collect(),
            by_block: Vec::new(),
            block_start: Vec::new(),
        };
        l.group();
        Some(l)
    }

    /// Block c of J_s from the values: in its fixed order's positions, or natural.
    fn assemble_block(&self, values: &[f64], c: usize, s: usize, pad: &[usize], order: Option<&Order>, a: &mut [f64]) {
        match order {
            Some(o) => {
                // the elimination reads only the factors' pattern: clear the fill, set the rest
                for &at in &o.fill_at {
                    a[at] = 0.0;
                }
                for &(e, at, scale) in &o.place {
                    a[at as usize] = values[e as usize] * scale;
                }
                for &at in &o.pad_at {
                    a[at] = 1.0;
                }
            }
            None => {
                a.fill(0.0);
                for &e in &self.by_block[self.block_start[c]..self.block_start[c + 1]] {
                    let (_, r, k) = self.at[e];
                    a[r * s + k] = values[e] * self.entry_scale[e];
                }
                for &p in pad.iter().filter(|&&p| p / s == c) {
                    a[(p % s) * (s + 1)] = 1.0;
                }
            }
        }
    }

    /// J_s assembled from the Jacobian's values (nnz) into f.j and
    /// factorised: each block in its fixed order when it has one and the
    /// values suit it, else with partial pivoting; the band with gbtf2's.
    pub fn factor(&self, values: &[f64], f: &mut Factors) {
        let (h, w) = (self.height, self.width);
        match &self.shape {
            Shape::Blocks { count, size, .. } => {
                let s = *size;
                let one = |(c, (((a, piv), (rm, cm)), fixed)): (usize, BlockParts)| {
                    *fixed = self.factor_block(values, c, a, piv, rm, cm);
                };
                let blocks =
                    f.j.chunks_mut(s * s)
                        .zip(f.piv.chunks_mut(s))
                        .zip(f.rm.chunks_mut(s).zip(f.cm.chunks_mut(s)))
                        .zip(f.fixed.iter_mut());
                if *count >= PARALLEL {
                    // many variants: their blocks factorise on every core (rayon)
                    let blocks =
                        f.j.par_chunks_mut(s * s)
                            .zip(f.piv.par_chunks_mut(s))
                            .zip(f.rm.par_chunks_mut(s).zip(f.cm.par_chunks_mut(s)))
                            .zip(f.fixed.par_iter_mut());
                    blocks.enumerate().for_each(one);
                } else {
                    blocks.enumerate().for_each(one);
                }
            }
            Shape::Band { kl, ku, size, .. } => {
                f.j.fill(0.0);
                for (e, &(b, r, c)) in self.at.iter().enumerate() {
                    f.j[(b * h + r) * w + c] = values[e] * self.entry_scale[e];
                }
                band_factor(&mut f.j, w, *size, &mut f.piv, *kl, *ku)
            }
            Shape::Triangular(t) => t.factor(values, f),
        }
    }

    /// Block c factorised into a (its storage): in its fixed order when it
    /// has one and the values suit it (returns its pivots' figures), else
    /// with partial pivoting into piv, rm, cm (returns None).
    fn factor_block(
        &self,
        values: &[f64],
        c: usize,
        a: &mut [f64],
        piv: &mut [usize],
        rm: &mut [u64],
        cm: &mut [u64],
    ) -> Option<Pivots> {
        let Shape::Blocks { size, pad, patterns, orders, .. } = &self.shape else { return None };
        let s = *size;
        if let Some(o) = orders.get(c).and_then(|o| o.as_ref()) {
            self.assemble_block(values, c, s, pad, Some(o), a);
            if let Some(p) = o.numeric(a).filter(|p| p.ratio() >= FALLBACK) {
                return Some(p);
            }
        }
        self.assemble_block(values, c, s, pad, None, a);
        if s <= MASK {
            for i in 0..s {
                rm[i] = patterns[c * s + i].0;
                cm[i] = patterns[c * s + i].1;
            }
            masked_factor(a, s, piv, rm, cm);
        } else {
            dense_factor(a, s, piv);
        }
        None
    }

    /// x = Phi_q^-1 b from the factors (b: m rows, x: n coordinates). The
    /// block-triangular layout's blocks (the march's usual case) inline,
    /// straight into their program; every other layout and the fallback
    /// out of line (`solve_other`), so the usual call has no prologue of theirs.
    #[inline]
    pub fn solve(&self, f: &mut Factors, b: &[f64], x: &mut [f64]) {
        self.solve_quiet(f, b, x);
    }

    /// `solve`, returning whether the blocks' program ran quiet
    /// (`Program::run_negating`): the quiet positions' right sides were all
    /// zero, and each quiet coordinate's x is its row's b, to the bit (false
    /// for every other layout and the fallback).
    #[inline]
    pub fn solve_quiet(&self, f: &mut Factors, b: &[f64], x: &mut [f64]) -> bool {
        if let Shape::Triangular(t) = &self.shape {
            if f.fixed[0].is_some() {
                return t.run_negating(&f.j, b, x);
            }
        }
        self.solve_other(f, b, x);
        false
    }

    /// The quiet coordinates of the blocks' program (crate::triangular::Program:
    /// its places are the coordinates), none for another layout.
    pub fn quiet(&self) -> &[u32] {
        match &self.shape {
            Shape::Triangular(t) => &t.program.quiet,
            _ => &[],
        }
    }

    /// `solve` of the layouts other than the triangular's blocks.
    #[inline(never)]
    fn solve_other(&self, f: &mut Factors, b: &[f64], x: &mut [f64]) {
        if let Shape::Triangular(t) = &self.shape {
            return t.solve(f, b, x, &self.scale, &self.col_scale);
        }
        if let Shape::Blocks { count, size, orders, .. } = &self.shape {
            if f.fixed.iter().all(|x| x.is_some()) {
                // every block in its fixed order: straight from b to x
                let s = *size;
                for (c, o) in orders.iter().enumerate().take(*count) {
                    if let Some(o) = o {
                        o.solve_fused(&f.j[c * s * s..(c + 1) * s * s], b, x, &mut f.y);
                    }
                }
                return;
            }
        }
        let w = &mut f.w;
        w.fill(0.0);
        for i in 0..self.m {
            w[self.row_pos[i]] = b[i] / self.scale[i];
        }
        match &self.shape {
            Shape::Blocks { count, size, orders, .. } => {
                let s = *size;
                for c in 0..*count {
                    let a = &f.j[c * s * s..(c + 1) * s * s];
                    let piv = &f.piv[c * s..(c + 1) * s];
                    let v = &mut w[c * s..(c + 1) * s];
                    if f.fixed[c].is_some() {
                        if let Some(o) = &orders[c] {
                            o.solve(a, v, &mut f.y);
                        }
                    } else if s <= MASK {
                        masked_solve(a, s, piv, &f.rm[c * s..(c + 1) * s], v);
                    } else {
                        dense_solve(a, s, piv, v);
                    }
                }
            }
            Shape::Band { kl, ku, size, singles, couple_row, couple_col } => {
                let (h, wd) = (self.height, self.width);
                for s in 0..*singles {
                    w[size + s] /= f.j[(h - 2) * wd + s];
                }
                for e in 0..couple_row.len() {
                    w[couple_row[e]] -= f.j[(h - 1) * wd + e] * w[size + couple_col[e]];
                }
                band_solve(&f.j, wd, *size, &f.piv, *kl, *ku, &mut w[..*size]);
            }
            Shape::Triangular(_) => {} // solved above
        }
        for j in 0..self.n {
            x[j] = w[self.col_pos[j]] * self.col_scale[j];
        }
    }

    /// (pivot ratio, det sign) of J_s from its factors: the smallest over the
    /// largest |pivot| at the real (not padding) positions, 0 when one is not
    /// finite; the sign of det(J_s) (the rows' and columns' reordering
    /// included), 0 for a zero pivot. The block-triangular layout's blocks
    /// inline (the figures their factorisation took), the rest by `pivots`.
    #[inline]
    pub fn stats(&self, f: &Factors) -> (f64, i32) {
        if let (Shape::Triangular(_), Some(Some(p))) = (&self.shape, f.fixed.first()) {
            return (p.ratio(), p.det);
        }
        let (ratio, det, _) = self.pivots(f);
        (ratio, det)
    }

    /// `stats` and the position of the smallest |pivot| (in the stored order).
    pub fn pivots(&self, f: &Factors) -> (f64, i32, usize) {
        let mut acc = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det: self.sign };
        match &self.shape {
            Shape::Blocks { count, size, .. } => {
                let s = *size;
                for c in 0..*count {
                    if let Some(p) = &f.fixed[c] {
                        // the figures its fixed-order elimination took
                        acc.det *= p.det;
                        acc.take(p.small, c * s + p.at);
                        acc.big = acc.big.max(p.big);
                        continue;
                    }
                    for j in 0..s {
                        let d = f.j[c * s * s + j * s + j];
                        if !acc.visit(d, f.piv[c * s + j] != j, self.real[c * s + j], c * s + j) {
                            return (0.0, acc.det, acc.at);
                        }
                    }
                }
            }
            Shape::Band { kl, ku, size, .. } => {
                let (h, wd) = (self.height, self.width);
                for j in 0..self.n {
                    let (d, sw) = if j < *size {
                        (f.j[(kl + ku) * wd + j], f.piv[j] != j)
                    } else {
                        (f.j[(h - 2) * wd + j - size], false)
                    };
                    if !acc.visit(d, sw, self.real[j], j) {
                        return (0.0, acc.det, acc.at);
                    }
                }
            }
            Shape::Triangular(t) => return t.pivots(f),
        }
        (acc.ratio(), acc.det, acc.at)
    }
}

impl Pivots {
    /// |pivot| x at position `at`, if the smallest so far.
    pub(crate) fn take(&mut self, x: f64, at: usize) {
        if x < self.small {
            self.small = x;
            self.at = at;
        }
    }

    /// One pivot d of a partial-pivoting factorisation (swapped: its row was
    /// interchanged); false when a real one is not finite.
    pub(crate) fn visit(&mut self, d: f64, swapped: bool, real: bool, pos: usize) -> bool {
        if swapped {
            self.det = -self.det;
        }
        if d < 0.0 {
            self.det = -self.det;
        } else if d == 0.0 {
            self.det = 0;
        }
        if real {
            let a = d.abs();
            if !(a < f64::INFINITY) {
                return false;
            }
            self.take(a, pos);
            self.big = self.big.max(a);
        }
        true
    }
}

/// LU of a (n x n, row-major) in place with partial pivoting (getf2).
pub fn dense_factor(a: &mut [f64], n: usize, piv: &mut [usize]) {
    for j in 0..n {
        let (mut p, mut big) = (j, a[j * n + j].abs());
        for i in j + 1..n {
            if a[i * n + j].abs() > big {
                p = i;
                big = a[i * n + j].abs();
            }
        }
        piv[j] = p;
        if p != j {
            for c in 0..n {
                a.swap(j * n + c, p * n + c);
            }
        }
        let d = a[j * n + j];
        if d != 0.0 {
            let r = 1.0 / d;
            for i in j + 1..n {
                let f = a[i * n + j] * r;
                a[i * n + j] = f;
                if f != 0.0 {
                    for c in j + 1..n {
                        a[i * n + c] -= f * a[j * n + c];
                    }
                }
            }
        }
    }
}

/// b <- A^-1 b from dense_factor's result, column by column (as getrs).
pub fn dense_solve(a: &[f64], n: usize, piv: &[usize], b: &mut [f64]) {
    for j in 0..n {
        b.swap(j, piv[j]);
    }
    for j in 0..n {
        let x = b[j];
        if x != 0.0 {
            for i in j + 1..n {
                b[i] -= a[i * n + j] * x;
            }
        }
    }
    for j in (0..n).rev() {
        let x = b[j] / a[j * n + j];
        b[j] = x;
        if x != 0.0 {
            for i in 0..j {
                b[i] -= a[i * n + j] * x;
            }
        }
    }
}

/// dense_factor's LU of one matrix (n <= 64) visiting only its structural
/// nonzeros: rm[i] has the columns of row i, cm[j] the rows of column j (in:
/// a's pattern; out: the factors', fill-in included). The same pivots in the
/// same order and the same arithmetic on every nonzero: the same factors to
/// the bit.
pub fn masked_factor(a: &mut [f64], n: usize, piv: &mut [usize], rm: &mut [u64], cm: &mut [u64]) {
    for j in 0..n {
        let bj = 1u64 << j;
        let (mut p, mut big) = (j, a[j * n + j].abs());
        let mut m = below(cm[j], j);
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            let v = a[i * n + j].abs();
            if v > big {
                p = i;
                big = v;
            }
        }
        piv[j] = p;
        if p != j {
            let bp = 1u64 << p;
            let mut u = rm[j] | rm[p];
            while u != 0 {
                let c = u.trailing_zeros() as usize;
                u &= u - 1;
                a.swap(j * n + c, p * n + c);
                let x = cm[c] & (bj | bp);
                if x == bj || x == bp {
                    cm[c] ^= bj | bp;
                }
            }
            rm.swap(j, p);
        }
        let d = a[j * n + j];
        if d != 0.0 {
            let r = 1.0 / d;
            let upper = rm[j] & !(bj | (bj - 1));
            let mut m = below(cm[j], j);
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let f = a[i * n + j] * r;
                a[i * n + j] = f;
                if f != 0.0 {
                    let bi = 1u64 << i;
                    let mut u = upper;
                    while u != 0 {
                        let c = u.trailing_zeros() as usize;
                        u &= u - 1;
                        a[i * n + c] -= f * a[j * n + c];
                        cm[c] |= bi;
                    }
                    rm[i] |= upper;
                }
            }
        }
    }
}

/// The bits of mask above bit j.
#[inline(always)]
fn below(mask: u64, j: usize) -> u64 {
    if j >= 63 {
        0
    } else {
        mask & !((2u64 << j) - 1)
    }
}

/// b <- A^-1 b from masked_factor's factors and row masks.
pub fn masked_solve(a: &[f64], n: usize, piv: &[usize], rm: &[u64], b: &mut [f64]) {
    for j in 0..n {
        b.swap(j, piv[j]);
    }
    for i in 1..n {
        let mut m = rm[i] & ((1u64 << i) - 1);
        let mut s = b[i];
        while m != 0 {
            let c = m.trailing_zeros() as usize;
            m &= m - 1;
            s -= a[i * n + c] * b[c];
        }
        b[i] = s;
    }
    for i in (0..n).rev() {
        let mut m = below(rm[i], i);
        let mut s = b[i];
        while m != 0 {
            let c = m.trailing_zeros() as usize;
            m &= m - 1;
            s -= a[i * n + c] * b[c];
        }
        b[i] = s / a[i * n + i];
    }
}

/// LU with partial pivoting of a band matrix in gbtrf storage (element
/// (i, j) at ab[(kl + ku + i - j) * w + j], kl rows of fill-in space above),
/// in place, as LAPACK's gbtf2; n columns.
pub fn band_factor(ab: &mut [f64], w: usize, n: usize, piv: &mut [usize], kl: usize, ku: usize) {
    let kv = kl + ku;
    let mut ju = 0usize;
    let at = |r: usize, c: usize| r * w + c;
    for j in 0..n {
        let km = kl.min(n - 1 - j);
        let (mut p, mut big) = (0usize, ab[at(kv, j)].abs());
        for i in 1..=km {
            if ab[at(kv + i, j)].abs() > big {
                p = i;
                big = ab[at(kv + i, j)].abs();
            }
        }
        piv[j] = j + p;
        if ab[at(kv + p, j)] == 0.0 {
            continue;
        }
        ju = ju.max((j + ku + p).min(n - 1));
        if p != 0 {
            for c in j..=ju {
                ab.swap(at(kv + j - c, c), at(kv + j + p - c, c));
            }
        }
        let r = 1.0 / ab[at(kv, j)];
        for i in 1..=km {
            ab[at(kv + i, j)] *= r;
        }
        for c in j + 1..=ju {
            let t = ab[at(kv + j - c, c)];
            if t != 0.0 {
                for i in 1..=km {
                    ab[at(kv + j + i - c, c)] -= ab[at(kv + i, j)] * t;
                }
            }
        }
    }
}

/// b <- A^-1 b from band_factor's result.
pub fn band_solve(ab: &[f64], w: usize, n: usize, piv: &[usize], kl: usize, ku: usize, b: &mut [f64]) {
    let kv = kl + ku;
    for j in 0..n {
        let p = piv[j];
        if p != j {
            b.swap(j, p);
        }
        let km = kl.min(n - 1 - j);
        for i in 1..=km {
            b[j + i] -= ab[(kv + i) * w + j] * b[j];
        }
    }
    for j in (0..n).rev() {
        b[j] /= ab[kv * w + j];
        for i in j.saturating_sub(kv)..j {
            b[i] -= ab[(kv + i - j) * w + j] * b[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn masked_equals_dense_and_solves() {
        let mut seed = 7u64;
        for n in [1usize, 3, 12, 40, 64] {
            let mut a = vec![0.0; n * n];
            let (mut rm, mut cm) = (vec![0u64; n], vec![0u64; n]);
            for i in 0..n {
                for j in 0..n {
                    if i == j || lcg(&mut seed) > 0.6 {
                        a[i * n + j] = if lcg(&mut seed) > 0.5 { 1.0 } else { lcg(&mut seed) };
                        rm[i] |= 1 << j;
                        cm[j] |= 1 << i;
                    }
                }
            }
            let (mut d, mut s) = (a.clone(), a.clone());
            let (mut pd, mut ps) = (vec![0; n], vec![0; n]);
            dense_factor(&mut d, n, &mut pd);
            masked_factor(&mut s, n, &mut ps, &mut rm, &mut cm);
            assert_eq!(pd, ps);
            // equal as numbers (an untouched zero of L is +0 where getf2 writes 0 x (1/pivot), maybe -0)
            let bad: Vec<usize> = (0..n * n).filter(|&k| d[k] != s[k]).collect();
            assert!(bad.is_empty(), "n {n}: {} differ, first {:?} {} {}", bad.len(), bad.first(), d[bad[0]], s[bad[0]]);
            let x: Vec<f64> = (0..n).map(|_| lcg(&mut seed)).collect();
            let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum()).collect();
            masked_solve(&s, n, &ps, &rm, &mut b);
            let err = b.iter().zip(&x).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
            assert!(err < 1e-8, "n {n}: error {err}");
        }
    }

    #[test]
    fn band_solves_a_tridiagonal_system() {
        let n = 30;
        let (kl, ku) = (1usize, 1usize);
        let w = n;
        let h = 2 * kl + ku + 1;
        let mut ab = vec![0.0; h * w];
        let mut full = vec![0.0; n * n];
        for i in 0..n {
            for j in i.saturating_sub(kl)..(i + ku + 1).min(n) {
                let v = if i == j { 0.1 } else { 1.0 + (i + 2 * j) as f64 * 0.01 };
                ab[(kl + ku + i - j) * w + j] = v;
                full[i * n + j] = v;
            }
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| full[i * n + j] * x[j]).sum()).collect();
        let mut piv = vec![0; n];
        band_factor(&mut ab, w, n, &mut piv, kl, ku);
        band_solve(&ab, w, n, &piv, kl, ku, &mut b);
        let err = b.iter().zip(&x).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "error {err}");
    }
}
