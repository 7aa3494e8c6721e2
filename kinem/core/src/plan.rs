//! What a model's plan computes once: the fixed pivot order of each small
//! block of J_s (crate::order), from the Jacobian's pattern and the entries
//! that are constant whatever the configuration; for one block of up to
//! MASK coordinates whose pattern decomposes (crate::decompose), its
//! block-triangular form (crate::triangular), each diagonal block with its
//! own fixed order.
use crate::decompose::{decompose, Kind};
use crate::families::At;
use crate::lu::{Layout, Shape, MASK};
use crate::model::Kin;
use crate::order::{Order, NONE};
use crate::triangular::{Diagonal, Triangular, NEGATE};
use num_complex::Complex64 as C64;

/// The Jacobian's values at a few arbitrary configurations and times:
/// (constant, unit) per entry: the same value at every one of them (a
/// constant of the formulation: +-1 of a joint, a gear's radii) and, for
/// those, whether the scaled value is +-1, and whether the value itself
/// (unscaled: the block-triangular factors are Phi_q's) is +1.
pub fn constant_entries(kin: &Kin, entry_scale: &[f64]) -> (Vec<bool>, Vec<bool>, Vec<bool>) {
    let (constant, unit, one, _) = constant_signs(kin, entry_scale);
    (constant, unit, one)
}

/// `constant_entries`, and whether the value (unscaled) is -1 (`negate`).
#[allow(clippy::type_complexity)]
pub fn constant_signs(kin: &Kin, entry_scale: &[f64]) -> (Vec<bool>, Vec<bool>, Vec<bool>, Vec<bool>) {
    let n = kin.n;
    let mut first: Option<Vec<f64>> = None;
    let mut constant = vec![true; kin.nnz];
    let mut values = vec![0.0; kin.nnz];
    let mut e = vec![C64::new(1.0, 0.0); n];
    for trial in 0..3 {
        let q: Vec<f64> = (0..n).map(|j| (1.7 * j as f64 + 0.9 * trial as f64 + 0.3).sin() * 2.0).collect();
        kin.rotate(&q, &mut e);
        kin.jac(&At { q: &q, e: &e, t: 0.31 + 0.77 * trial as f64 }, &mut values);
        match &first {
            None => first = Some(values.clone()),
            Some(v) => {
                for k in 0..kin.nnz {
                    constant[k] &= v[k] == values[k];
                }
            }
        }
    }
    let v = first.unwrap_or_default();
    let unit = (0..kin.nnz).map(|k| constant[k] && (v[k] * entry_scale[k]).abs() == 1.0).collect();
    let one = (0..kin.nnz).map(|k| constant[k] && v[k] == 1.0).collect();
    let minus = (0..kin.nnz).map(|k| constant[k] && v[k] == -1.0).collect();
    (constant, unit, one, minus)
}

/// The rows whose nu (= -Phi_t) is zero at a few arbitrary times: a
/// ground's, a joint's (not a driver's). Only a hint (`Program`'s quiet
/// positions are tested for zero at each solve).
pub fn still_rows(kin: &Kin) -> Vec<bool> {
    let mut still = vec![true; kin.m];
    let mut nu = vec![0.0; kin.m];
    for trial in 0..3 {
        kin.nu(0.31 + 0.77 * trial as f64, &mut nu);
        for (s, v) in still.iter_mut().zip(&nu) {
            *s &= *v == 0.0;
        }
    }
    still
}

/// Gives every block of up to MASK coordinates its fixed order (none where
/// the pattern is structurally singular: that block keeps partial pivoting);
/// one block that decomposes is laid out block-triangularly instead.
pub fn order_blocks(kin: &Kin, layout: &mut Layout) {
    let (constant, unit, one, minus) = constant_signs(kin, &layout.entry_scale);
    if triangulate_zero(layout, &constant, &unit, &one, &still_rows(kin), &kin.zero_entries()) {
        if let Shape::Triangular(t) = &mut layout.shape {
            negate(t, &minus);
        }
        return;
    }
    let Shape::Blocks { count, size, pad, patterns, .. } = &layout.shape else { return };
    let (count, s) = (*count, *size);
    if s > MASK || patterns.len() != count * s {
        return;
    }
    let (mut row_at, mut col_at) = (vec![crate::order::NONE; count * s], vec![crate::order::NONE; count * s]);
    for (i, &p) in layout.row_pos.iter().enumerate() {
        row_at[p] = i;
    }
    for (j, &p) in layout.col_pos.iter().enumerate() {
        col_at[p] = j;
    }
    let mut orders = Vec::with_capacity(count);
    for c in 0..count {
        let rows: Vec<u64> = (0..s).map(|i| patterns[c * s + i].0).collect();
        let (mut u, mut k) = (vec![0u64; s], vec![0u64; s]);
        for &e in &layout.by_block[layout.block_start[c]..layout.block_start[c + 1]] {
            let (_, r, col) = layout.at[e];
            if constant[e] {
                k[r] |= 1 << col;
                if unit[e] {
                    u[r] |= 1 << col;
                }
            }
        }
        for &p in pad.iter().filter(|&&p| p / s == c) {
            let i = p % s;
            u[i] |= 1 << i;
            k[i] |= 1 << i;
        }
        let mut order = Order::new(s, &rows, &u, &k);
        if let Some(o) = &mut order {
            let entries: Vec<(usize, usize)> = layout.by_block[layout.block_start[c]..layout.block_start[c + 1]]
                .iter()
                .map(|&e| (layout.at[e].1, layout.at[e].2))
                .collect();
            let pads: Vec<usize> = pad.iter().filter(|&&p| p / s == c).map(|&p| p % s).collect();
            o.fuse(
                &row_at[c * s..(c + 1) * s],
                &col_at[c * s..(c + 1) * s],
                &layout.scale,
                &layout.col_scale,
                &entries,
                &pads,
                &layout.real[c * s..(c + 1) * s],
            );
            let ids = &layout.by_block[layout.block_start[c]..layout.block_start[c + 1]];
            o.place =
                ids.iter().zip(&o.entry_at).map(|(&e, &at)| (e as u32, at as u32, layout.entry_scale[e])).collect();
        }
        orders.push(order);
    }
    if let Shape::Blocks { orders: o, .. } = &mut layout.shape {
        *o = orders;
    }
}

/// One block, square, without padding, whose pattern decomposes into two
/// blocks or more, none above MASK coordinates: laid out in its
/// block-triangular order (Shape::Triangular), each diagonal block's
/// positions in its fixed order. False (unchanged) otherwise, and where a
/// block has no fixed order (a greedy order can miss a structurally
/// nonsingular block's pivots). `one`: the entries whose value (unscaled)
/// looked +1 at every trial: a 1x1 block of one such entry is folded (no
/// division; each factorisation checks that it is still 1). Without
/// quiet positions (the tests').
#[cfg(test)]
pub(crate) fn triangulate(layout: &mut Layout, constant: &[bool], unit: &[bool], one: &[bool]) -> bool {
    triangulate_still(layout, constant, unit, one, &[])
}

/// `triangulate`, with `still`: the rows whose nu looked zero
/// (`still_rows`; none: no quiet positions in the solve's program).
#[cfg(test)]
pub(crate) fn triangulate_still(
    layout: &mut Layout,
    constant: &[bool],
    unit: &[bool],
    one: &[bool],
    still: &[bool],
) -> bool {
    triangulate_zero(layout, constant, unit, one, still, &[])
}

/// `triangulate_still`, with `zero`: the entries exactly zero at every
/// configuration (Kin::zero_entries; none: every entry may be nonzero),
/// which are no part of the structure: the blocks, their pivot orders,
/// the elimination and the solve's program are the pattern's without them
/// (their operations were products with a zero), so that a pin at the
/// ground's origin or at a point of it with the body's own origin is a
/// pair of 1x1 blocks, quiet (Triangular::program); each factorisation
/// whose values' Kin may not have them checks them
/// (Factoring::zero_entries, Factors::zeros_hold).
pub(crate) fn triangulate_zero(
    layout: &mut Layout,
    constant: &[bool],
    unit: &[bool],
    one: &[bool],
    still: &[bool],
    zero: &[bool],
) -> bool {
    let Shape::Blocks { count: 1, size, pad, patterns, .. } = &layout.shape else { return false };
    let (n, m) = (layout.n, layout.m);
    if !pad.is_empty() || n != m || *size != n || (n <= MASK && patterns.len() != n) {
        return false;
    }
    let (mut row_at, mut col_at) = (vec![NONE; n], vec![NONE; n]);
    for (i, &p) in layout.row_pos.iter().enumerate() {
        row_at[p] = i;
    }
    for (j, &p) in layout.col_pos.iter().enumerate() {
        col_at[p] = j;
    }
    let rows: Vec<usize> = layout.at.iter().map(|&(_, r, _)| row_at[r]).collect();
    let cols: Vec<usize> = layout.at.iter().map(|&(_, _, c)| col_at[c]).collect();
    // the exact zeros are no part of the structure the blocks are made of (checked instead: they
    // join Factoring::zero_entries below)
    let live: Vec<usize> = (0..rows.len()).filter(|&e| zero.get(e) != Some(&true)).collect();
    let (live_rows, live_cols): (Vec<usize>, Vec<usize>) = live.iter().map(|&e| (rows[e], cols[e])).unzip();
    let d = decompose(m, n, &live_rows, &live_cols);
    if d.kind != Kind::Exact || d.blocks.len() < 2 || d.blocks.iter().any(|b| b.cols.len() > MASK) {
        return false;
    }
    // each block's fixed order over its matched local indices (i: rows[i], cols[i])
    let (mut local_row, mut local_col) = (vec![0; m], vec![0; n]);
    let (mut block_of_row, mut block_of_col) = (vec![0; m], vec![0; n]);
    for (k, b) in d.blocks.iter().enumerate() {
        for (i, (&r, &c)) in b.rows.iter().zip(&b.cols).enumerate() {
            (local_row[r], local_col[c], block_of_row[r], block_of_col[c]) = (i, i, k, k);
        }
    }
    let mut inner: Vec<Vec<usize>> = vec![Vec::new(); d.blocks.len()]; // the entries inside each block
    for &e in &live {
        if block_of_row[rows[e]] == block_of_col[cols[e]] {
            inner[block_of_col[cols[e]]].push(e);
        }
    }
    let mut orders = Vec::with_capacity(d.blocks.len());
    for (k, b) in d.blocks.iter().enumerate() {
        let s = b.cols.len();
        if s == 1 {
            orders.push(None);
            continue;
        }
        let (mut pr, mut u, mut kk) = (vec![0u64; s], vec![0u64; s], vec![0u64; s]);
        for &e in &inner[k] {
            let (r, c) = (local_row[rows[e]], local_col[cols[e]]);
            pr[r] |= 1 << c;
            if constant[e] {
                kk[r] |= 1 << c;
                if unit[e] {
                    u[r] |= 1 << c;
                }
            }
        }
        let Some(mut o) = Order::new(s, &pr, &u, &kk) else { return false };
        let same: Vec<usize> = (0..s).collect();
        let local: Vec<(usize, usize)> = inner[k].iter().map(|&e| (local_row[rows[e]], local_col[cols[e]])).collect();
        o.fuse(&same, &same, &vec![1.0; s], &vec![1.0; s], &local, &[], &vec![true; s]);
        o.place =
            inner[k].iter().zip(&o.entry_at).map(|(&e, &at)| (e as u32, at as u32, layout.entry_scale[e])).collect();
        orders.push(Some(o));
    }
    // positions: block k's from start[k], in its order's steps (a 1x1 block: its pair)
    let (mut row_pos, mut col_pos) = (vec![0; m], vec![0; n]);
    let (mut blocks, mut at, mut store) = (Vec::new(), 0, n * n);
    for (k, (b, order)) in d.blocks.iter().zip(orders).enumerate() {
        let s = b.cols.len();
        for step in 0..s {
            let (i, j) = order.as_ref().map_or((step, step), |o| (o.row[step], o.col[step]));
            row_pos[b.rows[i]] = at + step;
            col_pos[b.cols[j]] = at + step;
        }
        let entries = if s == 1 { inner[k].iter().map(|&e| e as u32).collect() } else { Vec::new() };
        blocks.push(Diagonal { at, s, store, order, entries });
        at += s;
        store += s * s;
    }
    // the entries below the diagonal blocks, by the block of their row
    let mut off: Vec<(usize, u32, u32, u32)> = (live.iter().copied())
        .filter(|&e| block_of_row[rows[e]] != block_of_col[cols[e]])
        .map(|e| (block_of_row[rows[e]], row_pos[rows[e]] as u32, col_pos[cols[e]] as u32, e as u32))
        .collect();
    off.sort_by_key(|x| x.0);
    let place: Vec<(usize, usize, usize)> = off.iter().map(|x| (x.0, x.1 as usize, x.2 as usize)).collect();
    let folded: Vec<bool> = blocks.iter().map(|d| d.entries.len() == 1 && one[d.entries[0] as usize]).collect();
    let still: Vec<bool> = d.blocks.iter().map(|b| b.rows.len() == 1 && still.get(b.rows[0]) == Some(&true)).collect();
    let Ok(mut program) = Triangular::program(&blocks, &place, store, n, &folded, &still) else { return false };
    let off_entries: Vec<u32> = off.iter().map(|x| x.3).collect();
    let (mut gather, mut scatter) = (vec![0; n], vec![0; n]);
    for i in 0..n {
        gather[row_pos[i]] = i;
        scatter[col_pos[i]] = i;
    }
    let row_scale: Vec<f64> = gather.iter().map(|&i| layout.scale[i]).collect();
    let col_scale: Vec<f64> = scatter.iter().map(|&j| layout.col_scale[j]).collect();
    let Ok(mut factoring) =
        Triangular::factoring(&blocks, &off_entries, store, layout.at.len(), &folded, &row_scale, &col_scale)
    else {
        return false;
    };
    // the exact zeros, checked where the values' Kin may not have them (Factors::zeros_hold)
    factoring.zero_entries = (0..rows.len()).filter(|&e| zero.get(e) == Some(&true)).map(|e| e as u32).collect();
    program.renumber(&scatter); // the solve runs in the coordinates (Triangular::run)
    let t = Triangular {
        blocks,
        off_entries,
        off_at: store,
        program,
        factoring,
        into: (0..n).map(|i| scatter[row_pos[i]] as u32).collect(),
        sign: crate::order::parity(&gather) * crate::order::parity(&scatter),
        gather,
        scatter,
        whole_row: layout.row_pos.clone(),
        whole_col: layout.col_pos.clone(),
        whole_entries: (layout.at.iter().enumerate())
            .map(|(e, &(_, r, c))| (e as u32, (r * n + c) as u32, layout.entry_scale[e]))
            .collect(),
        whole_patterns: patterns.clone(),
        whole_sign: layout.sign,
        whole_to_pos: (0..n).map(|p| col_pos[col_at[p]]).collect(),
    };
    if t.check().is_err() {
        return false;
    }
    layout.row_pos = row_pos;
    layout.col_pos = col_pos;
    layout.shape = Shape::Triangular(Box::new(t));
    true
}

/// Marks the solve's divisions by a constant -1 (`minus`: per Jacobian
/// entry, its value looked -1 at every trial) with triangular::NEGATE: a
/// pivot placed from one such entry alone and written by no step of the
/// elimination (a revolute's -1 on the coordinate it solves, a 1x1 block or
/// a pivot of a larger block's order taken before any update reaches it).
/// Those entries join Factoring::minus_entries, checked at each
/// factorisation (a variant on the nominal's layout whose entry is not -1:
/// the fallback takes it).
pub(crate) fn negate(t: &mut Triangular, minus: &[bool]) {
    let f = &mut t.factoring;
    let (mut placed, mut from, mut written) = (vec![0u32; f.values], vec![0u32; f.values], vec![false; f.values]);
    for &[e, at] in &f.place {
        placed[at as usize] += 1;
        from[at as usize] = e;
    }
    for &at in f.clear.iter().chain(f.ones.iter()).chain(f.mults.iter().map(|m| &m[0])) {
        written[at as usize] = true;
    }
    for &[dst, _] in &f.pairs {
        written[dst as usize] = true;
    }
    // a division's value is its position's reciprocal (Factoring::recip_at): its pivot is that position's
    let pivot = |r: u32| f.diag.get((r as usize).wrapping_sub(f.recip_at as usize)).map(|&v| v as usize);
    let eligible =
        |v: usize| v < placed.len() && placed[v] == 1 && !written[v] && minus.get(from[v] as usize) == Some(&true);
    let (mut entries, mut negated, mut recips) = (Vec::new(), Vec::new(), Vec::new());
    for d in t.program.divs.iter_mut().chain(t.program.short.1.iter_mut()) {
        if let Some(v) = pivot(d[2]).filter(|&v| eligible(v)) {
            entries.push(from[v]);
            negated.push(v as u32);
            recips.push(d[2]);
            d[2] |= NEGATE;
        }
    }
    t.program.lay();
    for list in [&mut negated, &mut entries, &mut recips] {
        list.sort_unstable();
        list.dedup();
    }
    f.minus_entries = entries;
    // their reciprocals are -1, set once (Factoring::init), not computed
    f.recips.retain(|r| !recips.contains(&r[1]));
    f.minus_recips = recips;
    // their pivots' figures are constant (|-1| c_p / r_p, each a det flip): folded as the ones' are
    let minus_at = negated;
    let (mut small, mut big, mut first) = (f.ones_small, f.ones_big, f.first_one as usize);
    for (p, at) in f.diag.iter().enumerate() {
        if minus_at.contains(at) {
            let x = f.pivot_scale[p];
            if x < small || (x == small && p < first) {
                (small, first) = (x, p);
            }
            big = big.max(x);
        }
    }
    (f.ones_small, f.ones_big, f.first_one) = (small, big, first as u32);
    f.free.retain(|&(at, _, _)| !minus_at.contains(&at));
    // a larger block's elimination step on such a pivot: 1 / -1 without the division
    for step in f.steps.iter_mut().filter(|s| minus_at.contains(&s[0])) {
        step[0] |= NEGATE;
        f.negated_steps = true;
    }
    f.minus_odd = minus_at.len() % 2 == 1;
}

/// One block of a square pattern (rows, cols per entry) in the model's
/// order, as kinem.model.Model.plan lays it out (tests: plan's and the fuzz test's).
#[cfg(test)]
pub(crate) fn one_block(n: usize, rows: &[usize], cols: &[usize], scale: Vec<f64>, col_scale: Vec<f64>) -> Layout {
    let mut patterns = vec![(0u64, 0u64); n];
    for (&r, &c) in rows.iter().zip(cols) {
        patterns[r].0 |= 1 << c;
        patterns[c].1 |= 1 << r;
    }
    let mut l = Layout {
        shape: Shape::Blocks { count: 1, size: n, pad: Vec::new(), patterns, orders: Vec::new() },
        n,
        m: n,
        height: n,
        width: n,
        count: 1,
        at: rows.iter().zip(cols).map(|(&r, &c)| (0, r, c)).collect(),
        entry_scale: Vec::new(),
        row_pos: (0..n).collect(),
        col_pos: (0..n).collect(),
        real: vec![true; n],
        sign: 1,
        scale,
        col_scale,
        by_block: Vec::new(),
        block_start: Vec::new(),
    };
    l.entry_scale = rows.iter().zip(cols).map(|(&r, &c)| l.col_scale[c] / l.scale[r]).collect();
    l.group();
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decompose::tests::slider_crank;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// One block of the whole pattern in the model's order, as kinem.model.Model.plan lays it out
    fn one_block(n: usize, rows: &[usize], cols: &[usize]) -> Layout {
        let scale = (0..n).map(|i| 1.0 + 0.1 * i as f64).collect();
        let col_scale = (0..n).map(|j| 2.0 - 0.05 * j as f64).collect();
        super::one_block(n, rows, cols, scale, col_scale)
    }

    fn dense(n: usize, rows: &[usize], cols: &[usize], values: &[f64]) -> Vec<f64> {
        let mut a = vec![0.0; n * n];
        for e in 0..values.len() {
            a[rows[e] * n + cols[e]] = values[e];
        }
        a
    }

    #[test]
    fn the_block_triangular_layout_solves_and_falls_back_to_partial_pivoting() {
        let (rows, cols) = slider_crank();
        let n = 12;
        let plain = one_block(n, &rows, &cols);
        let mut tri = plain.clone();
        let constant: Vec<bool> = rows.iter().map(|&r| r < 3).collect();
        let none = vec![false; rows.len()];
        assert!(triangulate(&mut tri, &constant, &constant, &none), "the slider-crank decomposes");
        let Shape::Triangular(t) = &tri.shape else { panic!("not triangular") };
        let sizes: Vec<usize> = t.blocks.iter().map(|d| d.s).collect();
        assert_eq!(sizes, vec![1, 1, 1, 1, 1, 1, 1, 5]);
        let mut seed = 3u64;
        let (mut fell, mut fixed) = (0, 0);
        for trial in 0..200 {
            let mut values: Vec<f64> = rows.iter().map(|_| lcg(&mut seed)).collect();
            for (e, v) in values.iter_mut().enumerate() {
                if rows[e] < 3 || rows[e] == 11 {
                    *v = 1.0; // ground and driver rows: unit entries
                }
            }
            if trial % 4 == 0 {
                // a nearly singular loop: the blocks' pivots span more than FALLBACK
                for (e, v) in values.iter_mut().enumerate() {
                    if rows[e] == 9 {
                        *v *= 1e-5;
                    }
                }
            }
            let a = dense(n, &rows, &cols, &values);
            let x0: Vec<f64> = (0..n).map(|_| lcg(&mut seed)).collect();
            let b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x0[j]).sum()).collect();
            let (mut ft, mut fp) = (tri.factors(), plain.factors());
            tri.factor(&values, &mut ft);
            plain.factor(&values, &mut fp);
            let (mut xt, mut xp) = (vec![0.0; n], vec![0.0; n]);
            tri.solve(&mut ft, &b, &mut xt);
            plain.solve(&mut fp, &b, &mut xp);
            let (st, sp) = (tri.stats(&ft), plain.stats(&fp));
            let mut d = a.clone();
            let mut piv = vec![0; n];
            crate::lu::dense_factor(&mut d, n, &mut piv);
            let swaps = (0..n).filter(|&j| piv[j] != j).count() as i32;
            let det = (0..n).map(|k| d[k * n + k]).product::<f64>() * if swaps % 2 == 1 { -1.0 } else { 1.0 };
            if det.abs() < 1e-12 {
                continue;
            }
            assert_eq!(st.1 as f64, det.signum(), "trial {trial}: det sign");
            let ratio = sp.0.min(st.0);
            let err = xt.iter().zip(&x0).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
            assert!(err < 1e-9 / ratio.max(1e-6), "trial {trial}: error {err}");
            if ft.fixed[0].is_none() {
                // the fallback is the whole matrix's partial pivoting in the model's order: the same figures and solve
                assert_eq!((st.0.to_bits(), st.1), (sp.0.to_bits(), sp.1), "trial {trial}");
                assert!(xt.iter().zip(&xp).all(|(u, v)| u.to_bits() == v.to_bits()), "trial {trial}");
                fell += 1;
            } else {
                assert!(st.0 >= crate::lu::FALLBACK && trial % 4 != 0, "trial {trial}: {}", st.0);
                fixed += 1;
            }
        }
        assert!(fell >= 40 && fixed >= 40, "both paths taken: {fell} fallbacks, {fixed} in the blocks' orders");
    }
}

#[cfg(test)]
#[path = "fuzz.rs"]
mod fuzz;
