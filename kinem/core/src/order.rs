//! A fixed pivot order for a small block of J_s, chosen once per model from
//! the Jacobian's structure (shared/reference/performance.md, "What a
//! static pivot order must respect"): a greedy Markowitz order over the
//! structural pattern that prefers, among the cheapest pivots, entries that
//! are constant +-1 whatever the configuration (then other constants) and
//! have not been changed by an earlier elimination step. Its elimination
//! is a flat program over the factors' pattern (fill-in included), with no
//! search and no interchange at run time. Each factorisation checks it
//! numerically (`numeric`): a zero pivot or a multiplier above MULTIPLIER
//! (threshold pivoting with u = 1 / MULTIPLIER) rejects it, and the caller
//! factorises that block with partial pivoting instead.

/// Multipliers above this reject the fixed order for a factorisation: with
/// |l| <= 10 the elimination's growth stays bounded as with partial
/// pivoting (threshold u = 0.1, the usual choice of sparse direct solvers).
pub const MULTIPLIER: f64 = 10.0;

/// The program of one block of `s` coordinates (s <= 64).
#[derive(Clone, Debug)]
pub struct Order {
    pub s: usize,
    /// step k pivots on block row row[k] and block column col[k]
    pub row: Vec<usize>,
    pub col: Vec<usize>,
    /// position (k s + l) of natural (i, j) in the permuted block: inv_row[i] s + inv_col[j]
    pub inv_row: Vec<usize>,
    pub inv_col: Vec<usize>,
    /// sign of the two permutations (det(J) = parity * prod of the pivots)
    pub parity: i32,
    /// the elimination's steps with work, as (k, lo, hi): step k's
    /// multipliers are L's entries mult[lo..hi] (row i, position i s + k),
    /// each updating row i at U's row k's columns right[rlo[k]..rlo[k + 1]]
    steps: Vec<(u32, u32, u32)>,
    mult: Vec<(u32, u32)>,
    right: Vec<u32>,
    right_start: Vec<u32>,
    /// the solves' back substitution as one program: (i, at, k) is
    /// y[k] /= a[at] (the pivot) when i == k, else y[i] -= a[at] y[k] (U's
    /// column k above the diagonal); the forward steps are `steps` over `mult`
    back: Vec<(u32, u32, u32)>,
    /// per step: the pivot is at a real (not padding) position (set by `fuse`)
    real: Vec<bool>,
    /// every position of the factors' pattern (fill-in included): the only
    /// ones the elimination reads (`fuse` keeps those no entry sets: fill_at)
    pattern_at: Vec<usize>,
    /// the pattern's positions that no Jacobian entry or padding sets (set
    /// by `fuse`): the only ones to clear before each assembly
    pub fill_at: Vec<usize>,
    /// set by `fuse`: step k's right side is b[gather[k]] * gscale[k]
    /// (NONE: padding, 0) and x[scatter[l]] = y[l] * sscale[l]
    gather: Vec<usize>,
    gscale: Vec<f64>,
    scatter: Vec<usize>,
    sscale: Vec<f64>,
    /// per Jacobian entry of the block, its position in the permuted block
    pub entry_at: Vec<usize>,
    /// the assembly: Jacobian entry e goes to position at, times its scale
    pub place: Vec<(u32, u32, f64)>,
    /// the permuted positions of the block's padding (1 on the diagonal)
    pub pad_at: Vec<usize>,
}

/// A fixed-order factorisation's pivots: the smallest and largest |pivot|
/// at real positions (`at`: the block column of the smallest), and the
/// sign of the block's determinant.
#[derive(Clone, Copy, Debug)]
pub struct Pivots {
    pub small: f64,
    pub big: f64,
    pub at: usize,
    pub det: i32,
}

impl Pivots {
    /// smallest over largest (0 without a real pivot)
    pub fn ratio(&self) -> f64 {
        if self.big > 0.0 {
            self.small / self.big
        } else {
            0.0
        }
    }
}

/// No row or coordinate (a padding position).
pub const NONE: usize = usize::MAX;

fn flatten(lists: Vec<Vec<usize>>) -> (Vec<usize>, Vec<usize>) {
    let mut start = vec![0];
    let mut flat = Vec::new();
    for l in lists {
        flat.extend(l);
        start.push(flat.len());
    }
    (flat, start)
}

pub(crate) fn parity(perm: &[usize]) -> i32 {
    let mut seen = vec![false; perm.len()];
    let mut sign = 1;
    for i in 0..perm.len() {
        if seen[i] {
            continue;
        }
        let mut j = i;
        let mut len = 0;
        while !seen[j] {
            seen[j] = true;
            j = perm[j];
            len += 1;
        }
        if len % 2 == 0 {
            sign = -sign;
        }
    }
    sign
}

impl Order {
    /// The order for a block of size s with row patterns `rows` (bit j of
    /// rows[i]: entry (i, j) may be non-zero); `unit[i]` and `constant[i]`:
    /// the columns where row i's entry is constant with |value| 1, or
    /// constant at all. None when the pattern is structurally singular.
    pub fn new(s: usize, rows: &[u64], unit: &[u64], constant: &[u64]) -> Option<Order> {
        assert!(s <= 64 && rows.len() == s);
        let full = if s == 64 { u64::MAX } else { (1u64 << s) - 1 };
        let mut pat = rows.to_vec();
        let mut changed = vec![0u64; s];
        let (mut live_r, mut live_c) = (full, full);
        let (mut row, mut col) = (Vec::with_capacity(s), Vec::with_capacity(s));
        for _ in 0..s {
            let mut best: Option<(u64, u8, usize, usize)> = None;
            let mut rr = live_r;
            while rr != 0 {
                let i = rr.trailing_zeros() as usize;
                rr &= rr - 1;
                let ri = pat[i] & live_c;
                let rc = ri.count_ones() as u64;
                let mut cc = ri;
                while cc != 0 {
                    let j = cc.trailing_zeros() as usize;
                    cc &= cc - 1;
                    let colj = (0..s).filter(|&r| live_r >> r & 1 == 1 && pat[r] >> j & 1 == 1).count() as u64;
                    let cost = (rc - 1) * (colj - 1);
                    let bit = 1u64 << j;
                    let fresh = changed[i] & bit == 0;
                    let pref = if fresh && unit[i] & bit != 0 {
                        0
                    } else if fresh && constant[i] & bit != 0 {
                        1
                    } else {
                        2
                    };
                    let key = (cost, pref, i, j);
                    if best.is_none_or(|b| key < b) {
                        best = Some(key);
                    }
                }
            }
            let (_, _, i, j) = best?;
            let upd = pat[i] & live_c & !(1u64 << j);
            for r in 0..s {
                if r != i && live_r >> r & 1 == 1 && pat[r] >> j & 1 == 1 {
                    pat[r] |= upd;
                    changed[r] |= upd;
                }
            }
            live_r &= !(1u64 << i);
            live_c &= !(1u64 << j);
            row.push(i);
            col.push(j);
        }
        let (mut inv_row, mut inv_col) = (vec![0; s], vec![0; s]);
        for k in 0..s {
            inv_row[row[k]] = k;
            inv_col[col[k]] = k;
        }
        // the permuted pattern and its fill
        let mut p = vec![0u64; s];
        for (k, pk) in p.iter_mut().enumerate() {
            let mut m = rows[row[k]];
            while m != 0 {
                let j = m.trailing_zeros() as usize;
                m &= m - 1;
                *pk |= 1u64 << inv_col[j];
            }
        }
        for k in 0..s {
            let upper = if k >= 63 { 0 } else { p[k] & !((1u64 << (k + 1)) - 1) };
            for i in k + 1..s {
                if p[i] >> k & 1 == 1 {
                    p[i] |= upper;
                }
            }
        }
        let bits = |m: u64| (0..s).filter(move |&l| m >> l & 1 == 1);
        let u = |x: usize| x as u32;
        let below: Vec<Vec<usize>> = (0..s).map(|k| (k + 1..s).filter(|&i| p[i] >> k & 1 == 1).collect()).collect();
        let right: Vec<Vec<usize>> = (0..s).map(|k| bits(p[k]).filter(|&l| l > k).collect()).collect();
        let (mut steps, mut mult) = (Vec::new(), Vec::new());
        for k in 0..s {
            if !below[k].is_empty() {
                let lo = u(mult.len());
                mult.extend(below[k].iter().map(|&i| (u(i), u(i * s + k))));
                steps.push((u(k), lo, u(mult.len())));
            }
        }
        let (right, right_start) = flatten(right);
        let mut back = Vec::new();
        for k in (0..s).rev() {
            back.push((u(k), u(k * s + k), u(k)));
            back.extend((0..k).filter(|&i| p[i] >> k & 1 == 1).map(|i| (u(i), u(i * s + k), u(k))));
        }
        let pattern_at = (0..s).flat_map(|k| bits(p[k] | 1u64 << k).map(move |l| k * s + l)).collect();
        Some(Order {
            s,
            parity: parity(&row) * parity(&col),
            row,
            col,
            inv_row,
            inv_col,
            steps,
            mult,
            right: right.into_iter().map(u).collect(),
            right_start: right_start.into_iter().map(u).collect(),
            back,
            real: vec![true; s],
            pattern_at,
            fill_at: Vec::new(),
            gather: Vec::new(),
            gscale: Vec::new(),
            scatter: Vec::new(),
            sscale: Vec::new(),
            entry_at: Vec::new(),
            place: Vec::new(),
            pad_at: Vec::new(),
        })
    }

    /// Binds the order to its block's place in the model: the model row
    /// (row_at) and coordinate (col_at) at each natural block position
    /// (NONE for padding), the row scales and column scales, the block's
    /// entries' natural (row, col) and its padding's local indices.
    #[allow(clippy::too_many_arguments)]
    pub fn fuse(
        &mut self,
        row_at: &[usize],
        col_at: &[usize],
        scale: &[f64],
        col_scale: &[f64],
        entries: &[(usize, usize)],
        pads: &[usize],
        real: &[bool],
    ) {
        let s = self.s;
        self.real = (0..s).map(|k| real[self.col[k]]).collect();
        self.gather = (0..s).map(|k| row_at[self.row[k]]).collect();
        self.gscale = self.gather.iter().map(|&i| if i == NONE { 0.0 } else { 1.0 / scale[i] }).collect();
        self.scatter = (0..s).map(|l| col_at[self.col[l]]).collect();
        self.sscale = self.scatter.iter().map(|&j| if j == NONE { 0.0 } else { col_scale[j] }).collect();
        self.entry_at = entries.iter().map(|&(r, c)| self.inv_row[r] * s + self.inv_col[c]).collect();
        self.pad_at = pads.iter().map(|&i| self.inv_row[i] * s + self.inv_col[i]).collect();
        let mut set = vec![false; s * s];
        for &at in self.entry_at.iter().chain(&self.pad_at) {
            set[at] = true;
        }
        self.fill_at = self.pattern_at.iter().copied().filter(|&at| !set[at]).collect();
    }

    /// x (model coordinates) from b (model rows) with `numeric`'s factors
    /// and the block's place (`fuse`); y: work (s).
    #[inline]
    pub fn solve_fused(&self, a: &[f64], b: &[f64], x: &mut [f64], y: &mut [f64]) {
        let s = self.s;
        for k in 0..s {
            let i = self.gather[k];
            y[k] = if i == NONE { 0.0 } else { b[i] * self.gscale[k] };
        }
        self.eliminate(a, y);
        for l in 0..s {
            let j = self.scatter[l];
            if j != NONE {
                x[j] = y[l] * self.sscale[l];
            }
        }
    }

    /// Appends `eliminate` (without its test for a zero right side) to a
    /// solve's program: the block's positions from `at`, its factors in the
    /// values from `store`.
    pub fn program(&self, at: usize, store: usize, p: &mut crate::triangular::Program) {
        for &(k, lo, hi) in &self.steps {
            for &(i, a) in &self.mult[lo as usize..hi as usize] {
                p.sub(at + i as usize, at + k as usize, store + a as usize);
            }
        }
        for &(i, a, k) in &self.back {
            if i == k {
                p.div(at + k as usize, store + a as usize);
            } else {
                p.sub(at + i as usize, at + k as usize, store + a as usize);
            }
        }
    }

    /// Appends `numeric` (without its skip of a zero multiplier) to a
    /// factoring (crate::triangular::Factoring), the block's factors from
    /// `store`: its fill to clear, its entries' placement (`place`, set by
    /// the caller), its steps and its pivots; the pivots' reciprocals at
    /// `recip` + k (the steps' with them, the last one's after the steps).
    pub fn factoring(&self, store: usize, recip: usize, f: &mut crate::triangular::Factoring) {
        let (s, u) = (self.s, |x: usize| x as u32);
        f.clear.extend(self.fill_at.iter().map(|&at| u(store + at)));
        f.place.extend(self.place.iter().map(|&(e, at, _)| [e, u(store + at as usize)])); // Phi_q's own values
        for &(k, lo, hi) in &self.steps {
            let k = k as usize;
            let right = &self.right[self.right_start[k] as usize..self.right_start[k + 1] as usize];
            for &(i, at) in &self.mult[lo as usize..hi as usize] {
                let i = i as usize * s;
                f.pairs.extend(right.iter().map(|&j| [u(store + i + j as usize), u(store + k * s + j as usize)]));
                f.mults.push([u(store + at as usize), u(f.pairs.len())]);
            }
            f.steps.push([u(store + k * s + k), u(f.mults.len()), u(recip + k)]);
        }
        let stepped = |k: usize| self.steps.iter().any(|st| st.0 as usize == k);
        f.recips.extend((0..s).filter(|&k| !stepped(k)).map(|k| [u(store + k * s + k), u(recip + k)]));
        f.diag.extend((0..s).map(|k| u(store + k * s + k)));
    }

    /// y <- U^-1 L^-1 y (permuted order).
    #[inline]
    pub fn eliminate(&self, a: &[f64], y: &mut [f64]) {
        for &(k, lo, hi) in &self.steps {
            let yk = y[k as usize];
            if yk != 0.0 {
                for &(i, at) in &self.mult[lo as usize..hi as usize] {
                    y[i as usize] -= a[at as usize] * yk;
                }
            }
        }
        for &(i, at, k) in &self.back {
            let (i, at, k) = (i as usize, at as usize, k as usize);
            if i == k {
                y[k] /= a[at];
            } else {
                y[i] -= a[at] * y[k];
            }
        }
    }

    /// LU of the permuted block a (s x s, row-major) in place along the
    /// fixed order, and its pivots' figures; None when a pivot is zero or
    /// not finite or a multiplier above MULTIPLIER (the order does not suit
    /// these values).
    #[inline]
    pub fn numeric(&self, a: &mut [f64]) -> Option<Pivots> {
        let s = self.s;
        for &(k, lo, hi) in &self.steps {
            let k = k as usize;
            let r = 1.0 / a[k * s + k];
            let right = &self.right[self.right_start[k] as usize..self.right_start[k + 1] as usize];
            for &(i, at) in &self.mult[lo as usize..hi as usize] {
                let l = a[at as usize] * r;
                if !(l.abs() <= MULTIPLIER) {
                    return None; // a zero or non-finite pivot too
                }
                a[at as usize] = l;
                if l != 0.0 {
                    let (i, k) = (i as usize * s, k * s);
                    for &j in right {
                        a[i + j as usize] -= l * a[k + j as usize];
                    }
                }
            }
        }
        let mut p = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det: self.parity };
        for k in 0..s {
            let d = a[k * s + k];
            if d == 0.0 || !d.is_finite() {
                return None;
            }
            if d < 0.0 {
                p.det = -p.det;
            }
            if self.real[k] {
                let x = d.abs();
                if x < p.small {
                    p.small = x;
                    p.at = self.col[k];
                }
                p.big = p.big.max(x);
            }
        }
        Some(p)
    }

    /// b <- A^-1 b (natural order in and out) from `numeric`'s factors; y: work (s).
    #[inline]
    pub fn solve(&self, a: &[f64], b: &mut [f64], y: &mut [f64]) {
        let s = self.s;
        for k in 0..s {
            y[k] = b[self.row[k]];
        }
        self.eliminate(a, y);
        for l in 0..s {
            b[self.col[l]] = y[l];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fixed_order_solves_and_gives_the_determinant() {
        // a slider-crank-like pattern: unit diagonal-ish entries and a few couplings
        let s = 6;
        let a: [[f64; 6]; 6] = [
            [1.0, 0.0, 0.3, -1.0, 0.0, 0.0],
            [0.0, 1.0, -0.2, 0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0, 0.0, 0.7],
            [0.0, 0.0, 0.0, 0.0, 1.0, -0.4],
            [0.0, 0.0, 0.0, 0.5, 0.8, 0.0],
        ];
        let rows: Vec<u64> = a.iter().map(|r| (0..s).filter(|&j| r[j] != 0.0).fold(0, |m, j| m | 1 << j)).collect();
        let unit: Vec<u64> =
            a.iter().map(|r| (0..s).filter(|&j| r[j].abs() == 1.0).fold(0, |m, j| m | 1 << j)).collect();
        let o = Order::new(s, &rows, &unit, &unit).unwrap();
        let mut p = vec![0.0; s * s];
        for i in 0..s {
            for j in 0..s {
                p[o.inv_row[i] * s + o.inv_col[j]] = a[i][j];
            }
        }
        let figures = o.numeric(&mut p).expect("the fixed order suits these values");
        let x = [1.0, -2.0, 0.5, 3.0, 0.25, -1.5];
        let mut b: Vec<f64> = (0..s).map(|i| (0..s).map(|j| a[i][j] * x[j]).sum()).collect();
        let mut y = vec![0.0; s];
        o.solve(&p, &mut b, &mut y);
        for i in 0..s {
            assert!((b[i] - x[i]).abs() < 1e-13, "{b:?}");
        }
        // det by the pivots against a dense elimination's
        let det: f64 = o.parity as f64 * (0..s).map(|k| p[k * s + k]).product::<f64>();
        let mut d = a.iter().flatten().copied().collect::<Vec<_>>();
        let mut piv = vec![0; s];
        crate::lu::dense_factor(&mut d, s, &mut piv);
        let swaps = (0..s).filter(|&j| piv[j] != j).count();
        let dense: f64 = (0..s).map(|k| d[k * s + k]).product::<f64>() * if swaps % 2 == 1 { -1.0 } else { 1.0 };
        assert!((det - dense).abs() < 1e-12 * dense.abs(), "{det} {dense}");
        // the figures taken during the elimination: the det's sign and the pivots' span
        assert_eq!(figures.det as f64, det.signum());
        let mags: Vec<f64> = (0..s).map(|k| p[k * s + k].abs()).collect();
        let (small, big) =
            (mags.iter().cloned().fold(f64::INFINITY, f64::min), mags.iter().cloned().fold(0.0, f64::max));
        assert_eq!((figures.small, figures.big), (small, big));
        assert_eq!(p[o.inv_col[figures.at] * (s + 1)].abs(), small);
        // a zero pivot rejects the order
        let mut z = vec![0.0; s * s];
        assert!(o.numeric(&mut z).is_none());
    }

    #[test]
    fn a_structurally_singular_pattern_has_no_order() {
        assert!(Order::new(2, &[0b01, 0b01], &[0, 0], &[0, 0]).is_none());
    }
}
